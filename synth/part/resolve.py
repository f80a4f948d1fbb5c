"""Resolve surface points into contacts with inward normals (``Part.resolve``).

Every contact gets two normals (see :mod:`synth.scores.surface`): the mesh's own
(``Contacts.normals``), along which a fingertip touching the facets pushes, and the smooth
reading (``Contacts.smooth_normals``) of the curved surface a tessellation approximates. For a
point on face ``f`` of the cleaned mesh:

* inside a face (a planar facet or a facet of a tessellated patch), and on a smooth edge or a
  smooth vertex, ``feature="face"``: the mesh normal is the face's (on a smooth edge the mean
  of its two facets', at a smooth vertex the smooth normal there, both inside the feature's
  cone); the smooth normal is the face's on a planar facet and, on a tessellated patch, the
  barycentric interpolation of the corner normals of ``f`` (vertex normals of its smooth
  component), continuous across smooth edges;
* on a convex sharp edge, a convex corner or an open boundary: the normal cone is the set
  of normals of the incident facets (``Part.normal_cone``); the fingertip's normal is the
  normalised mean of the cone's normals (independent of the fingertip radius: for a sphere
  pushed straight onto the feature the contact force lies inside the cone, and the mean is
  the direction that favours no face); for the smooth reading the mean of the two sides'
  smooth normals; ``unique_normal=False``;
* on a concave edge: one contact per face (2), in a concave corner one per incident
  facet (3 in a box corner); they share a ``finger`` id; normals unique;
* at a saddle vertex: one contact per incident facet, ``unique_normal=False`` (which of
  them a fingertip really touches depends on its approach).

At a vertex both readings take the corner normals of the incident facets (an angle-weighted
mean of facets around the vertex, so inside the vertex's cone). ``finger`` is the index of the
input point, so contacts of one point share it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import trimesh

from synth.contacts.contacts import Contacts
from synth.errors import InputError
from synth.part.closest import closest_on_triangles
from synth.part.points import xyz_rows

if TYPE_CHECKING:
    from synth.part.model import Part

__all__ = ["closest_points", "resolve_points"]


def closest_points(part: Part, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest surface point, its face and distance for each query point: the nearest face
    by the part's box tree, the point on it by the relative-tolerance kernel
    (:class:`synth.part.closest.BoxTree`). A point equally near several faces (nearest an
    edge or a corner) gets one of them.

    Parameters
    ----------
    part : Part
    points : (n, 3) float

    Returns
    -------
    closest : (n, 3) float
    faces : (n,) int
    distance : (n,) float
    """
    return part._index.closest(points)


