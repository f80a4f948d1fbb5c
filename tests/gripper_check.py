"""An independent check of gripper grasps, sharing no code with synth.

From a grasp file's JSON, the part's mesh file and the gripper's description file only, with
numpy, scipy's NNLS and trimesh (to read files): the pose is a rigid transform; both contacts
lie on the part's surface (exact point-triangle distance) and outside it just beyond (winding
number), and on their pads (or, a pad resting across a groove, on the groove's bottom under
it: the part meets the pad's plane at two opposite sides of the pad); each normal is its pad's or, for a contact on the pad's rim, the
inward normal of a triangle through the point or, where the rim crosses an edge of the part,
a normal perpendicular to the rim between those of the triangles through the point; the line
between them lies inside both friction cones; the posed gripper's shapes, the fingers opened by ``clear`` on each side, do not intersect the part (an exact
triangle-triangle separating-axis test, so crossing edges count, not only vertices) and no
shape lies inside it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import scipy.optimize
import trimesh


def gripper_shapes(description: Path, width: float, scale: float) -> list[tuple[np.ndarray,
                                                                                np.ndarray]]:
    """The gripper's shapes (vertices in its frame, faces) at ``width``, built from the file."""
    doc = json.loads(description.read_text())
    out = []

    def shape(item: dict) -> tuple[np.ndarray, np.ndarray]:
        if "box" in item:
            b = trimesh.creation.box(extents=item["box"]["size"])
            return np.asarray(b.vertices) + item["box"]["center"], np.asarray(b.faces)
        m = trimesh.load(description.parent / item["mesh"], force="mesh")
        a = math.radians(item.get("rotate_z_deg", 0.0))
        R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
        return np.asarray(m.vertices) @ R.T + item.get("offset", [0, 0, 0]), np.asarray(m.faces)

    fz = np.array(doc.get("finger_z", [[0, 0], [1, 0]]), float)
    rise = float(np.interp(width / scale, fz[:, 0], fz[:, 1]))
    for item in doc["palm"]:
        V, F = shape(item)
        out.append((V * scale, F))
    for flip in (1.0, -1.0):
        for item in doc["finger"]:
            V, F = shape(item)
            V = V + [width / scale / 2, 0, rise]
            out.append((V * [flip, flip, 1] * scale, F))
    return out


