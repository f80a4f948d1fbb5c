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
from synth.scores.simplex import UNBOUNDED, UNVERIFIED, compiled_for, solve_batch
from synth.scores.wrench import balance_rows
from synth.tolerances import D_STAR_TOL

__all__ = ["frictional_form_closure_batch", "friction_edge_wrenches_batch"]

#: Grasps per block of LPs: a block's matrices (about 8 kB a grasp at 7 contacts) stay in cache.
_CHUNK = 512


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
    mu_k = np.broadcast_to(np.asarray(mu, dtype=np.float64), (k,))[None, :, None]
    Mu, Mv = mu_k * u.reshape(B, k, 3), mu_k * v.reshape(B, k, 3)
    R = points - np.asarray(center, dtype=np.float64).reshape(-1, 1, 3)
    # edge j of contact i is n + mu (cos a_j u + sin a_j v), its wrench linear in (n, mu u, mu v):
    # basis[:, row, i] holds the wrenches of those three, and one matmul spreads them to edges
    basis = np.empty((B, 6, k, 3))
    for col, F in enumerate((N, Mu, Mv)):
        basis[:, :3, :, col] = F.transpose(0, 2, 1)
        basis[:, 3:, :, col] = np.cross(R, F).transpose(0, 2, 1)
    a = 2.0 * np.pi * np.arange(edges) / edges
    G = basis.reshape(-1, 3) @ np.stack([np.ones(edges), np.cos(a), np.sin(a)])  # one GEMM
    return G.reshape(B, 6, k * edges)


def frictional_form_closure_batch(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
    compiled: bool | None = None,
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
    compiled : bool, optional
        Simplex route (see :func:`synth.scores.simplex.compiled_for`, the default): True for
        the numba kernel, False for numpy.

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
    o = P.mean(axis=1) if center is None else np.broadcast_to(
        np.asarray(center, dtype=np.float64), (B, 3))
    d = np.zeros(B)
    rank = np.zeros(B, dtype=np.int64)
    # columns: lam' (nE) | s | g (k) | artificials (6); rows: 6 wrench rows | k contact rows
    nE = k * E
    template = np.zeros((6 + k, nE + 1 + k + 6))
    template[:6, nE + 1 + k :] = np.eye(6)
    template[6:, :nE] = -np.kron(np.eye(k), np.ones((1, E)))
    template[6:, nE] = 1.0
    template[6:, nE + 1 : nE + 1 + k] = np.eye(k)
    hi = np.concatenate([np.full(nE + 1, np.inf), np.ones(k), np.zeros(6)])
    c = np.zeros(nE + 1 + k + 6)
    c[nE] = 1.0
    basis0 = np.concatenate([np.arange(nE + 1 + k, nE + 1 + k + 6), np.arange(nE + 1, nE + 1 + k)])
    unverified = []
    if compiled is None:
        compiled = compiled_for(B)  # for the whole batch, not per chunk
    A_all = np.empty((min(B, _CHUNK),) + template.shape)  # one buffer: only G's block changes
    A_all[:] = template
    for lo in range(0, B, _CHUNK):  # chunks keep the LP matrices in cache
        sl = slice(lo, min(lo + _CHUNK, B))
        G = friction_edge_wrenches_batch(P[sl], N[sl], mu_a, o[sl], E)
        rank[sl] = rank_of_balanced(balance_rows(G)[0])  # a Gram certificate, else the SVD
        A = A_all[: G.shape[0]]
        rowmax = np.abs(G).max(axis=2, keepdims=True)  # rows scaled to max-norm 1
        np.divide(G, np.where(rowmax > 0, rowmax, 1.0), out=A[:, :6, :nE])
        sol = solve_batch(A, np.zeros((G.shape[0], 6 + k)), c, hi, basis0, crash=True,
                          compiled=compiled)
        s = sol.x[:, nE]
        d[sl] = np.where(sol.status == UNBOUNDED, 1.0, s / (1.0 + s))
        unverified.append(lo + np.nonzero(sol.status == UNVERIFIED)[0])
    bad = np.concatenate(unverified)
    for j in bad:
        d[j] = frictional_form_closure(P[j], N[j], mu_a, center=None, edges=E).d_star
    d = np.where(d > D_STAR_TOL, np.minimum(d, 1.0), 0.0)
    closure = (d > 0) & (rank == 6)
    return BatchScores(d, closure, rank, int(bad.size), time.perf_counter() - t0)
