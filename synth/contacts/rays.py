"""Contacts from approach rays: a finger moving along a direction hits the surface."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import trimesh

from synth.contacts.contacts import Contacts
from synth.errors import InputError

if TYPE_CHECKING:
    from synth.part.model import Part

__all__ = ["contacts_from_rays", "first_hits"]

_FORWARD = -1e-6  # trimesh: a hit counts when its distance along the ray exceeds this
_SEGMENTS_PER_ROUND = 4
_RAY_CHUNK = 4096
_MAX_SEGMENTS = 512
_STEP = 12.0  # segment length, in median triangle extents


def _narrow(tri: np.ndarray, normals: np.ndarray, o: np.ndarray, d: np.ndarray,
            cand: np.ndarray, ray: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """trimesh's exact ray/triangle test (``ray_triangle_id``) on candidate pairs.

    Parameters
    ----------
    tri : (f, 3, 3) float
    normals : (f, 3) float
        Face normals (as trimesh uses them).
    o, d : (r, 3) float
        Ray origins and unit directions.
    cand, ray : (c,) int
        Candidate triangle and its ray.

    Returns
    -------
    tri_idx, ray_idx : (h,) int
    location : (h, 3) float
    distance : (h,) float
        Hits that trimesh would report, with the same arithmetic.
    """
    tc = tri[cand]
    location, valid = trimesh.intersections.planes_lines(
        plane_origins=tc[:, 0, :], plane_normals=normals[cand],
        line_origins=o[ray], line_directions=d[ray])
    bary = trimesh.triangles.points_to_barycentric(tc[valid], location)
    zero = trimesh.tol.zero
    hit = (bary > -zero).all(axis=1) & (bary < 1 + zero).all(axis=1)
    ti, ri, loc = cand[valid][hit], ray[valid][hit], location[hit]
    dist = trimesh.util.diagonal_dot(loc - o[ri], d[ri])
    fw = dist > _FORWARD
    return ti[fw], ri[fw], loc[fw], dist[fw]


def _slab(o: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """Parameter interval (r,), (r,) of each ray inside the box ``[lo, hi]`` (empty: a > b)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1, t2 = (lo - o) * inv, (hi - o) * inv
    flat = d == 0
    inside = (o >= lo) & (o <= hi)
    t1 = np.where(flat, np.where(inside, -np.inf, np.inf), t1)
    t2 = np.where(flat, np.where(inside, np.inf, -np.inf), t2)
    return np.minimum(t1, t2).max(axis=1), np.maximum(t1, t2).min(axis=1)