def pad_of(description: Path, width: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Pad rectangle centre (y, z) and size at ``width``, in the part's unit."""
    doc = json.loads(description.read_text())
    fz = np.array(doc.get("finger_z", [[0, 0], [1, 0]]), float)
    rise = float(np.interp(width / scale, fz[:, 0], fz[:, 1]))
    c = np.array(doc["pad"]["center"], float) + [0, rise]
    return c * scale, np.array(doc["pad"]["size"], float) * scale


def point_triangle_distance(p: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Exact distance from point ``p`` (3,) to each triangle of ``T`` (n, 3, 3)."""
    a, b, c = T[:, 0], T[:, 1], T[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    ok = nn > 0
    t = np.einsum("ij,ij->i", p - a, n) / np.where(ok, nn, 1)
    q = p - t[:, None] * n  # projection on the plane
    inside = ok.copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, q - u), n) >= 0
    best = np.where(inside, np.linalg.norm(p - q, axis=1), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        e = v - u
        s = np.clip(np.einsum("ij,ij->i", p - u, e) / np.maximum(np.einsum("ij,ij->i", e, e),
                                                                  1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (u + s[:, None] * e), axis=1))
    return best


def winding_number(points: np.ndarray, V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Generalised winding number of each point (1 inside a closed outward-wound body)."""
    out = np.zeros(len(points))
    for i, p in enumerate(points):
        a, b, c = (V[F[:, k]] - p for k in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la \
            + np.einsum("ij,ij->i", c, a) * lb
        out[i] = np.arctan2(num, den).sum() / (2 * np.pi)
    return out


def _project(T: np.ndarray, axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.einsum("nkj,nj->nk", T, axes)
    return d.min(1), d.max(1)


def triangles_intersect(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Exact separating-axis test for pairs of triangles ``A``, ``B`` (n, 3, 3): True where
    they intersect (touching counts as intersecting)."""
    ea = np.stack([A[:, 1] - A[:, 0], A[:, 2] - A[:, 1], A[:, 0] - A[:, 2]], 1)
    eb = np.stack([B[:, 1] - B[:, 0], B[:, 2] - B[:, 1], B[:, 0] - B[:, 2]], 1)
    axes = [np.cross(ea[:, 0], ea[:, 1]), np.cross(eb[:, 0], eb[:, 1])]
    axes += [np.cross(ea[:, i], eb[:, j]) for i in range(3) for j in range(3)]
    hit = np.ones(len(A), bool)
    for ax in axes:
        usable = np.einsum("ij,ij->i", ax, ax) > 1e-30
        a0, a1 = _project(A, ax)
        b0, b1 = _project(B, ax)
        separated = usable & ((a1 < b0) | (b1 < a0))
        hit &= ~separated
    # coplanar triangles would also need in-plane edge normals; the pairs here are not
    # coplanar except where a pad lies on a face, which the clearance keeps apart
    return hit


def meshes_intersect(VA: np.ndarray, FA: np.ndarray, VB: np.ndarray, FB: np.ndarray) -> bool:
    """Whether two triangle meshes have an intersecting pair of triangles."""
    TA, TB = VA[FA], VB[FB]
    lo, hi = VA.min(0), VA.max(0)
    near = np.all((TB.max(1) >= lo) & (TB.min(1) <= hi), axis=1)
    TB = TB[near]
    if not len(TB):
        return False
    alo, ahi = TA.min(1), TA.max(1)
    blo, bhi = TB.min(1), TB.max(1)
    for i in range(0, len(TA), 64):
        ov = np.all((ahi[i:i + 64, None] >= blo[None]) & (alo[i:i + 64, None] <= bhi[None]),
                    axis=2)
        ia, ib = np.nonzero(ov)
        if len(ia) and triangles_intersect(TA[i:i + 64][ia], TB[ib]).any():
            return True
    return False


def _groove(part: trimesh.Trimesh, R: np.ndarray, t: np.ndarray, plane: float, sgn: float,
            pc: np.ndarray, ps: np.ndarray, g: np.ndarray, behind: float, tol: float) -> bool:
    """Whether a pad contact ``behind`` its pad's plane is the bottom of a groove the pad
    rests across: rays cast towards the part, from beyond the pad, at the middles of two
    opposite sides of the pad's rectangle (in the gripper frame: ``y = sgn (pc[0] +- ps[0]/2)``
    at the contact's ``z``, or ``z = pc[1] +- ps[1]/2`` at its ``y``) first meet the part in
    the pad's plane, and the contact lies at most a quarter of half the span behind it."""
    for k in (0, 1):
        if behind > 0.25 * ps[k] / 2 + tol:
            continue
        ends = []
        for side in (-1.0, 1.0):
            q = g.copy()
            if k == 0:
                q[1] = sgn * (pc[0] + side * ps[0] / 2)
            else:
                q[2] = pc[1] + side * ps[1] / 2
            q[0] = plane + sgn * 10 * tol  # just outside the pad, towards its back
            origin = R @ q + t
            hits, _, _ = part.ray.intersects_location([origin], [-sgn * R[:, 0]])
            if len(hits):
                d = np.linalg.norm(hits - origin, axis=1).min() - 10 * tol
                ends.append(abs(d) <= tol)
        if len(ends) == 2 and all(ends):
            return True
    return False


def check_grasp(grasp: dict, mesh_path: Path, description: Path, scale: float, mu: float,
                clear: float) -> list[str]:
    """Everything wrong with one grasp of a ``synth.gripper_grasps`` document (empty: fine).

    ``scale`` converts the description's metres to the part's unit.
    """
    errors = []
    part = trimesh.load(mesh_path, force="mesh", process=False)
    V, F = np.asarray(part.vertices, float), np.asarray(part.faces)
    size = float(np.linalg.norm(V.max(0) - V.min(0)))
    T = np.array(grasp["pose"], float)
    R, t = T[:3, :3], T[:3, 3]
    if not (np.allclose(R.T @ R, np.eye(3), atol=1e-9) and abs(np.linalg.det(R) - 1) < 1e-9
            and np.allclose(T[3], [0, 0, 0, 1])):
        errors.append("pose is not a rigid transform")
    w = float(grasp["width"])
    pc, ps = pad_of(description, w, scale)
    pts = np.array([c["point"] for c in grasp["contacts"]], float)
    nrm = np.array([c["normal"] for c in grasp["contacts"]], float)
    # on the surface and on the pad: within 1e-5 of the part's size (synth's own surface
    # tolerance follows the coordinates' precision, a few 1e-6 of the size on these parts)
    tol = 1e-5 * size
    closed = winding_number(pts - 2e-3 * size * nrm, V, F)  # a step out of the part
    for i, (p, n, sgn) in enumerate(zip(pts, nrm, (1.0, -1.0))):
        d = point_triangle_distance(p, V[F]).min()
        if d > tol:
            errors.append(f"contact {i} is {d:.3g} off the surface")
        if closed[i] > 0.5:
            errors.append(f"contact {i} is not on the exposed surface")
        g = R.T @ (p - t)
        y = sgn * g[1]  # the -x pad is the half-turn of the +x one
        behind = sgn * (sgn * w / 2 - g[0])  # how far the contact lies behind the pad plane
        if abs(behind) > tol and not (np.allclose(n, -sgn * R[:, 0], atol=1e-9) and
                                      _groove(part, R, t, sgn * w / 2, sgn, pc, ps, g, behind,
                                              tol)):
            errors.append(f"contact {i} is not on its pad")
        if abs(y - pc[0]) > ps[0] / 2 + tol or abs(g[2] - pc[1]) > ps[1] / 2 + tol:
            errors.append(f"contact {i} is not on its pad")
        if not np.allclose(n, -sgn * R[:, 0], atol=1e-9):
            # else the pad's rim: the point on the rectangle's border and the normal a
            # triangle's inward one (the rim on a face), or, where the rim crosses an edge of
            # the part, perpendicular to the rim and between the inward normals of the
            # triangles through the point (non-negative weights, by NNLS)
            on_y = abs(abs(y - pc[0]) - ps[0] / 2) <= tol
            on_z = abs(abs(g[2] - pc[1]) - ps[1] / 2) <= tol
            tri = V[F][point_triangle_distance(p, V[F]) <= tol]
            inward = -np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            length = np.linalg.norm(inward, axis=1)
            inward = inward[length > 0] / length[length > 0, None]  # zero-area ones have none
            # (to 1e-6: a file of float32 coordinates, or its stored facet normals, give a
            # facet's normal to a few 1e-8)
            face = np.any(np.all(np.abs(inward - n) <= 1e-6, axis=1))
            rim_dir = R[:, 2] if on_y else R[:, 1]
            edge = len(inward) > 1 and on_y != on_z and abs(n @ rim_dir) <= 1e-6 and \
                abs(np.linalg.norm(n) - 1.0) <= 1e-6 and \
                scipy.optimize.nnls(inward.T, n)[1] <= 1e-6
            if not ((on_y or on_z) and (face or edge)):
                errors.append(f"contact {i}'s normal is neither its pad's nor, on its rim, "
                              "a face's or an edge's")
    line = (pts[1] - pts[0]) / np.linalg.norm(pts[1] - pts[0])
    half = math.atan(mu)
    for i, n, s in ((0, nrm[0], 1.0), (1, nrm[1], -1.0)):
        if math.acos(np.clip(s * line @ n, -1, 1)) > half + 1e-9:
            errors.append(f"the line between the contacts leaves contact {i}'s friction cone")
    for k, (Vg, Fg) in enumerate(gripper_shapes(description, w + 2 * clear, scale)):
        Vp = Vg @ R.T + t
        if meshes_intersect(Vp, Fg, V, F):
            errors.append(f"gripper shape {k} intersects the part")
        elif winding_number(Vp.mean(0, keepdims=True), V, F)[0] > 0.5:
            errors.append(f"gripper shape {k} lies inside the part")
    return errors
