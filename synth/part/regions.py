"""Face regions: planar facets and smooth curved patches, and per-corner normals.

A *planar facet* is a connected set of coplanar faces (normals within ``COPLANAR_ANGLE``)
at least half of whose outline (by length) is sharp; such a region's normal is exact. The
other faces form *smooth components* (connected across smooth edges); a component whose
normals spread more than ``PATCH_HALF_ANGLE`` from their mean is split into *patches* along
the cells of an icosahedron. Regions are the planar facets and the patches.

Interpolated normals are continuous inside a smooth component: the normal at a vertex is
the angle-weighted mean of the normals of the faces of the same smooth component around it
(patch borders inside a component do not break it; sharp edges do).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from synth.part.features import Features
from synth.part.meshcache import face_geometry, scaled_zero
from synth.part.order import group_ids, stable_order

__all__ = ["Region", "RegionSet", "compute_regions"]


@dataclass(frozen=True, eq=False)
class Region:
    """One face region of a part.

    Attributes
    ----------
    index : int
        Region id (``Part.regions[index]``).
    faces : (k,) int
        Faces of the region.
    area : float
    planar : bool
        True for a planar facet (exact normal), False for a smooth curved patch.
    normal : (3,) float
        Inward unit normal of a planar facet; for a smooth patch the inward axis of its
        normal cone (area-weighted mean direction).
    half_angle : float
        Half-angle in radians of the normal cone around ``normal`` (0 for a planar facet).
    boundary_edges : (b,) int
        Unique-edge indices of the region's outline.
    boundary : (b, 2) int
        The outline as vertex index pairs.
    outline : tuple of (m, 3) float
        Ordered closed loops of the outline of a planar facet (empty for smooth patches).
    """

    index: int
    faces: np.ndarray
    area: float
    planar: bool
    normal: np.ndarray
    half_angle: float
    boundary_edges: np.ndarray
    boundary: np.ndarray
    outline: tuple[np.ndarray, ...]

    @property
    def normal_cone(self) -> tuple[np.ndarray, float]:
        """``(axis, half_angle)`` of the inward normals of the region."""
        return self.normal, self.half_angle


@dataclass(frozen=True, eq=False)
class RegionSet:
    """Region labelling of a mesh (internal to :class:`synth.part.Part`).

    Attributes
    ----------
    regions : tuple of Region
    face_region : (f,) int
        Region id of each face.
    face_group : (f,) int
        Normal group of each face: a planar facet, or a smooth component (within which
        corner normals are shared by the faces of one fan around a vertex).
    corner_normals : (f, 3, 3) float
        Inward unit normal at each corner of each face (``[f, j]`` for vertex
        ``faces[f, j]``), exact face normal on planar facets.
    """

    regions: tuple[Region, ...]
    face_region: np.ndarray
    face_group: np.ndarray
    corner_normals: np.ndarray


def _components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    graph = coo_matrix((np.ones(len(a), np.int8), (a, b)), shape=(n, n))
    return connected_components(graph, directed=False)[1]


#: Faces at a time where a step makes a row of several numbers per face.
_BLOCK = 1 << 16


def _sums(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """``np.add.at(np.zeros((n, 3)), index, values)`` for values (m, 3): the same sums in the
    same order, a column at a time with bincount (several times faster)."""
    return np.column_stack([np.bincount(index, weights=values[:, c], minlength=n)
                            for c in range(3)])


def _icosahedron() -> np.ndarray:
    return np.asarray(trimesh.creation.icosahedron().vertices, float)


def compute_regions(
    mesh: trimesh.Trimesh,
    features: Features,
    coplanar_angle: float,
    patch_half_angle: float,
    precision: float = 0.0,
) -> RegionSet:
    """Split the faces of ``mesh`` into planar facets and smooth patches.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    features : Features
        Edge classification of ``mesh``.
    coplanar_angle, patch_half_angle : float
        Radians; see :mod:`synth.part.tolerances`.
    precision : float
        Rounding error of the vertex coordinates (length). Two faces count as coplanar when
        their normals differ by less than ``coplanar_angle`` plus the normal error that this
        rounding causes on the smaller of them (``2 precision / smallest height``), at most
        a quarter of the sharp-edge angle.

    Returns
    -------
    RegionSet
    """
    normals, areas = face_geometry(mesh)
    face_planar, face_region, face_group, smooth = _label_faces(
        features, normals, areas, coplanar_angle, patch_half_angle, precision)
    corner = _corner_normals(mesh, features.edges[smooth], features.edge_faces[smooth],
                             face_planar, normals)
    regions = _build_regions(mesh, features, face_region, face_planar, normals, areas)
    _fill_normalless(corner, normals, features)
    for arr in (face_region, face_group, corner):
        arr.flags.writeable = False
    return RegionSet(regions, face_region, face_group, corner)


def _label_faces(
    features: Features, normals: np.ndarray, areas: np.ndarray, coplanar_angle: float,
    patch_half_angle: float, precision: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Which faces are planar (f,) bool, their region (f,) and smooth group (f,), and the
    smooth edges inside smooth components (s,) (edge indices): the steps of
    :func:`compute_regions`, in a function of their own so that their edge-sized temporaries
    are gone before the corner normals are built (at 1.3M faces they held 230 MB)."""
    n_f = len(normals)
    ef, kind, angle = features.edge_faces, features.edge_kind, features.edge_angle
    inner = ef[:, 1] >= 0
    fa, fb = ef[inner, 0], ef[inner, 1]
    ang_in, kind_in = angle[inner], kind[inner]

    # 1. coplanar components and which of them are planar facets
    tol = np.full(len(fa), coplanar_angle)
    if precision > 0:
        fe = features.face_edges
        length = features.edge_length
        longest = np.maximum(np.maximum(length[fe[:, 0]], length[fe[:, 1]]), length[fe[:, 2]])
        height = 2.0 * areas / np.maximum(longest, 1e-300)
        tol += 2.0 * precision / np.maximum(np.minimum(height[fa], height[fb]), 1e-300)
        tol = np.minimum(tol, max(coplanar_angle, 0.25 * features.sharp_angle))  # slivers
    cop = ang_in < tol
    lab_cp = _components(n_f, fa[cop], fb[cop])
    n_cp = lab_cp.max() + 1
    length = features.edge_length
    la = lab_cp[ef[:, 0]]
    lb = np.where(ef[:, 1] >= 0, lab_cp[np.maximum(ef[:, 1], 0)], -1)
    on_outline = la != lb
    sharp = kind != 0
    # each outline edge's length to the components on both sides (both sides' sums in one
    # pass, in the order np.add.at would add them)
    ma, mb = on_outline & (la >= 0), on_outline & (lb >= 0)
    side = np.concatenate([la[ma], lb[mb]])
    run = np.concatenate([length[ma], length[mb]])
    total = np.bincount(side, weights=run, minlength=n_cp)
    sharp_len = np.bincount(side, weights=np.where(np.concatenate([sharp[ma], sharp[mb]]),
                                                   run, 0.0), minlength=n_cp)
    planar_cp = sharp_len >= 0.5 * total
    face_planar = planar_cp[lab_cp]

    # 2. smooth components over the remaining faces
    both = ~face_planar[fa] & ~face_planar[fb] & (kind_in == 0)
    lab_sm = _components(n_f, fa[both], fb[both])

    # 3. patches of bounded spread
    patch = lab_sm.copy()
    sm_faces = np.flatnonzero(~face_planar)
    if len(sm_faces):
        n_sm = lab_sm.max() + 1
        mean = _sums(lab_sm[sm_faces], normals[sm_faces] * areas[sm_faces, None], n_sm)
        mean /= np.maximum(np.linalg.norm(mean, axis=1), 1e-300)[:, None]
        cosf = np.einsum("ij,ij->i", normals[sm_faces], mean[lab_sm[sm_faces]])
        min_cos = np.ones(n_sm)
        np.minimum.at(min_cos, lab_sm[sm_faces], cosf)
        wide = min_cos < np.cos(patch_half_angle)
        if wide.any():
            ico = _icosahedron().T
            cell = np.empty(n_f, np.int64)
            for s in range(0, n_f, _BLOCK):  # no (f, 12) temporary (125 MB at 1.3M faces)
                cell[s:s + _BLOCK] = np.argmax(normals[s:s + _BLOCK] @ ico, axis=1)
            keep = both & (cell[fa] == cell[fb]) | (both & ~wide[lab_sm[fa]])
            patch = _components(n_f, fa[keep], fb[keep])
    face_region = group_ids(np.where(face_planar, lab_cp, n_f + patch), 2 * n_f)[2]
    face_group = group_ids(np.where(face_planar, lab_cp, n_f + lab_sm), 2 * n_f)[2]
    return face_planar, face_region, face_group, np.flatnonzero(inner)[both]


