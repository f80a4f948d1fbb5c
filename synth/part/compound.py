"""Files with several bodies: which bodies form one part, and uniting those that overlap.

Robot and simulator collision meshes are usually convex decompositions (V-HACD, CoACD): one
object stored as 4 to 100 convex pieces that touch, overlap, or leave gaps of 1e-5 to 1e-3 of
its size. Other files hold several objects side by side. So:

* bodies whose surfaces come within ``GROUP_GAP_RTOL`` of the file's size of each other (or
  one inside the other) are one *object*, a rigid part; objects farther apart are separate,
  and the loader plans one of them (:func:`synth.load_part`, ``body=``);
* closed bodies of one object that overlap (a common volume above ``OVERLAP_RTOL`` of the
  smaller) are united with manifold3d, so the hidden surface inside the overlap disappears
  and the seam becomes a real concave edge; bodies that only touch or nearly touch stay
  separate, and the part model hides what lies against another body
  (:mod:`synth.part.bodies`).

Distances come from FCL (python-fcl) on each body's BVH; volumes of overlap from manifold3d in
float64, around the object's own centre so that coordinates far from the origin lose nothing.
"""

from __future__ import annotations

import fcl
import numpy as np
import trimesh
from scipy.spatial import cKDTree

from synth.isolate import NativeCrash, call_isolated
from synth.native import bvh_model
from synth.part.bodies import solid_moments
from synth.part.closest import BoxTree
from synth.part.meshcache import face_geometry
from synth.part.repair import face_keys, fix_degenerate, tilted_normals

__all__ = ["OVERLAP_RTOL", "group_bodies", "unite_overlapping"]

#: The manifold3d steps, run in the child process of :mod:`synth.isolate`.
OVERLAP_VOLUMES = "synth.native:overlap_volumes"
UNITE = "synth.native:unite"

#: Two closed bodies overlap when their common volume exceeds this fraction of the smaller.
OVERLAP_RTOL: float = 1e-6


def _bvh(mesh: trimesh.Trimesh) -> fcl.CollisionObject:
    return fcl.CollisionObject(bvh_model(mesh.vertices, mesh.faces), fcl.Transform())


