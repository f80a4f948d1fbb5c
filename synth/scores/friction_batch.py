"""Trinkle's frictional d* (see :mod:`synth.scores.friction`) for many grasps at once.

Dividing the edge intensities by ``1 - d`` (``lam' = lam / (1 - d)``, ``s = d / (1 - d)``) turns
the constraints ``d <= sum_j lam_ij <= 1`` into ``sum_j lam'_ij = s + g_i`` with
``0 <= g_i <= 1``, and the frictional LP into

    maximise s  s.t.  G lam' = 0,   s + g_i - sum_j lam'_ij = 0 (each contact),
                      lam' >= 0,   0 <= g <= 1,   s >= 0,

with ``d* = s / (1 + s)``: 6 equality rows plus one row per contact and a zero right-hand
side, so every basis is feasible at the origin and the bounded simplex of
:mod:`synth.scores.simplex` starts from a crash basis for the whole batch at once; optima not
verified are re-solved with HiGHS through :func:`synth.frictional_form_closure`.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import ArrayLike, NDArray

from synth.errors import InputError
from synth.scores.batch import BatchScores
from synth.scores.friction import frictional_form_closure, tangent_basis
from synth.scores.gram import rank_of_balanced
from synth.scores.simplex import UNBOUNDED, UNVERIFIED, solve_batch
from synth.scores.wrench import balance_rows
from synth.tolerances import D_STAR_TOL

__all__ = ["frictional_form_closure_batch", "friction_edge_wrenches_batch"]


def friction_edge_wrenches_batch(
    points: NDArray[np.float64],
    normals: NDArray[np.float64],
    mu: float | NDArray[np.float64],
    center: NDArray[np.float64],
    edges: int,
) -> NDArray[np.float64]:
    """Edge wrenches of linearised cones for a batch of spatial grasps.

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and unit inward normals.
    mu : float or (k,) float
        Friction coefficient, shared or one per contact.
    center : (3,) or (B, 3) float
        Moment reference.
    edges : int

    Returns
    -------
    G : (B, 6, k * edges) float
        Column ``i * edges + j`` is edge ``j`` of contact ``i`` (as in
        :func:`synth.friction_cone_wrenches`).
    """
    B, k, _ = points.shape
    N = normals / np.linalg.norm(normals, axis=2, keepdims=True)
    u, v = tangent_basis(N.reshape(-1, 3))
    u, v = u.reshape(B, k, 1, 3), v.reshape(B, k, 1, 3)
    a = 2.0 * np.pi * np.arange(edges) / edges
    mu_b = np.asarray(mu, dtype=np.float64).reshape(1, -1, 1, 1)
    F = N[:, :, None, :] + mu_b * (np.cos(a)[None, None, :, None] * u
                                   + np.sin(a)[None, None, :, None] * v)
    R = points - np.asarray(center, dtype=np.float64).reshape(-1, 1, 3)
    tau = np.cross(R[:, :, None, :], F)
    return np.concatenate([F, tau], axis=3).reshape(B, k * edges, 6).transpose(0, 2, 1)


def frictional_form_closure_batch(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
) -> BatchScores:
    """Frictional d*, closure flag and rank of many spatial grasps.

    Same answers as :func:`synth.frictional_form_closure` (to 1e-7 on d*).

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and inward normals.
    mu : float or (k,) float
        Coulomb coefficient, shared or one per contact position (>= 0, some > 0; use
        :func:`synth.form_closure_batch` without friction).
    center : (3,) float, optional
        Moment reference (default: each grasp's centroid); d* does not depend on it.
    edges : int
        Cone edges (>= 3).

    Returns
    -------
    BatchScores
        ``closure`` is frictional form closure.
    """
    t0 = time.perf_counter()
    P = np.asarray(points, dtype=np.float64)
    N = np.asarray(normals, dtype=np.float64)
    if P.ndim != 3 or P.shape[2] != 3 or N.shape != P.shape:
        raise InputError(f"points and normals must both have shape (B, k, 3), got {P.shape} "
                         f"and {N.shape}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(N))):
        raise InputError("points and normals must be finite")
    B, k, _ = P.shape
    mu_a = np.asarray(mu, dtype=np.float64)
    if mu_a.shape not in ((), (k,)) or not np.all(np.isfinite(mu_a)) or np.any(mu_a < 0) or \
            not np.any(mu_a > 0):
        raise InputError(f"mu must be finite, >= 0 and somewhere > 0, one value or {k}, got "
                         f"{mu!r}")
    if int(edges) != edges or edges < 3:
        raise InputError(f"edges must be an integer >= 3, got {edges!r}")
    E = int(edges)
    if B == 0:
        return BatchScores(np.zeros(0), np.zeros(0, bool), np.zeros(0, np.int64))
    o = P.mean(axis=1) if center is None else np.asarray(center, dtype=np.float64)
    G = friction_edge_wrenches_batch(P, N, mu_a, o, E)
    Gb, _ = balance_rows(G)
    rank = rank_of_balanced(Gb)  # a Gram certificate, the SVD only where it cannot tell
    nE = k * E
    # columns: lam' (nE) | s | g (k) | artificials (6); rows: 6 wrench rows | k contact rows
    rowmax = np.abs(Gb).max(axis=2, keepdims=True)
    A = np.zeros((B, 6 + k, nE + 1 + k + 6))
    A[:, :6, :nE] = Gb / np.where(rowmax > 0, rowmax, 1.0)
    A[:, :6, nE + 1 + k :] = np.eye(6)
    A[:, 6:, :nE] = -np.kron(np.eye(k), np.ones((1, E)))
    A[:, 6:, nE] = 1.0
    A[:, 6:, nE + 1 : nE + 1 + k] = np.eye(k)
    hi = np.concatenate([np.full(nE + 1, np.inf), np.ones(k), np.zeros(6)])
    c = np.zeros(nE + 1 + k + 6)
    c[nE] = 1.0
    basis0 = np.concatenate([np.arange(nE + 1 + k, nE + 1 + k + 6), np.arange(nE + 1, nE + 1 + k)])
    sol = solve_batch(A, np.zeros((B, 6 + k)), c, hi, basis0, crash=True)
    s = sol.x[:, nE]
    d = np.where(sol.status == UNBOUNDED, 1.0, s / (1.0 + s))
    bad = np.nonzero(sol.status == UNVERIFIED)[0]
    for j in bad:
        d[j] = frictional_form_closure(P[j], N[j], mu_a, center=None, edges=E).d_star
    d = np.where(d > D_STAR_TOL, np.minimum(d, 1.0), 0.0)
    closure = (d > 0) & (rank == 6)
    return BatchScores(d, closure, rank, int(bad.size), time.perf_counter() - t0)