def _corner_normals(
    mesh: trimesh.Trimesh, edges: np.ndarray, edge_faces: np.ndarray, planar: np.ndarray,
    normals: np.ndarray
) -> np.ndarray:
    """Inward normal at each face corner (f, 3, 3): the angle-weighted mean normal of the
    faces around the vertex that the corner's face reaches through the smooth ``edges``
    (e, 2) at that vertex (between the faces ``edge_faces`` (e, 2)). Where a crease (a seam
    of a union) passes through a vertex, its two sides keep their own normals there even
    when they join elsewhere; planar faces keep their own normal."""
    faces = np.asarray(mesh.faces, np.int64)
    # trimesh's face angles, kept where trimesh keeps them (the solids read them again)
    angles = _face_angles(np.asarray(mesh.vertices, float), faces)
    mesh._cache["face_angles"] = angles
    w = angles.ravel()
    n_f = len(faces)
    m = len(edges)
    a, b = np.empty(2 * m, np.int64), np.empty(2 * m, np.int64)
    for end in (0, 1):  # the corners of both faces at each end of each smooth edge
        v = edges[:, end]
        for out, f in ((a, edge_faces[:, 0]), (b, edge_faces[:, 1])):
            # which corner of f is v, a column at a time (no (e, 3) temporaries)
            corner_of_v = np.where(np.take(faces[:, 0], f) == v, 0,
                                   np.where(np.take(faces[:, 1], f) == v, 1, 2))
            out[end * m:(end + 1) * m] = 3 * f + corner_of_v
    fan = _components(3 * n_f, a, b)
    del a, b
    acc = np.zeros((int(fan.max()) + 1 if n_f else 0, 3))
    for c in range(3):  # the sums np.add.at makes, in the same order, 10x faster
        acc[:, c] = np.bincount(fan, weights=np.repeat(normals[:, c], 3) * w,
                                minlength=len(acc))
    acc /= np.maximum(np.linalg.norm(acc, axis=1), 1e-300)[:, None]
    corner = np.take(acc, fan, axis=0).reshape(-1, 3, 3)
    corner[planar] = normals[planar][:, None, :]
    return np.negative(corner, out=corner)