def first_hits(part: Part, origins: np.ndarray, directions: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First hit of each ray, identical to trimesh's ``intersects_location`` (no embree).

    Each ray is cut into short segments inside the mesh bounds; segments are queried
    against the triangle r-tree in order, a few per round, and a ray stops once its
    nearest hit lies within the segments already searched. The exact test on the
    candidates is trimesh's (same arithmetic, ``multiple_hits=False``); a ray whose nearest
    hit is an exact tie between faces is re-done with trimesh so the same face wins.

    Parameters
    ----------
    part : Part
    origins : (r, 3) float
    directions : (r, 3) float
        Unit directions.

    Returns
    -------
    locations : (h, 3) float
    ray_idx : (h,) int
        Sorted ray index of each hit (rays that miss are absent).
    tri_idx : (h,) int
    """
    mesh = part.mesh
    tri = part._corners()
    normals = np.asarray(mesh.face_normals, float)
    tree = mesh.triangles_tree
    n_f = len(tri)
    pad = 1e-9 * part.length + 1e-12
    lo, hi = tri.min(axis=(0, 1)) - pad, tri.max(axis=(0, 1)) + pad
    ext = np.ptp(tri, axis=1).max(axis=1)
    step = max(_STEP * float(np.median(ext)), part.length / _MAX_SEGMENTS, pad)
    out_loc, out_ray, out_tri = [], [], []
    for s in range(0, len(origins), _RAY_CHUNK):
        o, d = origins[s:s + _RAY_CHUNK], directions[s:s + _RAY_CHUNK]
        ta, tb = _slab(o, d, lo, hi)
        ta = np.maximum(ta, 2 * _FORWARD - pad)
        active = np.flatnonzero(ta <= tb)
        best_t = np.full(len(o), np.inf)
        hits: list[tuple[np.ndarray, ...]] = []
        j0 = 0
        while len(active):
            r = np.repeat(active, _SEGMENTS_PER_ROUND)
            t0 = ta[r] + np.tile(j0 + np.arange(_SEGMENTS_PER_ROUND), len(active)) * step
            keep = t0 <= tb[r]
            r, t0 = r[keep], t0[keep]
            t1 = np.minimum(t0 + step, tb[r])
            p0, p1 = o[r] + t0[:, None] * d[r], o[r] + t1[:, None] * d[r]
            ids, counts = tree.intersection_v(np.minimum(p0, p1) - pad,
                                              np.maximum(p0, p1) + pad)
            key = np.unique(np.repeat(r, np.asarray(counts, np.int64)) * n_f
                            + np.asarray(ids, np.int64))
            h = _narrow(tri, normals, o, d, key % n_f, key // n_f)
            if len(h[0]):
                hits.append(h)
                np.minimum.at(best_t, h[1], h[3])
            j0 += _SEGMENTS_PER_ROUND
            end = ta[active] + j0 * step
            done = (best_t[active] <= end) | (end >= tb[active])
            active = active[~done]
        if not hits:
            continue
        ti, ri, loc, dist = (np.concatenate(x) for x in zip(*hits, strict=True))
        # one row per (ray, face), the first found; then nearest per ray
        _, u = np.unique(ri * n_f + ti, return_index=True)
        ti, ri, loc, dist = ti[u], ri[u], loc[u], dist[u]
        order = np.lexsort((dist, ri))
        ti, ri, loc, dist = ti[order], ri[order], loc[order], dist[order]
        fr = np.flatnonzero(np.r_[True, ri[1:] != ri[:-1]])
        nxt = np.minimum(fr + 1, len(ri) - 1)
        tie = (nxt != fr) & (ri[nxt] == ri[fr]) & (dist[nxt] == dist[fr])
        ok = fr[~tie]
        out_loc.append(loc[ok])
        out_ray.append(ri[ok] + s)
        out_tri.append(ti[ok])
        redo = ri[fr[tie]]
        if len(redo):  # exact tie between faces: let trimesh pick, as before
            lr, rr, tr = _first_hits_trimesh(part, o[redo], d[redo])
            out_loc.append(lr)
            out_ray.append(redo[rr] + s)
            out_tri.append(tr)
    if not out_ray:
        return np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64)
    loc, ray, tri_idx = np.concatenate(out_loc), np.concatenate(out_ray), np.concatenate(out_tri)
    order = np.argsort(ray, kind="stable")
    return loc[order], ray[order], tri_idx[order]


def _first_hits_trimesh(part: Part, o: np.ndarray, d: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference: trimesh's own search (every triangle in each ray's box)."""
    locs, ray_idx, tri_idx = part.mesh.ray.intersects_location(o, d, multiple_hits=False)
    ray_idx = np.asarray(ray_idx, np.int64)
    order = np.argsort(ray_idx, kind="stable")
    return (np.asarray(locs, float).reshape(-1, 3)[order], ray_idx[order],
            np.asarray(tri_idx, np.int64)[order])


def contacts_from_rays(part: Part, origins: np.ndarray, directions: np.ndarray) -> Contacts:
    """Resolve the first hit of each ray on the part's surface.

    Parameters
    ----------
    part : Part
    origins : (r, 3) float
        Start points of the fingertips (outside the part).
    directions : (r, 3) float
        Approach directions (any non-zero length).

    Returns
    -------
    Contacts
        Contacts of the rays that hit, resolved as in :meth:`Part.resolve`; ``finger`` is
        the index of the ray, so rays that miss have no rows and a ray hitting a groove
        gives two rows with its index.

    Examples
    --------
    >>> c = contacts_from_rays(part, [[0, 0, 5.0]], [[0, 0, -1.0]])  # doctest: +SKIP
    """
    from synth.part.model import Part
    from synth.part.points import xyz_rows

    if not isinstance(part, Part):
        raise InputError(f"contacts_from_rays: part must be a synth Part (synth.load_part), "
                         f"got {type(part).__name__}")
    o = xyz_rows(origins, "origins") if np.size(origins) else np.zeros((0, 3))
    d = xyz_rows(directions, "directions", len(o)) if np.size(directions) else np.zeros((0, 3))
    if d.shape != o.shape:
        raise InputError(f"directions: expected shape {o.shape} like origins, got {d.shape}")
    norm = np.linalg.norm(d, axis=1)
    if (norm <= 0).any():
        raise InputError(f"directions: row {int(np.argmin(norm))} has zero length")
    d = d / norm[:, None]
    locs, ray_idx, tri_idx = first_hits(part, o, d)
    c = part.resolve(locs, tri_idx, snap=True)
    return replace(c, finger=ray_idx[c.finger])
