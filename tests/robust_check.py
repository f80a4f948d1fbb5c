"""Independent checks of contact regions (imports nothing from synth).

Closure of a grasp with 7 frictionless contacts is decided here from the signed cofactors of
its wrench matrix (``numpy.linalg.det``) and confirmed with a plain ``scipy.optimize.linprog``
of Trinkle's d*; counterexamples are searched by coordinate descent over region vertices (a
cofactor is affine in each contact's position, so its minimum over a product of polygons is
at a vertex choice).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog


def wrenches(P, N, center, length):
    """(..., 6, k) wrench matrices."""
    P, N = np.asarray(P, float), np.asarray(N, float)
    N = np.broadcast_to(N, P.shape)
    M = np.cross(P - center, N) / length
    return np.concatenate([np.swapaxes(N, -1, -2), np.swapaxes(M, -1, -2)], axis=-2)


def cofactors(W):
    """Signed cofactors (..., k) of (..., 6, 7) matrices: the null vector."""
    k = W.shape[-1]
    return np.stack([(-1) ** j * np.linalg.det(np.delete(W, j, axis=-1)) for j in range(k)],
                    axis=-1)


def d_star_lp(W):
    """Trinkle's d* (box -1 <= c <= 1) by one linprog; 0 when not positive."""
    m, k = W.shape
    res = linprog(np.r_[np.zeros(k), -1.0], A_ub=np.c_[-np.eye(k), np.ones(k)],
                  b_ub=np.zeros(k), A_eq=np.c_[W, np.zeros(m)], b_eq=np.zeros(m),
                  bounds=[(-1, 1)] * k + [(None, None)], method="highs")
    return max(-res.fun, 0.0) if res.status == 0 else 0.0


def d_star_svd(W):
    """d* of (B, 6, 7) matrices with rank 6 from the null vector (-1 where not closure)."""
    s, vt = np.linalg.svd(W)[1:]
    v = vt[:, -1, :]
    v = v * np.sign(v.sum(axis=1, keepdims=True))
    ok = (s[:, -1] > 1e-9 * s[:, 0]) & (v.min(axis=1) > 0)
    return np.where(ok, v.min(axis=1) / v.max(axis=1), -1.0)


def d_star_solve(W):
    """As :func:`d_star_svd`, faster: the null vector is ``[x; 1]`` with
    ``W[:, :6] x = -W[:, 6]`` where that 6 x 6 block is well conditioned (an SVD elsewhere)."""
    with np.errstate(all="ignore"):
        try:
            x = np.linalg.solve(W[:, :, :6], -W[:, :, 6:])[:, :, 0]
        except np.linalg.LinAlgError:
            x = np.full(W.shape[:1] + (6,), np.nan)
    v = np.concatenate([x, np.ones((len(W), 1))], axis=1)
    bad = ~np.isfinite(v).all(axis=1) | (np.abs(v).max(axis=1) > 1e6)
    d = np.where(v.min(axis=1) > 0, v.min(axis=1) / np.abs(v).max(axis=1), -1.0)
    if bad.any():
        d[bad] = d_star_svd(W[bad])
    return d


def sample_polygon(poly, n, rng):
    """n uniform points in a convex polygon given by its corners (any count >= 1)."""
    poly = np.asarray(poly, float)
    if len(poly) == 1:
        return np.repeat(poly, n, axis=0)
    if len(poly) == 2:
        t = rng.uniform(size=(n, 1))
        return poly[0] + t * (poly[1] - poly[0])
    a, b, c = poly[0], poly[1:-1], poly[2:]
    area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    tri = rng.choice(len(area), size=n, p=area / area.sum())
    r1, r2 = rng.uniform(size=(2, n, 1))
    s = np.sqrt(r1)
    return a * (1 - s) + b[tri] * (s * (1 - r2)) + c[tri] * (s * r2)


def worst_vertex_choice(P, N, polygons, center, length, rng, starts=6, sweeps=8):
    """Smallest oriented, normalised cofactor found over vertex choices of the regions.

    Returns (value, points): value <= 0 means a choice that is not form closure."""
    P, N = np.asarray(P, float), np.asarray(N, float)
    c0 = cofactors(wrenches(P, N, center, length))
    sign = np.sign(c0.sum())
    scale = np.abs(c0).max()
    best, best_pts = np.inf, P.copy()
    k = len(P)
    for j in range(k):
        for s in range(starts):
            pick = [0 if s == 0 else rng.integers(len(p)) for p in polygons]
            for _ in range(sweeps):
                changed = False
                for i in range(k):
                    cand = np.repeat(np.array([polygons[c][pick[c]] for c in range(k)])[None],
                                     len(polygons[i]), axis=0)
                    cand[:, i] = polygons[i]
                    val = sign * cofactors(wrenches(cand, N, center, length))[:, j] / scale
                    a = int(val.argmin())
                    if a != pick[i] and val[a] < val[pick[i]] - 1e-15:
                        pick[i], changed = a, True
                if not changed:
                    break
            pts = np.array([polygons[c][pick[c]] for c in range(k)])
            v = sign * cofactors(wrenches(pts, N, center, length))[j] / scale
            if v < best:
                best, best_pts = v, pts
    return best, best_pts


def tangent_discs(P, N, kinds, polygons, r, m=64):
    """Each contact's disc of radius r on its feature as polygons ON the circle (so a vertex
    choice is a real placement): a disc in the tangent plane for "plane", the segment along
    the edge for "edge", the point for others."""
    out = []
    for p, n, kind, poly in zip(P, N, kinds, polygons, strict=True):
        if kind == "plane":
            a = np.eye(3)[np.argmin(np.abs(n))]
            u = np.cross(n, a)
            u /= np.linalg.norm(u)
            v = np.cross(n, u)
            t = np.arange(m) * 2 * np.pi / m
            out.append(p + r * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v))
        elif kind == "edge":
            e = np.asarray(poly[1], float) - np.asarray(poly[0], float)
            e /= np.linalg.norm(e)
            out.append(np.array([p - r * e, p + r * e]))
        else:
            out.append(np.asarray(p, float)[None])
    return out