def _fill_normalless(corner: np.ndarray, normals: np.ndarray, features: Features) -> None:
    """Give the corners that have no normal one, in place: a face too thin for trimesh to
    give it a normal (a sliver, as in float32 CAD) takes the mean inward normal of the faces
    across its edges, which for a sliver of a planar facet is the facet's (its own cross
    product, from corners a rounding apart, may point anywhere); the faces of a sliver with
    no such neighbour keep none."""
    # only a face without a normal can have corners without one (a smooth fan of faces with
    # normals sums to a nonzero vector): found a block at a time, no (f, 3, 3) temporary
    rows = np.concatenate([s + np.flatnonzero(~(np.abs(normals[s:s + _BLOCK]).max(axis=1) > 0))
                           for s in range(0, len(normals), _BLOCK)] or [np.zeros(0, np.int64)])
    rows = rows[~(np.abs(corner[rows]).max(axis=(1, 2)) > 0)]
    if not len(rows):
        return
    ef = features.edge_faces[features.face_edges[rows]]  # (r, 3 edges, 2 sides)
    other = np.where(ef[..., 0] == rows[:, None], ef[..., 1], ef[..., 0])  # (r, 3)
    side = np.where(other[..., None] >= 0, normals[np.maximum(other, 0)], 0.0).sum(axis=1)
    length = np.linalg.norm(side, axis=1)
    ok = length > 0
    corner[rows[ok]] = (-side[ok] / length[ok, None])[:, None, :]