def _barycentric(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    return trimesh.triangles.points_to_barycentric(tri, p, method="cramer")


def _interp_normals(part: Part, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Inward normal of the surface of ``faces`` at ``points`` (n, 3)."""
    bary = np.clip(_barycentric(part._corners(faces), points), 0.0, None)
    bary /= np.maximum(bary.sum(axis=1, keepdims=True), 1e-300)
    n = np.einsum("ij,ijk->ik", bary, part._regions.corner_normals[faces])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


def resolve_points(
    part: Part,
    points: np.ndarray,
    faces: np.ndarray | None = None,
    *,
    snap: bool = False,
) -> Contacts:
    """See :meth:`synth.part.Part.resolve`."""
    pts = xyz_rows(points, "points")
    n_f = len(part.mesh.faces)
    if faces is None:
        q, f, dist = closest_points(part, pts)
    else:
        f = np.asarray(faces)
        if f.shape != (len(pts),) or not np.issubdtype(f.dtype, np.integer):
            raise InputError(f"faces: expected ({len(pts)},) int, got {f.shape} {f.dtype}")
        if len(f) and (f.min() < 0 or f.max() >= n_f):
            raise InputError(f"faces: indices must lie in [0, {n_f}), got {f.min()}..{f.max()}")
        f = f.astype(np.int64)
        q = closest_on_triangles(part._corners(f), pts)
        dist = np.linalg.norm(q - pts, axis=1)
    tol = part.surface_tolerance
    if not snap and len(dist) and dist.max() > tol:
        bad = np.flatnonzero(dist > tol)
        raise InputError(
            f"points: {len(bad)} of {len(pts)} lie farther than {tol:g} {part.units or ''} "
            f"from the surface (first index {bad[0]}, distance {dist[bad[0]]:g}); "
            "pass snap=True to project them onto it"
        )
    return _classify(part, q, f)


def _classify(part: Part, q: np.ndarray, f: np.ndarray) -> Contacts:
    feats = part.features
    mfaces = np.asarray(part.mesh.faces, np.int64)
    eps = part.feature_tolerance
    n = len(q)
    tri = part._corners(f)
    dv = np.linalg.norm(tri - q[:, None, :], axis=2)  # distance to corners
    jv = np.argmin(dv, axis=1)
    at_vertex = dv[np.arange(n), jv] <= eps
    # distance to the edges (k: corners k, k+1), measured in the face plane
    a, b = tri, np.roll(tri, -1, axis=1)
    ab = b - a
    t = np.clip(np.einsum("ijk,ijk->ij", q[:, None] - a, ab) / np.einsum("ijk,ijk->ij", ab, ab),
                0.0, 1.0)
    de = np.linalg.norm(a + t[..., None] * ab - q[:, None], axis=2)
    je = np.argmin(de, axis=1)
    on_edge = ~at_vertex & (de[np.arange(n), je] <= eps)

    vid = mfaces[f, jv]
    eid = feats.face_edges[f, je]
    vkind = np.where(at_vertex, feats.vertex_kind[vid], 0)
    # a vertex inside a sharp edge chain is treated as a point on that edge
    vedge = at_vertex & (vkind == 1)
    eid = np.where(vedge, feats.vertex_edge[vid], eid)
    on_edge = on_edge | vedge
    ekind = np.where(on_edge, feats.edge_kind[eid], 0)
    corner = at_vertex & (vkind >= 2)
    smooth_edge = on_edge & (ekind == 0)
    on_edge &= ekind != 0  # smooth edges behave as faces (but for the mesh's normal)

    face_in = -np.asarray(part.mesh.face_normals, float)  # inward facet normals
    smooth = _interp_normals(part, f, q)
    normal = face_in[f]
    # on a smooth edge the mesh's normal is the mean of its two facets' (whichever face the
    # point was found on); at a smooth vertex the corner normal (in the vertex's cone); a
    # face without area has no normal of its own
    ef = feats.edge_faces
    se = np.flatnonzero(smooth_edge)
    normal[se] = _unit(face_in[ef[eid[se], 0]] + face_in[ef[eid[se], 1]])
    flat = (at_vertex & (vkind == 0)) | (np.linalg.norm(normal, axis=1) < 0.5)
    normal[flat] = smooth[flat]
    kind = np.zeros(n, np.int8)  # 0 face, 1 edge, 2 vertex
    index = f.copy()
    unique = np.ones(n, bool)
    face_out = f.copy()

    # (src, normal, smooth normal, face, kind, index, unique)
    rows: list[tuple[np.ndarray, ...]] = []
    single = ~on_edge & ~corner

    # convex and boundary edges: mean of the two side normals
    cvx = on_edge & ((ekind == 1) | (ekind == 3))
    if cvx.any():
        e = eid[cvx]
        fa = ef[e, 0]
        fb = np.where(ef[e, 1] >= 0, ef[e, 1], fa)
        normal[cvx] = _unit(face_in[fa] + face_in[fb])
        smooth[cvx] = _unit(_interp_normals(part, fa, q[cvx]) + _interp_normals(part, fb, q[cvx]))
        kind[cvx], index[cvx], unique[cvx], face_out[cvx] = 1, e, False, fa
        single |= cvx
    ccv = on_edge & (ekind == 2)
    if ccv.any():
        src = np.flatnonzero(ccv)
        e = eid[ccv]
        for side in (0, 1):
            fs = ef[e, side]
            rows.append((src, face_in[fs], _interp_normals(part, fs, q[ccv]), fs,
                         np.full(len(src), 1, np.int8), e, np.ones(len(src), bool)))
    if corner.any():
        src = np.flatnonzero(corner)
        v = vid[corner]
        off, cfaces, cnorm = part._vertex_cone
        counts = off[v + 1] - off[v]
        rep_src = np.repeat(src, counts)
        sel = np.concatenate([np.arange(off[x], off[x + 1]) for x in v]) if len(v) else \
            np.zeros(0, np.int64)
        vk = np.repeat(vkind[corner], counts)
        mean_like = (vkind[corner] == 2) | (vkind[corner] == 5)
        # convex corners and open-boundary vertices: one contact, mean of the cone
        if mean_like.any():
            cs = src[mean_like]
            acc = np.zeros((n, 3))
            m = np.isin(rep_src, cs)
            np.add.at(acc, rep_src[m], cnorm[sel[m]])
            normal[cs] = smooth[cs] = _unit(acc[cs])
            kind[cs], index[cs], unique[cs] = 2, vid[cs], False
            single[cs] = True
        multi = ~np.isin(rep_src, src[mean_like])
        if multi.any():
            rs = rep_src[multi]
            rows.append((rs, cnorm[sel[multi]], cnorm[sel[multi]], cfaces[sel[multi]],
                         np.full(len(rs), 2, np.int8), vid[rs], vk[multi] == 3))

    src_all = [np.flatnonzero(single)]
    cols: list[tuple[np.ndarray, ...]] = [(normal[single], smooth[single], face_out[single],
                                           kind[single], index[single], unique[single])]
    for r in rows:
        src_all.append(r[0])
        cols.append(r[1:])
    src_cat = np.concatenate(src_all)
    order = np.argsort(src_cat, kind="stable")
    src_cat = src_cat[order]
    nrm, smo, fcs, knd, idx, unq = (np.concatenate([c[i] for c in cols])[order]
                                    for i in range(6))
    names = np.array(["face", "edge", "vertex"])
    return Contacts(
        points=q[src_cat],
        normals=nrm,
        features=names[knd],
        feature_index=idx,
        faces=fcs,
        unique_normal=unq,
        region=part.face_region[fcs],
        finger=src_cat,
        smooth_normals=smo,
    )
