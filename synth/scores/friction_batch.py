"""Trinkle's frictional d* (see :mod:`synth.scores.friction`) for many grasps at once.

Dividing the edge intensities by ``1 - d`` (``lam' = lam / (1 - d)``, ``s = d / (1 - d)``) turns
the constraints ``d <= sum_j lam_ij <= 1`` into ``sum_j lam'_ij = s + g_i`` with
``0 <= g_i <= 1``, and the frictional LP into

    maximise s  s.t.  G lam' = 0,   s + g_i - sum_j lam'_ij = 0 (each contact),
                      lam' >= 0,   0 <= g <= 1,   s >= 0,

with ``d* = s / (1 + s)``: 6 equality rows plus one row per contact and a zero right-hand
side, so every basis is feasible at the origin and the bounded simplex of
:mod:`synth.scores.simplex` starts from a crash basis for the whole batch at once; optima not
verified are re-solved with HiGHS (:func:`synth.scores.friction_lp.solve_frictional_lp`, the
LP :func:`synth.frictional_form_closure` solves). Soft contacts (``torsion > 0``) only change
the generators (:mod:`synth.scores.cones`).
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import ArrayLike

from synth.errors import InputError
from synth.scores.arguments import center_arg, edges_arg, numbers_arg
from synth.scores.batch import BatchScores
from synth.scores.cones import check_contacts_batch, cone_wrenches_batch, generators_per_contact
from synth.scores.friction_lp import solve_frictional_lp
from synth.scores.gram import rank_of_balanced
from synth.scores.simplex import UNBOUNDED, UNVERIFIED, compiled_for, solve_batch
from synth.scores.wrench import balance_rows
from synth.tolerances import D_STAR_TOL

__all__ = ["frictional_form_closure_batch"]

#: Grasps per block of LPs: a block's matrices (about 8 kB a grasp at 7 contacts) stay in cache.
_CHUNK = 512


def frictional_form_closure_batch(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
    compiled: bool | None = None,
    torsion: ArrayLike = 0.0,
) -> BatchScores:
    """Frictional d*, closure flag and rank of many spatial grasps.

    Same answers as :func:`synth.frictional_form_closure` (to 1e-7 on d*).

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and inward normals.
    mu : float, (k,) or (B, k) float
        Coulomb coefficient: shared, one per contact position, or one per contact of each
        grasp (>= 0; some mu or torsion > 0: use :func:`synth.form_closure_batch` without
        friction).
    center : (3,) float, optional
        Moment reference (default: each grasp's centroid); d* does not depend on it.
    edges : int
        Cone edges (>= 3).
    compiled : bool, optional
        Simplex route (see :func:`synth.scores.simplex.compiled_for`, the default): True for
        the numba kernel, False for numpy.
    torsion : float, (k,) or (B, k) float
        Torsional coefficients of soft contacts, lengths in the points' unit (default 0:
        point contacts); see :mod:`synth.scores.cones`.

    Returns
    -------
    BatchScores
        ``closure`` is frictional form closure.
    """
    t0 = time.perf_counter()
    P, N = check_contacts_batch(points, normals)
    B, k, _ = P.shape
    mu_a = numbers_arg(mu, "mu")
    gam = numbers_arg(torsion, "torsion")
    for name, a in (("mu", mu_a), ("torsion", gam)):
        if a.shape not in ((), (k,), (B, k)) or not np.all(np.isfinite(a)) or np.any(a < 0):
            raise InputError(f"{name} must be finite and >= 0: one value, {k} or ({B}, {k}), "
                             f"got shape {a.shape}")
    if not (np.any(mu_a > 0) or np.any(gam > 0)):
        raise InputError("mu or torsion must be somewhere > 0 (use form_closure_batch "
                         "without friction)")
    edges = edges_arg(edges)
    mu_b = np.broadcast_to(mu_a, (B, k))
    gam_b = np.broadcast_to(gam, (B, k))
    if B == 0:
        return BatchScores(np.zeros(0), np.zeros(0, bool), np.zeros(0, np.int64))
    o = P.mean(axis=1) if center is None else np.broadcast_to(center_arg(center), (B, 3))
    d = np.zeros(B)
    rank = np.zeros(B, dtype=np.int64)
    soft = bool(np.any(gam_b > 0))
    E = generators_per_contact(edges, soft)
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
        G = cone_wrenches_batch(P[sl], N[sl], mu_b[sl], o[sl], edges, gam_b[sl], soft)
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
        G = cone_wrenches_batch(P[j : j + 1], N[j : j + 1], mu_b[j : j + 1], o[j : j + 1],
                                edges, gam_b[j : j + 1], soft)[0]
        d[j] = solve_frictional_lp(G, k)[0]
    d = np.where(d > D_STAR_TOL, np.minimum(d, 1.0), 0.0)
    closure = (d > 0) & (rank == 6)
    return BatchScores(d, closure, rank, int(bad.size), time.perf_counter() - t0)
