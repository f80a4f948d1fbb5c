"""Trinkle's d* for many grasps at once: the hot path of planning and database generation.

Rank first: a Gram/Cholesky bound (:mod:`synth.scores.gram`) certifies full row rank of most
wrench matrices in a few vectorised numpy steps; only the uncertified ones pay for a LAPACK SVD
(about 10 us per matrix), so the ranks equal :func:`synth.scores.wrench.numerical_rank`'s.
Then two exact routes, chosen per grasp:

* Nullity one (7 contacts in space, 4 in the plane, full rank): the null space is a line; its
  unit vector ``v`` comes from the Gram factor (refined) where certified, else from the SVD.
  d* is ``min(v) / max(v)`` when every entry has the same strict sign, else 0.
* Otherwise: substituting ``c = d 1 + (1 - d) f`` with ``0 <= f <= 1`` turns Trinkle's LP into
  ``max s  s.t.  W f + s W 1 = 0,  0 <= f <= 1,  s >= 0`` with ``d* = s / (1 + s)`` (a ray shot
  from the origin along ``-W 1`` into the zonotope ``W [0, 1]^n``). That LP has only m = 6
  (or 3) equality rows, so the batched bounded simplex of :mod:`synth.scores.simplex` keeps
  only m x m basis inverses. As the right-hand side is 0,
  every basis is feasible at the origin, so the simplex starts from a crash basis of real
  columns instead of pivoting the artificials out one degenerate step at a time. Every optimum
  is checked against the LP (a primal point and duals that prove it); anything not verified
  is re-solved with HiGHS.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.scores.gram import GramFactors, gram_factors, rank_of_balanced
from synth.scores.simplex import OPTIMAL, UNBOUNDED, UNVERIFIED, solve_batch
from synth.tolerances import D_STAR_TOL

__all__ = ["BatchScores", "form_closure_batch", "d_star_linprog"]


@dataclass(frozen=True)
class BatchScores:
    """Result of :func:`form_closure_batch`.

    Attributes
    ----------
    d_star : (B,) float
        Trinkle's measure per grasp (0 below ``D_STAR_TOL``).
    closure : (B,) bool
        Form closure: ``d_star > 0`` and full row rank.
    rank : (B,) int
        Numerical rank of each wrench matrix.
    fallback : int
        How many grasps had to be re-solved with HiGHS.
    solve_time : float
        Seconds for the whole batch.
    forces : (B, n) float, optional
        For a grasp with ``d_star > 0``, normal forces that leave the part at rest
        (``W c = 0``) with every entry between ``d_star`` and 1 (the LP's optimum ``c``:
        Trinkle's forces); zeros where ``d_star`` is 0 and for the few grasps the batch
        could not verify, which HiGHS solves again (``fallback``). Given by
        :func:`form_closure_batch`.
    """

    d_star: NDArray[np.float64]
    closure: NDArray[np.bool_]
    rank: NDArray[np.int64]
    fallback: int = 0
    solve_time: float = field(default=0.0, repr=False)
    forces: NDArray[np.float64] | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return int(self.d_star.shape[0])


def d_star_linprog(W: NDArray[np.float64]) -> float:
    """d* of one wrench matrix by a plain HiGHS solve of eq. (12)-(15) (no free columns)."""
    m, n = W.shape
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    A_ub = np.hstack([-np.eye(n), np.ones((n, 1))])
    res = linprog(
        cost,
        A_ub=A_ub,
        b_ub=np.zeros(n),
        A_eq=np.hstack([W, np.zeros((m, 1))]),
        b_eq=np.zeros(m),
        bounds=[(-1.0, 1.0)] * n + [(0.0, None)],
        method="highs",
    )
    if res.status != 0:
        raise SolverError(f"form-closure LP failed: {res.message}")
    return float(res.x[-1])


def _check_batch(W: ArrayLike) -> NDArray[np.float64]:
    try:
        A = np.asarray(W, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InputError(f"W must be a numeric array of shape (B, m, n) ({e})") from e
    if A.ndim != 3 or A.shape[1] not in (3, 6) or A.shape[2] < 1:
        raise InputError(f"W must have shape (B, 6, n) or (B, 3, n), got {A.shape}")
    if not np.all(np.isfinite(A)):
        bad = int(np.nonzero(~np.isfinite(A).all(axis=(1, 2)))[0][0])
        raise InputError(f"W[{bad}] has NaN or infinite entries")
    return A


def form_closure_batch(W: ArrayLike, compiled: bool | None = None,
                       factors: GramFactors | None = None) -> BatchScores:
    """Form-closure measure d*, closure flag and rank of many wrench matrices.

    Gives the same answers as :func:`synth.form_closure` (to 1e-7 on d*) at a small fraction of
    the cost; see ``scripts/bench_closure.py``.

    Parameters
    ----------
    W : (B, m, n) float
        Normal wrench matrices, m = 6 (space) or 3 (plane).
    compiled : bool, optional
        Simplex route for the grasps that need the LP (see
        :func:`synth.scores.simplex.compiled_for`, the default): True for the numba kernel,
        False for numpy. The answers agree to about 1e-12 either way.
    factors : GramFactors, optional
        :func:`synth.scores.gram.gram_factors` of ``W``, when the caller already has them
        (the planner shares them with the hold measure); computed here otherwise.

    Returns
    -------
    BatchScores

    Examples
    --------
    >>> import numpy as np
    >>> from synth import wrench_matrix
    >>> P = np.array([[.5, .3, .1], [-.5, .4, 0], [-.2, .5, -.1], [-.1, -.5, 0],
    ...               [-.1, .2, .5], [-.3, .2, -.5], [-.1, .4, -.5]])
    >>> N = -np.sign(P) * (np.abs(P) == .5)  # inward normals of a unit cube's faces
    >>> res = form_closure_batch(wrench_matrix(P, N)[None])
    >>> res.closure, res.d_star.round(6)
    (array([ True]), array([0.5]))
    """
    t0 = time.perf_counter()
    A = _check_batch(W)
    B, m, n = A.shape
    d = np.zeros(B)
    if B == 0:
        return BatchScores(d, np.zeros(0, bool), np.zeros(0, np.int64), forces=np.zeros((0, n)))
    f = gram_factors(A) if factors is None else factors
    if f.wrenches.shape != A.shape:
        raise InputError(f"factors: of matrices of shape {f.wrenches.shape}, but W has "
                         f"shape {A.shape}")
    Wb, certified = f.balanced, f.certified
    rank = rank_of_balanced(Wb, certified)
    todo = np.ones(B, dtype=bool)
    forces = np.zeros((B, n))
    if n == m + 1:
        # nullity one: the null line gives d* directly (Gram route where certified, else SVD)
        v = f.null.copy()
        other = np.nonzero(~certified & (rank == m))[0]
        if other.size:
            v[other] = np.linalg.svd(Wb[other], full_matrices=True)[2][:, -1, :]
        one = rank == m
        v = v[one]
        v = v * np.sign(v.sum(axis=1, keepdims=True) + (v.sum(axis=1, keepdims=True) == 0))
        vmin, vmax = v.min(axis=1), v.max(axis=1)
        d[one] = np.where(vmin > 0, vmin / np.where(vmax > 0, vmax, 1.0), 0.0)
        forces[one] = np.where((vmin > 0)[:, None], v / np.where(vmax > 0, vmax, 1.0)[:, None],
                               0.0)
        todo = ~one
    fallback = 0
    if todo.any():
        ii = np.nonzero(todo)[0]
        k = ii.size
        # [W, W 1, I] with the rows of [W, W 1] scaled to max-norm 1, built in place
        Afull = np.empty((k, m, n + 1 + m))
        Afull[:, :, :n] = Wb if k == B else Wb[ii]
        Afull[:, :, n] = Afull[:, :, :n].sum(axis=2)
        rowmax = np.abs(Afull[:, :, : n + 1]).max(axis=2, keepdims=True)
        Afull[:, :, : n + 1] /= np.where(rowmax > 0, rowmax, 1.0)
        Afull[:, :, n + 1 :] = np.eye(m)
        hi = np.concatenate([np.ones(n), [np.inf], np.zeros(m)])
        c = np.zeros(n + 1 + m)
        c[n] = 1.0
        sol = solve_batch(Afull, np.zeros((k, m)), c, hi, np.arange(n + 1, n + 1 + m), crash=True,
                          compiled=compiled)
        s = sol.x[:, n]
        d[ii] = np.where(sol.status == UNBOUNDED, 1.0, s / (1.0 + s))
        found = (sol.status == OPTIMAL) & (s > 0)  # c = (f + s 1) / (1 + s), in [d*, 1]
        forces[ii[found]] = (sol.x[found, :n] + s[found, None]) / (1.0 + s[found, None])
        forces[ii[sol.status == UNBOUNDED]] = 1.0  # s unbounded only where W 1 = 0
        bad = ii[sol.status == UNVERIFIED]
        fallback = int(bad.size)
        for j in bad:
            d[j] = d_star_linprog(A[j])
    d = np.where(d > D_STAR_TOL, np.minimum(d, 1.0), 0.0)
    closure = (d > 0) & (rank == m)
    forces[d == 0] = 0.0
    return BatchScores(d, closure, rank, fallback, time.perf_counter() - t0, forces)
