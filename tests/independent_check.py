"""An independent check of the grasps synth returns. It shares no code with synth.

It reads the mesh file itself with trimesh (every object of an OBJ, every connected piece of
every mesh), and for each grasp of a ``synth.grasps`` document checks that

1. every contact lies on the surface of the file's mesh (an exact point-triangle distance),
   and on its exposed part: a step of ``STEP_RTOL`` times the part's size from the contact
   towards its fingertip's centre (along the outward normal for a fingertip with one contact)
   lands outside every closed piece (trimesh's signed distance);
2. the file's own normal at every contact: the normal of the triangle it lies in (the faces
   within the on-surface tolerance of it, except those buried in another closed piece
   beside it, all coplanar); on an edge or at a vertex (touched faces not coplanar) the
   reported normal, which must lie in the cone of the touched faces' inward normals. The
   reported smooth normals point into every touched face and lie in the cone of the touched
   faces and the faces around them (sharing a corner), as an interpolated normal does;
3. d* solved again as a plain scipy LP (Trinkle 1992, LP (12)-(15) with the box
   -1 <= c <= 1; with friction its Section II.B test, written with free tangential
   intensities and polygon facets) with the file's own normals equals the reported
   ``d_star_mesh``, with the reported smooth normals equals ``d_star_smooth``, and the
   reported ``d_star`` is the one of the surface model (``params.surface``: the smaller of the
   two for ``both``). Unless the model is ``smooth``, a grasp reported as form closure is form
   closure with the file's own normals (positive d*, full rank);
4. every fingertip touches its contacts and, with every finger body (a capsule along the
   approach direction), stays outside every closed piece and off every surface (trimesh's
   signed distance; open pieces by unsigned distance), and fingertips do not overlap. A tip
   may sink ``PENETRATION`` of its radius into the surface, nothing more (tips are seated on
   the facets), and the reported ``tip_sink`` is the depth measured here to within that.

``check_document(path, doc)`` returns a list of readable failures (empty when all pass).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from scipy.optimize import linprog, nnls

STEP_RTOL = 2e-3  # the exposure step of the project's domain notes
PENETRATION = 2e-3  # fraction of a radius a finger may sink in (synth allows 1e-3)
D_STAR_ATOL = 1e-6
RANK_RTOL = 1e-6


def point_triangle_distance(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Exact distances (n,) from points p (n, 3) to triangles tri (n, 3, 3): the projection on
    the plane when it falls inside (signed areas), else the nearest of the three edges.

    (trimesh's closest-point kernel compares against an absolute zero and, for small
    triangles far from the origin, answers with a vertex although the point lies inside.)
    """
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n /= np.maximum(norm, 1e-300)
    h = np.einsum("ij,ij->i", p - a, n)
    q = p - h[:, None] * n
    inside = norm[:, 0] > 0  # a triangle without area is its edges
    best = np.full(len(p), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, q - u), n) >= 0
        e = v - u
        t = np.clip(np.einsum("ij,ij->i", p - u, e) / np.maximum(np.einsum("ij,ij->i", e, e),
                                                                 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(u + t[:, None] * e - p, axis=1))
    return np.where(inside, np.abs(h), best)


def _decimal_quantum(path: Path) -> float:
    """The last decimal a text mesh file writes its coordinates with (0 for binary files)."""
    if path.suffix.lower() != ".obj":
        return 0.0
    decimals = 0
    for line in path.read_text(errors="replace").splitlines():
        if line.startswith("v "):
            for word in line.split()[1:4]:
                if "." in word and "e" not in word.lower():
                    decimals = max(decimals, len(word.split(".")[1]))
    return 10.0**-decimals if decimals else 0.0


class Pieces:
    """The file's geometry: every piece, the closed ones for inside tests."""

    def __init__(self, path: str | Path) -> None:
        path = Path(path)
        kw = {"split_objects": True, "group_material": False} if path.suffix.lower() == ".obj" \
            else {}
        loaded = trimesh.load(str(path), process=False, **kw)
        geoms = loaded.dump() if isinstance(loaded, trimesh.Scene) else [loaded]
        # trimesh merges corners closer than an absolute 1e-8: done on a copy of unit size
        # (a part of side 1e-9 would merge into a point), then put back where the file has it
        allv = np.vstack([np.asarray(g.vertices, float) for g in geoms])
        o = (allv.min(axis=0) + allv.max(axis=0)) / 2
        s = float(np.linalg.norm(allv.max(axis=0) - allv.min(axis=0))) or 1.0
        pieces = []
        for g in geoms:
            g = trimesh.Trimesh((np.asarray(g.vertices, float) - o) / s, g.faces, process=True)
            for q in (g.split(only_watertight=False, repair=False) if len(g.faces) > 1
                      else [g]):
                pieces.append(trimesh.Trimesh(np.asarray(q.vertices) * s + o, q.faces,
                                              process=False))
        self.surface = trimesh.util.concatenate(pieces)
        lo, hi = self.surface.bounds
        self.length = float(np.linalg.norm(hi - lo))
        # trimesh's proximity and inside tests use absolute tolerances: they are asked about
        # a copy of the part centred and of unit size
        self._o, self._s = (lo + hi) / 2, self.length

        def unit(m: trimesh.Trimesh) -> trimesh.Trimesh:
            return trimesh.Trimesh((m.vertices - self._o) / self._s, m.faces, process=False)

        self.closed = []
        for p in pieces:
            with np.errstate(invalid="ignore", divide="ignore"):
                solid = p.is_watertight and abs(p.volume) > 1e-9 * self.length**3
            if solid:
                p = unit(p)
                trimesh.repair.fix_normals(p)
                self.closed.append(p)
        self._unit_surface = unit(self.surface)
        v = np.asarray(self.surface.vertices, float)
        top = float(np.abs(v).max())
        # on the surface, and on a face, an edge or a corner, within what the file's numbers
        # can tell apart: coordinates written with d decimals are off by up to half the last
        # one each, float32 ones by half an ulp of the largest, so a point two of those from
        # an edge may lie on it (synth's documented feature tolerance is four halves too)
        f32 = bool(np.all(v.astype(np.float32).astype(np.float64) == v))
        ulp = 2.0**-23 * top if f32 else 0.0
        self.tol = 1e-6 * self.length + 1e-9 * top + 2.0 * max(_decimal_quantum(path), ulp)
        self.normals = np.asarray(self._unit_surface.face_normals, float)  # (any size)
        self.tri = np.asarray(self.surface.triangles, float)
        # trimesh's kernel can misjudge points near triangles of area below ~1e-6 (absolute)
        edges = np.linalg.norm(self.tri - np.roll(self.tri, 1, axis=1), axis=2).max(axis=1)
        small = self._unit_surface.area_faces < 1e-5
        self.small_edge = float(edges[small].max()) if small.any() else 0.0

    def inside_depth(self, pts: np.ndarray) -> np.ndarray:
        """Largest trimesh signed distance over the closed pieces (> 0: inside one)."""
        depth = np.full(len(pts), -np.inf)
        unit = (pts - self._o) / self._s
        for p in self.closed:
            lo, hi = p.bounds
            near = np.all((unit >= lo - 0.1) & (unit <= hi + 0.1), axis=1)
            if near.any():
                sd = trimesh.proximity.signed_distance(p, unit[near]) * self._s
                depth[near] = np.maximum(depth[near], sd)
        return depth

    def distance(self, pts: np.ndarray, below: float | None = None) -> np.ndarray:
        """Unsigned distance to the surface of every piece, exact wherever it may be less
        than ``below`` (everywhere by default).

        trimesh's closest point gives an upper bound that is off by at most the size of the
        small triangles it misjudges; where that bound could hide a distance below ``below``,
        the faces whose boxes come that close are measured exactly."""
        unit = (pts - self._o) / self._s
        upper = trimesh.proximity.closest_point(self._unit_surface, unit)[1] * self._s
        out = upper.copy()
        rows = np.arange(len(pts)) if below is None else np.flatnonzero(
            upper <= below + self.small_edge)
        if not len(rows):
            return out
        tree = self.surface.triangles_tree
        pad = upper[rows, None] * (1 + 1e-9) + 1e-12 * self.length
        boxes = np.hstack([pts[rows] - pad, pts[rows] + pad])
        cand = [np.fromiter(tree.intersection(b), np.int64) for b in boxes]
        counts = np.array([len(c) for c in cand])
        owner = np.repeat(np.arange(len(rows)), counts)
        d = point_triangle_distance(self.tri[np.concatenate(cand)], pts[rows][owner])
        best = np.full(len(rows), np.inf)
        np.minimum.at(best, owner, d)
        out[rows] = np.minimum(upper[rows], best)
        return out

    def touched(self, p: np.ndarray) -> np.ndarray:
        """Faces (with an area, so a normal) within the on-surface tolerance of the point and
        not buried in another closed piece beside it: some point of the face a step from
        ``p`` (towards its centroid or one of its corners), stepped out along the face's
        normal, is outside every closed piece (a piece that overlaps another has faces inside
        it that reach the other's surface only along a seam; a finger cannot touch them)."""
        d = point_triangle_distance(self.tri, np.broadcast_to(p, (len(self.tri), 3)))
        faces = np.flatnonzero((d <= self.tol) & (np.linalg.norm(self.normals, axis=1) > 0.5))
        step = STEP_RTOL * self.length
        tri = self.tri[faces]
        toward = np.concatenate([tri.mean(axis=1, keepdims=True), tri], axis=1) - p  # (f, 4, 3)
        far = np.linalg.norm(toward, axis=2, keepdims=True)
        q = p + toward / np.maximum(far, 1e-300) * np.minimum(step, far / 2)
        q += step * self.normals[faces][:, None, :]
        out = self.inside_depth(q.reshape(-1, 3)).reshape(len(faces), 4) < 0
        return faces[out.any(axis=1)]

    def normal_cone(self, faces: np.ndarray) -> np.ndarray:
        """Inward normals of the touched faces and of the faces sharing a corner with them."""
        ring = np.flatnonzero(np.isin(self.surface.faces, self.surface.faces[faces]).any(1))
        return -self.normals[np.union1d(faces, ring)]


def lp_d_star(points: np.ndarray, normals: np.ndarray) -> tuple[float, int]:
    """Trinkle's d* by scipy's linprog, and the rank of the wrench matrix."""
    k = len(points)
    r = points - points.mean(axis=0)
    scale = np.linalg.norm(r, axis=1).max() or 1.0
    W = np.vstack([normals.T, np.cross(r / scale, normals).T])  # moments scaled: same null space
    cost = np.r_[np.zeros(k), -1.0]
    A_eq = np.hstack([W, np.zeros((6, 1))])
    A_ub = np.hstack([-np.eye(k), np.ones((k, 1))])  # d - c_i <= 0
    res = linprog(cost, A_ub=A_ub, b_ub=np.zeros(k), A_eq=A_eq, b_eq=np.zeros(6),
                  bounds=[(-1, 1)] * k + [(None, None)], method="highs")
    s = np.linalg.svd(W, compute_uv=False)
    rank = int(np.sum(s > RANK_RTOL * s[0]))
    return max(0.0, float(-res.fun)), rank


def lp_frictional_d_star(points: np.ndarray, normals: np.ndarray, mu: float, edges: int
                         ) -> float:
    """Trinkle's frictional d* by scipy's linprog, written with free tangential intensities
    and the inscribed polygon's facets: cos(th) t_u + sin(th) t_v <= mu cos(pi/E) c_n."""
    n = len(points)
    helper = np.where(np.abs(normals[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    u = np.cross(normals, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(normals, u)
    r = points - points.mean(axis=0)
    scale = np.linalg.norm(r, axis=1).max() or 1.0
    W = np.hstack([np.concatenate([d, np.cross(r / scale, d)], axis=1).T for d in (normals, u, v)])
    th = (2 * np.arange(edges) + 1) * np.pi / edges
    rows = []
    for i in range(n):
        for t in th:
            row = np.zeros(3 * n + 1)
            row[i], row[n + i], row[2 * n + i] = -mu * np.cos(np.pi / edges), np.cos(t), np.sin(t)
            rows.append(row)
        row = np.zeros(3 * n + 1)
        row[i], row[-1] = -1.0, 1.0
        rows.append(row)
    cost = np.zeros(3 * n + 1)
    cost[-1] = -1.0
    res = linprog(cost, A_ub=np.array(rows), b_ub=np.zeros(len(rows)),
                  A_eq=np.hstack([W, np.zeros((6, 1))]), b_eq=np.zeros(6),
                  bounds=[(0, 1)] * n + [(None, None)] * (2 * n) + [(0, 1)], method="highs")
    return max(0.0, float(-res.fun))


def _in_cone(n: np.ndarray, cone: np.ndarray) -> bool:
    lam, resid = nnls(cone.T, n)
    return bool(resid <= 1e-6 and lam.sum() > 0)


def _lp(points: np.ndarray, normals: np.ndarray, mu: float, edges: int) -> tuple[float, int]:
    """d* (frictional with mu > 0) and the rank of the frictionless wrench matrix."""
    d, rank = lp_d_star(points, normals)
    if mu > 0:
        d = lp_frictional_d_star(points, normals, mu, edges)
        d = d if d > 1e-9 else 0.0
    return d, rank


def check_grasp(pieces: Pieces, g: dict, mu: float = 0.0, edges: int = 8,
                surface: str = "both") -> list[str]:
    """Failures of one grasp (a dict of a synth.grasps document) planned with friction
    coefficient ``mu``, ``edges`` cone edges and the surface model ``surface``."""
    out: list[str] = []
    P = np.asarray(g["points"], float)
    N = np.asarray(g["normals"], float)
    S = np.asarray(g.get("smooth_normals", g["normals"]), float)
    L = pieces.length
    for name, arr in (("normals", N), ("smooth normals", S)):
        if not np.allclose(np.linalg.norm(arr, axis=1), 1.0, atol=1e-9):
            out.append(f"{name} are not unit vectors")
    dist = pieces.distance(P)
    for j in np.flatnonzero(dist > pieces.tol):
        out.append(f"contact {j} is {dist[j]:.3g} off the surface (tolerance {pieces.tol:.3g})")
    f = g["fingers"]
    C = np.asarray(f["tip_centers"], float)
    cf = np.asarray(f.get("contact_finger", range(len(P))), int)
    toward = C[cf] - P
    toward /= np.linalg.norm(toward, axis=1, keepdims=True)
    depth = pieces.inside_depth(P + STEP_RTOL * L * toward)
    for j in np.flatnonzero(depth >= 0):
        out.append(f"contact {j} is not exposed: a step outward lands inside a closed piece")
    own = N.copy()  # the file's own normal at each contact
    for j, (p, n, sm) in enumerate(zip(P, N, S, strict=True)):
        faces = pieces.touched(p)
        if not len(faces):
            continue
        inward = -pieces.normals[faces]
        if np.all(inward @ inward[0] >= np.cos(1e-6)):  # inside one facet (or coplanar ones)
            own[j] = inward[0] / np.linalg.norm(inward[0])
        elif np.any(inward @ n <= 0) or not _in_cone(n, inward):
            out.append(f"contact {j}: normal {np.round(n, 4).tolist()} is outside the normal "
                       "cone of the faces it touches")
        if np.any(inward @ sm <= 0) or not _in_cone(sm, pieces.normal_cone(faces)):
            out.append(f"contact {j}: smooth normal {np.round(sm, 4).tolist()} is outside the "
                       "normal cone of the faces it touches and those around them")
    d_mesh, rank_mesh = _lp(P, own, mu, edges)
    d_smooth, rank_smooth = _lp(P, S, mu, edges)
    d_model = {"mesh": d_mesh, "smooth": d_smooth}.get(surface, min(d_mesh, d_smooth))
    for name, got, want in (("d*", g["d_star"], d_model),
                            ("d_star_mesh", g.get("d_star_mesh", g["d_star"]), d_mesh),
                            ("d_star_smooth", g.get("d_star_smooth", g["d_star"]), d_smooth)):
        if abs(want - got) > D_STAR_ATOL:
            out.append(f"{name} reported {got:.9f}, scipy LP gives {want:.9f}")
    holds = [(d_mesh, rank_mesh, "the file's own normals")] if surface != "smooth" else []
    if surface != "mesh":
        holds.append((d_smooth, rank_smooth, "the smooth normals"))
    for d, rank, what in holds:
        if g["closure"] == "form" and (rank < 6 or d <= 1e-9):
            out.append(f"reported form closure, but with {what} rank {rank} and LP d* {d:.3g}")
        if g["closure"] == "frictional form" and d <= 1e-9:
            out.append(f"reported frictional form closure, but with {what} the frictional LP "
                       f"gives {d:.3g}")
    A = np.asarray(f["approach"], float)
    r, rb, lb = float(f["tip_radius"]), float(f["body_radius"]), float(f["body_length"])
    gap = np.abs(np.linalg.norm(P - C[cf], axis=1) - r)
    for j in np.flatnonzero(gap > 1e-2 * r):
        out.append(f"contact {j} is {gap[j]:.3g} off its fingertip's sphere")
    for i in range(len(C)):
        for k in range(i + 1, len(C)):
            if np.linalg.norm(C[i] - C[k]) < 2 * r * (1 - PENETRATION):
                out.append(f"fingertips {i} and {k} overlap")
    if (d_tip := pieces.inside_depth(C)).max() >= 0:
        out.append(f"fingertip {int(np.argmax(d_tip))} centre is inside a closed piece")
    near = pieces.distance(C, below=r)
    for i in np.flatnonzero(near < r * (1 - PENETRATION)):
        out.append(f"fingertip {i} sinks {r - near[i]:.3g} into the surface (allowed "
                   f"{r * PENETRATION:.3g})")
    if "tip_sink" in f and abs(float(f["tip_sink"]) - max(0.0, float(r - near.min()))) > \
            r * PENETRATION:
        out.append(f"tip_sink reported {f['tip_sink']:.3g}, measured {r - near.min():.3g}")
    if lb > 0:
        t = np.linspace(0.0, 1.0, max(2, int(np.ceil(20 * lb / rb)) + 1))
        axis = C[:, None, :] + (lb * t)[None, :, None] * A[:, None, :]
        pts = axis.reshape(-1, 3)
        inside = pieces.inside_depth(pts).reshape(len(C), -1)
        dd = pieces.distance(pts, below=rb).reshape(len(C), -1)
        for i in range(len(C)):
            if inside[i].max() >= 0:
                out.append(f"finger {i} body passes through a closed piece")
            elif dd[i].min() < rb * (1 - PENETRATION) - 0.5 * lb / (len(t) - 1):
                out.append(f"finger {i} body comes {dd[i].min():.3g} from the surface "
                           f"(body radius {rb:.3g})")
    return out


def check_document(path: str | Path, doc: dict, pieces: Pieces | None = None) -> list[str]:
    """Failures of every grasp of a ``synth.grasps`` document planned on ``path``."""
    pieces = pieces or Pieces(path)
    mu = float(doc.get("params", {}).get("mu", 0.0))
    edges = int(doc.get("params", {}).get("edges", 8))
    surface = str(doc.get("params", {}).get("surface", "smooth"))
    out = []
    for i, g in enumerate(doc["grasps"]):
        out.extend(f"grasp {i + 1}: {msg}" for msg in check_grasp(pieces, g, mu, edges,
                                                                   surface))
    return out
