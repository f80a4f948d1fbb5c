"""Exact closest points on a triangle mesh, vectorised (used by ``Part.resolve``).

The point-triangle kernel is the one of ``trimesh.triangles.closest_point`` ("Real Time
Collision Detection", ClosestPtPointTriangle), with the same arithmetic and branch order, so
it returns the same points; it avoids trimesh's per-call overhead (Python ``any`` over the
masks). The search certifies its answer with the bound ``dist(p, f) >= |p - c_f| - r``
where ``c_f`` is the centroid of face ``f`` and ``r`` the largest centroid-to-corner distance
of the mesh.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["MeshIndex", "closest_on_mesh", "closest_on_triangles", "plane_and_sides"]

_ZERO = 1e-13  # trimesh.tol.zero
_ONES = [1.0, 1.0, 1.0]
_CHUNK = 1 << 15


def closest_on_triangles(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Closest point on each triangle to the matching point.

    Parameters
    ----------
    triangles : (n, 3, 3) float
    points : (n, 3) float

    Returns
    -------
    closest : (n, 3) float
        Same values as ``trimesh.triangles.closest_point(triangles, points)``.
    """
    triangles = np.asarray(triangles, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    result = np.zeros_like(points)
    remain = np.ones(len(points), dtype=bool)
    a, b, c = triangles[:, 0, :], triangles[:, 1, :], triangles[:, 2, :]
    ab = b - a
    ac = c - a
    ap = points - a
    d1 = np.dot(ab * ap, _ONES)
    d2 = np.dot(ac * ap, _ONES)
    is_a = (d1 < _ZERO) & (d2 < _ZERO)
    if is_a.any():
        result[is_a] = a[is_a]
        remain[is_a] = False
    collapsed_ab = np.all(ab == 0.0, axis=1)
    if collapsed_ab.any():
        segment = ac[collapsed_ab]
        length_squared = np.sum(segment**2, axis=1)
        factor = np.zeros(len(segment), dtype=np.float64)
        np.divide(np.sum(ap[collapsed_ab] * segment, axis=1), length_squared, out=factor,
                  where=length_squared > 0)
        result[collapsed_ab] = a[collapsed_ab] + np.clip(factor, 0, 1)[:, None] * segment
        remain[collapsed_ab] = False
    bp = points - b
    d3 = np.dot(ab * bp, _ONES)
    d4 = np.dot(ac * bp, _ONES)
    is_b = (d3 > -_ZERO) & (d4 <= d3) & remain
    if is_b.any():
        result[is_b] = b[is_b]
        remain[is_b] = False
    vc = (d1 * d4) - (d3 * d2)
    is_ab = (vc < _ZERO) & (d1 > -_ZERO) & (d3 < _ZERO) & remain
    if is_ab.any():
        v = (d1[is_ab] / (d1[is_ab] - d3[is_ab])).reshape((-1, 1))
        result[is_ab] = a[is_ab] + (v * ab[is_ab])
        remain[is_ab] = False
    cp = points - c
    d5 = np.dot(ab * cp, _ONES)
    d6 = np.dot(ac * cp, _ONES)
    is_c = (d6 > -_ZERO) & (d5 <= d6) & remain
    if is_c.any():
        result[is_c] = c[is_c]
        remain[is_c] = False
    vb = (d5 * d2) - (d1 * d6)
    is_ac = (vb < _ZERO) & (d2 > -_ZERO) & (d6 < _ZERO) & remain
    if is_ac.any():
        w = (d2[is_ac] / (d2[is_ac] - d6[is_ac])).reshape((-1, 1))
        result[is_ac] = a[is_ac] + w * ac[is_ac]
        remain[is_ac] = False
    va = (d3 * d6) - (d5 * d4)
    is_bc = (va < _ZERO) & ((d4 - d3) > -_ZERO) & ((d5 - d6) > -_ZERO) & remain
    if is_bc.any():
        d43 = d4[is_bc] - d3[is_bc]
        w = (d43 / (d43 + (d5[is_bc] - d6[is_bc]))).reshape((-1, 1))
        result[is_bc] = b[is_bc] + w * (c[is_bc] - b[is_bc])
        remain[is_bc] = False
    if remain.any():
        denom = 1.0 / (va[remain] + vb[remain] + vc[remain])
        v = (vb[remain] * denom).reshape((-1, 1))
        w = (vc[remain] * denom).reshape((-1, 1))
        result[remain] = a[remain] + (ab[remain] * v) + (ac[remain] * w)
    return result


class MeshIndex(NamedTuple):
    """What the search needs of a mesh (``Part`` holds these arrays).

    Attributes
    ----------
    triangles : (f, 3, 3) float
    tree : cKDTree
        Tree of the triangle centroids.
    radius : float
        Upper bound of the distance from a centroid to its triangle's corners.
    plane_normals : (f, 3) float
        Unit face normals.
    plane_offsets : (f,) float
        ``n_f . a_f``.
    edge_normals : (f, 3, 3) float
        In-plane unit normals of the edges (0,1), (1,2), (2,0), pointing into the face.
    edge_offsets : (f, 3) float
    unbounded : (f,) bool
        Faces whose normals do not match their winding (or are degenerate): no lower bound
        from planes and edges, always evaluated.
    """

    triangles: np.ndarray
    tree: cKDTree
    radius: float
    plane_normals: np.ndarray
    plane_offsets: np.ndarray
    edge_normals: np.ndarray
    edge_offsets: np.ndarray
    unbounded: np.ndarray


def plane_and_sides(index: MeshIndex, cand: np.ndarray, points: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Signed distances of points to the planes and edge lines of candidate faces.

    Parameters
    ----------
    index : MeshIndex
    cand : (m, k) int
        Candidate faces of each point.
    points : (m, 3) float

    Returns
    -------
    h : (m, k) float
        ``n_f . p - n_f . a_f``.
    side : (m, k, 3) float
        ``e_fj . p - o_fj``: all >= 0 when the projection of ``p`` lies in the face.
    """
    x, y, z = points[:, None, 0], points[:, None, 1], points[:, None, 2]
    pn = index.plane_normals[cand]
    h = pn[..., 0] * x + pn[..., 1] * y + pn[..., 2] * z - index.plane_offsets[cand]
    en = index.edge_normals[cand]  # (m, k, 3, 3)
    x, y, z = x[..., None], y[..., None], z[..., None]
    side = en[..., 0] * x + en[..., 1] * y + en[..., 2] * z - index.edge_offsets[cand]
    return h, side


def _lower_bound(index: MeshIndex, cand: np.ndarray, h: np.ndarray, side: np.ndarray
                 ) -> np.ndarray:
    """Distance from a point to a face is at least ``sqrt(h^2 + max(0, -min side)^2)``:
    the face lies in the slab ``side >= 0`` of each of its edges."""
    out = np.minimum(side.min(axis=-1), 0.0)
    return np.where(index.unbounded[cand], 0.0, np.sqrt(h * h + out * out))


def _first_min(starts: np.ndarray, keys: tuple[np.ndarray, ...]) -> np.ndarray:
    """Index of the lexicographic minimum of ``keys`` in each group, the first on ties.

    Parameters
    ----------
    starts : (n,) int
        Start of each group in arrays whose groups are contiguous and non-empty.
    keys : tuple of (c,) float
        Primary key first.

    Returns
    -------
    pick : (n,) int
    """
    c = len(keys[0])
    counts = np.diff(np.r_[starts, c])
    mask = np.ones(c, bool)
    for key in keys:
        x = np.where(mask, key, np.inf)
        low = np.repeat(np.minimum.reduceat(x, starts), counts)
        mask &= x == low
    pos = np.where(mask, np.arange(c), c)
    return np.minimum.reduceat(pos, starts)


def _best_of_groups(tri: np.ndarray, points: np.ndarray, owner: np.ndarray, cand: np.ndarray,
                    starts: np.ndarray, rank: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nearest of the candidate faces ``cand`` (c,) of points ``owner`` (c,).

    Groups of one owner are contiguous, in owner order, from ``starts`` (n,) on, and
    non-empty. Returns closest (n, 3), face (n,) and distance (n,); among equal distances
    the smallest ``rank`` (c,) wins, then the earliest candidate.
    """
    q = closest_on_triangles(tri[cand], points[owner])
    d = np.linalg.norm(q - points[owner], axis=1)
    pick = _first_min(starts, (d, rank))
    return q[pick], cand[pick], d[pick]


def _prune(index: MeshIndex, points: np.ndarray, owner: np.ndarray, cand: np.ndarray,
           starts: np.ndarray, lb: np.ndarray, rank: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact nearest among candidates (c,) grouped as in :func:`_best_of_groups`, skipping
    those whose lower bound ``lb`` exceeds the exact distance of the candidate with the
    smallest bound; ties: see :func:`_best_of_groups`."""
    n = len(starts)
    first = _first_min(starts, (lb,))
    _, _, ub = _best_of_groups(index.triangles, points, np.arange(n), cand[first],
                               np.arange(n), rank[first])
    slack = 1e-9 * (ub + index.radius)  # rounding in lb: never drop a tie
    keep = lb <= np.repeat(ub + slack, np.diff(np.r_[starts, len(lb)]))
    keep[first] = True
    counts = np.add.reduceat(keep.astype(np.int64), starts)
    new_starts = np.r_[0, np.cumsum(counts)[:-1]]
    return _best_of_groups(index.triangles, points, owner[keep], cand[keep], new_starts,
                           rank[keep])


def closest_on_mesh(index: MeshIndex, points: np.ndarray, k: int = 8,
                    cand: np.ndarray | None = None, dist_c: np.ndarray | None = None,
                    h: np.ndarray | None = None, side: np.ndarray | None = None,
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact closest point of the mesh to each point.

    The faces with the ``k`` nearest centroids are tried first; faces whose lower bound
    (plane distance and in-plane distance past an edge) exceeds the exact distance of the
    most promising one are skipped. When the best is farther than ``|p - c_k| - radius``
    (``c_k``: the k-th nearest centroid), every face whose centroid lies within
    ``best + radius`` is tried the same way, which includes every face at distance
    ``<= best``.

    Parameters
    ----------
    index : MeshIndex
    points : (n, 3) float
    k : int
    cand, dist_c : (n, k) int, (n, k) float, optional
        The ``k`` nearest centroids' faces and distances, if already queried.
    h, side : (n, k) and (n, k, 3) float, optional
        :func:`plane_and_sides` of ``cand``, if already computed.

    Returns
    -------
    closest : (n, 3) float
    faces : (n,) int
    distance : (n,) float
        Ties between faces at the same distance go to the face with the nearer centroid.
    """
    points = np.asarray(points, dtype=np.float64)
    tri, tree, radius = index.triangles, index.tree, index.radius
    n = len(points)
    closest, face, dist = np.zeros((n, 3)), np.zeros(n, np.int64), np.zeros(n)
    if cand is None or dist_c is None:
        k = min(k, len(tri))
    else:
        k = cand.shape[1]
    for s in range(0, n, _CHUNK):
        p = points[s:s + _CHUNK]
        m = len(p)
        if cand is None or dist_c is None:
            dc, cd = tree.query(p, k=k, workers=-1)
            dc, cd = dc.reshape(m, k), cd.reshape(m, k).astype(np.int64)
            hh, ins = plane_and_sides(index, cd, p)
        else:
            dc, cd = dist_c[s:s + m], cand[s:s + m]
            if h is None or side is None:
                hh, ins = plane_and_sides(index, cd, p)
            else:
                hh, ins = h[s:s + m], side[s:s + m]
        c, f, d = _prune(index, p, np.repeat(np.arange(m), k), cd.ravel(), np.arange(m) * k,
                         _lower_bound(index, cd, hh, ins).ravel(), dc.ravel())
        if k < len(tri):
            unsure = np.flatnonzero(d > dc[:, -1] - radius)
            if len(unsure):
                pu = p[unsure]
                balls = tree.query_ball_point(pu, d[unsure] + radius, workers=-1)
                counts = np.fromiter(map(len, balls), np.int64, len(balls))
                cand2 = np.fromiter(itertools.chain.from_iterable(balls), np.int64,
                                    int(counts.sum()))
                full = np.flatnonzero(counts > 0)  # (an empty ball: rounding; keep pass 1)
                unsure, pu, counts = unsure[full], pu[full], counts[full]
            if len(unsure):
                owner = np.repeat(np.arange(len(full)), counts)
                starts = np.r_[0, np.cumsum(counts)[:-1]]
                h2, in2 = plane_and_sides(index, cand2[:, None], pu[owner])
                lb2 = _lower_bound(index, cand2[:, None], h2, in2)[:, 0]
                rank2 = np.linalg.norm(tree.data[cand2] - pu[owner], axis=1)
                c2, f2, d2 = _prune(index, pu, owner, cand2, starts, lb2, rank2)
                better = d2 <= d[unsure]
                unsure, c2, f2, d2 = unsure[better], c2[better], f2[better], d2[better]
                c[unsure], f[unsure], d[unsure] = c2, f2, d2
        closest[s:s + m], face[s:s + m], dist[s:s + m] = c, f, d
    return closest, face, dist