def _box_gap(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Distances (n, n) between axis-aligned boxes (0 where they overlap)."""
    sep = np.maximum(lo[:, None, :] - hi[None, :, :], lo[None, :, :] - hi[:, None, :])
    return np.linalg.norm(np.maximum(sep, 0.0), axis=2)


def _arrays(mesh: trimesh.Trimesh, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A body's vertices around ``origin`` and its faces, for :mod:`synth.native`."""
    return (np.asarray(mesh.vertices, np.float64) - origin,
            np.asarray(mesh.faces, np.int64))


#: Vertices of each body that :func:`_close_corners` compares, at most.
_CORNER_SAMPLE = 20_000


def _close_corners(a: trimesh.Trimesh, b: trimesh.Trimesh, gap: float) -> bool:
    """Whether a vertex of ``a`` lies within ``gap`` of a vertex of ``b``: then the bodies
    are within ``gap`` (a sufficient test, of a sample of at most ``_CORNER_SAMPLE`` vertices
    of each near the other, that spares building FCL's trees of large bodies, 1 s for 400k
    faces, when they touch)."""
    va, vb = np.asarray(a.vertices, float), np.asarray(b.vertices, float)
    lo = np.maximum(va.min(axis=0), vb.min(axis=0)) - gap
    hi = np.minimum(va.max(axis=0), vb.max(axis=0)) + gap
    near = [v[np.all((v >= lo) & (v <= hi), axis=1)] for v in (va, vb)]
    near = [v[::max(1, -(-len(v) // _CORNER_SAMPLE))] for v in near]
    if not all(len(v) for v in near):
        return False
    d = cKDTree(near[0]).query(near[1], distance_upper_bound=gap)[0]
    return bool((d <= gap).any())


class _Sets:
    """Union-find over n items."""

    def __init__(self, n: int) -> None:
        self.up = list(range(n))

    def find(self, i: int) -> int:
        while self.up[i] != i:
            self.up[i] = self.up[self.up[i]]
            i = self.up[i]
        return i

    def join(self, i: int, j: int) -> None:
        self.up[self.find(i)] = self.find(j)

    def groups(self) -> list[list[int]]:
        out: dict[int, list[int]] = {}
        for i in range(len(self.up)):
            out.setdefault(self.find(i), []).append(i)
        return sorted(out.values(), key=lambda g: g[0])


def _overlap_volume(a: trimesh.Trimesh, b: trimesh.Trimesh, origin: np.ndarray) -> float:
    """The volume common to two closed bodies (manifold3d, in the child process)."""
    return float(call_isolated(OVERLAP_VOLUMES, [_arrays(a, origin), _arrays(b, origin)],
                               [(0, 1)])[0])


def group_bodies(meshes: list[trimesh.Trimesh], closed: list[bool], gap_rtol: float
                 ) -> tuple[list[list[int]], list[str]]:
    """Split bodies into objects: groups of bodies that touch, nearly touch or nest.

    Parameters
    ----------
    meshes : list of trimesh.Trimesh
        The bodies, each one connected piece.
    closed : list of bool
        Which bodies are watertight (only those can contain another).
    gap_rtol : float
        Largest gap, as a fraction of the bounding-box diagonal of all the bodies.

    Returns
    -------
    groups : list of list of int
        Body indices of each object, in order of their first body.
    warnings : list of str
        One line per nesting test manifold3d crashed on (those bodies count as apart).
    """
    n = len(meshes)
    if n == 1:
        return [[0]], []
    lo = np.array([m.bounds[0] for m in meshes], float)
    hi = np.array([m.bounds[1] for m in meshes], float)
    thr = gap_rtol * float(np.linalg.norm(hi.max(axis=0) - lo.min(axis=0)))
    near = np.triu(_box_gap(lo, hi) <= thr, 1)
    sets = _Sets(n)
    objects: dict[int, fcl.CollisionObject] = {}

    def obj(i: int) -> fcl.CollisionObject:
        if i not in objects:
            objects[i] = _bvh(meshes[i])
        return objects[i]

    centre = (lo.min(axis=0) + hi.max(axis=0)) / 2
    warnings: list[str] = []
    for i, j in zip(*np.nonzero(near), strict=True):
        i, j = int(i), int(j)
        if sets.find(i) == sets.find(j):
            continue
        if _close_corners(meshes[i], meshes[j], thr) or fcl.distance(
                obj(i), obj(j), fcl.DistanceRequest(), fcl.DistanceResult()) <= thr:
            sets.join(i, j)
            continue
        for outer, inner in ((i, j), (j, i)):  # one body nested inside the other
            if closed[outer] and closed[inner] and np.all(lo[outer] <= lo[inner]) and \
                    np.all(hi[inner] <= hi[outer]):
                try:
                    nested = _overlap_volume(meshes[outer], meshes[inner], centre) > 0
                except NativeCrash as e:
                    warnings.append(f"manifold3d crashed ({e.how}) testing whether body "
                                    f"{inner} lies inside body {outer}; counted them apart")
                    nested = False
                if nested:
                    sets.join(i, j)
                    break
    return sets.groups(), warnings


def unite_overlapping(meshes: list[trimesh.Trimesh], names: list[str], closed: list[bool],
                      height: float, max_move: float,
                      keyed: dict[bytes, np.ndarray] | None = None
                      ) -> tuple[list[trimesh.Trimesh], list[str], list[np.ndarray],
                                 list[np.ndarray | None], list[str]]:
    """Unite the closed bodies of one object that overlap (manifold3d, float64).

    Parameters
    ----------
    meshes : list of trimesh.Trimesh
    names : list of str
    closed : list of bool
    height, max_move : float
        Slivers of the union thinner than ``height`` are repaired, moving its surface by at
        most ``max_move`` (:func:`synth.part.repair.fix_degenerate`).
    keyed : dict, optional
        Faces of the bodies an earlier repair tilted (:func:`synth.part.repair.face_keys`),
        with their triangles' normals: the union's pieces of them get those.

    Returns
    -------
    meshes, names : lists
        The bodies after uniting (a union that falls apart into pieces touching at an edge
        or a point gives several bodies).
    sources : list of (f_k,) int
        For each face of each body, the input body it lies on.
    normals : list of (f_k, 3) float or None
        For a united body, the normal of the union's face each face comes from (a piece of
        an input triangle, in its plane) where the sliver repair of the union tilted the face
        (it moves corners by up to the coordinates' precision, which tilts a small face by
        that over its size: 0.0033 degrees on a robot gripper's jaw), NaN elsewhere; None for
        a body not united. The part reads these as the faces' normals, so a contact's normal
        is that of the file's own triangle.
    notes : list of str
        One line per union made.
    """
    n = len(meshes)
    if n == 1:
        return meshes, names, [np.zeros(len(meshes[0].faces), np.int64)], [None], []
    lo = np.array([m.bounds[0] for m in meshes], float)
    hi = np.array([m.bounds[1] for m in meshes], float)
    centre = (lo.min(axis=0) + hi.max(axis=0)) / 2
    boxes = np.triu(_box_gap(lo, hi) <= 0.0, 1)
    pairs = [(int(i), int(j)) for i, j in zip(*np.nonzero(boxes), strict=True)
             if closed[i] and closed[j]]
    used = sorted({k for p in pairs for k in p})
    slot = {k: s for s, k in enumerate(used)}
    notes: list[str] = []
    sets = _Sets(n)
    try:
        volumes = call_isolated(OVERLAP_VOLUMES, [_arrays(meshes[k], centre) for k in used],
                                [(slot[i], slot[j]) for i, j in pairs]) if pairs else []
    except NativeCrash as e:
        volumes = [0.0] * len(pairs)
        notes.append(f"could not test which bodies overlap (manifold3d crashed: {e.how}); "
                     "kept them separate")
    vol = [abs(float(m.volume)) if c else 0.0 for m, c in zip(meshes, closed, strict=True)]
    for (i, j), common in zip(pairs, volumes, strict=True):
        if common > OVERLAP_RTOL * min(vol[i], vol[j]):
            sets.join(i, j)
    out_m: list[trimesh.Trimesh] = []
    out_n: list[str] = []
    out_s: list[np.ndarray] = []
    out_nn: list[np.ndarray | None] = []

    def keep(i: int) -> None:
        out_m.append(meshes[i])
        out_n.append(names[i])
        out_s.append(np.full(len(meshes[i].faces), i, np.int64))
        out_nn.append(None)

    for group in sets.groups():
        if len(group) == 1:
            keep(group[0])
            continue
        try:
            pieces = call_isolated(UNITE, [_arrays(meshes[i], centre) for i in group])
            why = "manifold3d failed"
        except NativeCrash as e:
            pieces, why = None, f"manifold3d crashed: {e.how}"
        if not pieces:
            for i in group:
                keep(i)
            notes.append(f"could not unite overlapping bodies {[names[i] for i in group]} "
                         f"({why}); kept them separate")
            continue
        label = "+".join(names[i] for i in group)
        trees: dict[int, BoxTree] = {}  # of the group's bodies, shared by the union's pieces
        # a piece of negative volume is the wall of a void the union encloses (manifold3d
        # gives it as a piece of its own: three gaps between the puck goal's nets, 2.9e-7 of
        # its 2.8e-4 m^3, touching its outside). The part has no model of a cavity: as a body
        # of its own it was an open sheet, exposed where it touched the outside, and its
        # slabs in simulation stood out of the surface and met the fingers. The void is
        # filled: no finger reaches it, and the enclosing body's outer wall counted its
        # volume as material already.
        signed = [solid_moments(v[f])[0] for v, f, _ in pieces]
        voids = [k for k, s in enumerate(signed) if s < 0]
        if len(voids) == len(pieces):  # no solid left: the signs say nothing, keep them all
            voids = []
        pieces = [p for k, p in enumerate(pieces) if k not in voids]
        for k, (v, f, src) in enumerate(pieces):
            united = trimesh.Trimesh(v + centre, f, process=False)
            # the union's faces are pieces of the input triangles, in their planes
            pieces_normals = _piece_normals(united, [meshes[i] for i in group], src,
                                            keyed or {}, trees)
            united, _, _, kept = fix_degenerate(united, height, max_move)
            out_m.append(united)
            out_s.append(np.asarray(group, np.int64)[src][kept])
            out_n.append(label if len(pieces) == 1 else f"{label}#{k}")
            out_nn.append(tilted_normals(united, pieces_normals[kept], max_move))
        shown = [names[i] for i in group]
        shown = shown if len(shown) <= 6 else shown[:5] + [f"... {len(shown) - 5} more"]
        filled = (f"; filled {len(voids)} void{'s' * (len(voids) > 1)} it enclosed (volume "
                  f"{-sum(signed[k] for k in voids):.3g})") if voids else ""
        notes.append(f"united {len(group)} overlapping bodies {shown} into "
                     f"{len(pieces)} (manifold3d){filled}")
    return out_m, out_n, out_s, out_nn, notes


def _piece_normals(united: trimesh.Trimesh, inputs: list[trimesh.Trimesh], src: np.ndarray,
                   keyed: dict[bytes, np.ndarray], trees: dict[int, BoxTree]) -> np.ndarray:
    """The normals (f, 3) of the union's faces, those of the input triangles they are pieces
    of: their own, except where an earlier repair tilted the input triangle (``keyed``), whose
    file triangle's normal they get (found by the face of body ``src`` nearest their centre,
    with the body's box tree in ``trees``, built here on first use)."""
    normals = np.array(face_geometry(united)[0], float)
    if not keyed:
        return normals
    centres = np.asarray(united.triangles_center, float)
    for b in np.unique(src).tolist():
        rows = np.flatnonzero(src == b)
        body = inputs[b]
        if b not in trees:
            trees[b] = BoxTree(body.vertices, body.faces)
        _, face, _ = trees[b].closest(centres[rows])
        for r, key in zip(rows.tolist(), face_keys(body, face).tolist(), strict=True):
            n = keyed.get(key)
            if n is not None:
                normals[r] = n if float(n @ normals[r]) > 0 else -n
    return normals