def _face_angles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``trimesh.triangles.angles`` of the triangles ``faces`` (f, 3) of ``vertices`` (v, 3):
    the angles (f, 3) at their corners, the same values, found a coordinate at a time from
    (f,) arrays instead of the (f, 3, 3) corners (0.09 against 0.12 s at 1.3M faces)."""
    cols = [np.ascontiguousarray(vertices[:, k]) for k in range(3)]
    corner = [np.ascontiguousarray(faces[:, c]) for c in range(3)]
    x = [[np.take(col, corner[c]) for c in range(3)] for col in cols]  # coordinate, corner
    zero = scaled_zero(vertices)  # (trimesh's, for a part of size 1 or more)
    u = _unit([x[k][1] - x[k][0] for k in range(3)], zero)
    v = _unit([x[k][2] - x[k][0] for k in range(3)], zero)
    w = _unit([x[k][2] - x[k][1] for k in range(3)], zero)
    del x
    out = np.empty((len(faces), 3))
    # trimesh's row dot products (np.dot with ones, a BLAS call) sum x, y, then z with this
    # machine's OpenBLAS; another BLAS may round them otherwise, in the last bit
    out[:, 0] = np.arccos(np.clip((u[0] * v[0] + u[1] * v[1]) + u[2] * v[2], -1, 1))
    out[:, 1] = np.arccos(np.clip(((-u[0]) * w[0] + (-u[1]) * w[1]) + (-u[2]) * w[2], -1, 1))
    out[:, 2] = np.pi - out[:, 0] - out[:, 1]
    out[(out < trimesh.tol.merge).any(axis=1), :] = 0.0  # a degenerate triangle has none
    return out


def _unit(d: list[np.ndarray], zero: float) -> list[np.ndarray]:
    """``trimesh.util.unitize`` of vectors given as their three coordinates (n,) each (a
    vector of no length, ``zero`` or less, is scaled by its length, as trimesh scales it)."""
    norm = np.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])
    valid = norm > zero
    norm[valid] **= -1
    return [c * norm for c in d]


def _build_regions(
    mesh: trimesh.Trimesh,
    features: Features,
    face_region: np.ndarray,
    face_planar: np.ndarray,
    normals: np.ndarray,
    areas: np.ndarray,
) -> tuple[Region, ...]:
    n_r = int(face_region.max()) + 1
    order, sorted_region = stable_order(face_region, n_r)
    bounds = np.searchsorted(sorted_region, np.arange(n_r + 1))
    area = np.bincount(face_region, weights=areas, minlength=n_r)
    axis = _sums(face_region, normals * areas[:, None], n_r)
    axis /= np.maximum(np.linalg.norm(axis, axis=1), 1e-300)[:, None]
    cosf = np.einsum("ij,ij->i", normals, axis[face_region])
    min_cos = np.ones(n_r)
    np.minimum.at(min_cos, face_region, cosf)
    planar_r = np.zeros(n_r, bool)
    planar_r[face_region] = face_planar

    ef = features.edge_faces
    ra = face_region[ef[:, 0]]
    rb = np.where(ef[:, 1] >= 0, face_region[np.maximum(ef[:, 1], 0)], -1)
    out = np.flatnonzero(ra != rb)
    owner = np.concatenate([ra[out], rb[out]])
    edge_ids = np.concatenate([out, out])
    m = owner >= 0
    owner, edge_ids = owner[m], edge_ids[m]
    b_order, sorted_owner = stable_order(owner, n_r)
    b_bounds = np.searchsorted(sorted_owner, np.arange(n_r + 1))
    verts = np.asarray(mesh.vertices, float)

    regions = []
    for r in range(n_r):
        faces_r = order[bounds[r] : bounds[r + 1]].copy()
        be = edge_ids[b_order[b_bounds[r] : b_bounds[r + 1]]].copy()
        bv = features.edges[be].copy()
        outline = tuple(verts[loop] for loop in _loops(bv)) if planar_r[r] else ()
        normal = -axis[r]
        half = 0.0 if planar_r[r] else float(np.arccos(np.clip(min_cos[r], -1.0, 1.0)))
        for a in (faces_r, be, bv, normal, *outline):
            a.flags.writeable = False
        regions.append(
            Region(r, faces_r, float(area[r]), bool(planar_r[r]), normal, half, be, bv, outline)
        )
    return tuple(regions)


def _loops(edges: np.ndarray) -> list[np.ndarray]:
    """Order boundary edges (b, 2) into closed vertex loops (best effort at junctions)."""
    adj: dict[int, list[int]] = {}
    for a, b in edges.tolist():
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    seen: set[tuple[int, int]] = set()
    loops = []
    for a, b in edges.tolist():
        if (a, b) in seen:
            continue
        loop = [a]
        prev, cur = a, b
        seen.update({(a, b), (b, a)})
        while cur != a:
            loop.append(cur)
            nxt = [n for n in adj[cur] if (cur, n) not in seen]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            seen.update({(prev, cur), (cur, prev)})
        loops.append(np.asarray(loop, np.int64))
    return loops
