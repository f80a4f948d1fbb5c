"""A batched bounded-variable primal simplex, in numpy, for many small LPs at once.

Solves, for each of ``B`` problems of the same shape,

    maximise  c^T x   subject to  A x = b,  0 <= x <= hi,

starting from a basis whose columns form the identity (slacks or artificials fixed at 0) and
which is feasible with every other variable at 0. All problems pivot in lock step; finished
ones drop out of the working set. Pricing is Dantzig's rule, switching to Bland's rule (which
cannot cycle) for a problem after a run of degenerate pivots. Every answer is then verified from
scratch: the final basis is refactorised, the basic values and the duals are recomputed and
primal and dual feasibility are checked. A problem whose check fails (or that hits the
iteration cap) is reported as unverified so the caller can re-solve it another way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from synth.tolerances import LP_FEAS_TOL

__all__ = ["BatchLP", "solve_batch"]

_PIVOT_TOL = 1e-9
_DEGENERATE_RUN = 8
OPTIMAL, UNBOUNDED, UNVERIFIED = 0, 1, 2


@dataclass(frozen=True)
class BatchLP:
    """Solutions of :func:`solve_batch`.

    Attributes
    ----------
    x : (B, N) float
        Optimal points (meaningful where ``status == 0``).
    objective : (B,) float
        ``c^T x``; ``inf`` where unbounded.
    status : (B,) int
        0 optimal and verified, 1 unbounded, 2 not verified (re-solve another way).
    iterations : (B,) int
        Simplex iterations (pivots and bound flips) per problem.
    """

    x: NDArray[np.float64]
    objective: NDArray[np.float64]
    status: NDArray[np.int64]
    iterations: NDArray[np.int64]


def solve_batch(
    A: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    hi: NDArray[np.float64],
    basis0: NDArray[np.int64],
    max_iter: int = 500,
) -> BatchLP:
    """Solve ``B`` bounded LPs ``max c^T x, A x = b, 0 <= x <= hi`` in lock step.

    Parameters
    ----------
    A : (B, M, N) float
        Constraint matrices; ``A[:, :, basis0]`` must be the identity.
    b : (B, M) float
        Right-hand sides, with ``0 <= b <= hi[basis0]`` (the start is feasible).
    c : (N,) float
        Objective, shared by all problems.
    hi : (N,) float
        Upper bounds (``inf`` allowed); ``hi = 0`` fixes a variable at 0 (artificials).
    basis0 : (M,) int
        Initial basic columns.
    max_iter : int
        Iteration cap; problems still running are reported unverified.

    Returns
    -------
    BatchLP
    """
    Bn, M, N = A.shape
    x_out = np.zeros((Bn, N))
    status = np.full(Bn, UNVERIFIED, dtype=np.int64)
    iters = np.zeros(Bn, dtype=np.int64)
    movable = hi > 0
    # working set
    idx = np.arange(Bn)
    T = A.astype(np.float64, copy=True)
    xB = b.astype(np.float64, copy=True)
    basis = np.broadcast_to(basis0, (Bn, M)).copy()
    is_basic = np.zeros((Bn, N), dtype=bool)
    is_basic[:, basis0] = True
    at_upper = np.zeros((Bn, N), dtype=bool)
    r = c[None, :] - np.einsum("m,bmn->bn", c[basis0], T)  # reduced costs
    stash: list[tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]] = []
    degen = np.zeros(Bn, dtype=np.int64)
    hi_b = np.where(np.isinf(hi), np.inf, hi)
    for _ in range(max_iter):
        if idx.size == 0:
            break
        ar = np.arange(idx.size)
        elig = ~is_basic & movable & np.where(at_upper, r < -LP_FEAS_TOL, r > LP_FEAS_TOL)
        has = elig.any(axis=1)
        bland = degen >= _DEGENERATE_RUN
        q = np.where(bland, np.argmax(elig, axis=1), np.argmax(np.where(elig, np.abs(r), -1.0), 1))
        sig = np.where(at_upper[ar, q], -1.0, 1.0)
        alpha = sig[:, None] * T[ar, :, q]
        loB_gap = xB  # lower bounds are all 0
        hiB = hi_b[basis]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(
                alpha > _PIVOT_TOL,
                loB_gap / alpha,
                np.where(alpha < -_PIVOT_TOL, (hiB - xB) / -alpha, np.inf),
            )
        ratio = np.maximum(ratio, 0.0)
        theta_r = ratio.min(axis=1)
        ties = ratio <= theta_r[:, None] + 1e-12
        p = np.where(
            bland,
            np.argmin(np.where(ties, basis, N + 1), axis=1),
            np.argmax(np.where(ties, np.abs(alpha), -1.0), axis=1),
        )
        theta_f = hi_b[q]
        flip = np.isfinite(theta_f) & (theta_f <= theta_r)
        unbounded = has & ~flip & np.isinf(theta_r)
        step = has & ~unbounded
        theta = np.where(step, np.where(flip, theta_f, theta_r), 0.0)
        theta = np.where(np.isfinite(theta), theta, 0.0)
        xB -= theta[:, None] * alpha
        fl = step & flip
        at_upper[ar[fl], q[fl]] ^= True
        piv = step & ~flip
        if piv.any():
            leave = basis[ar, p]
            pi = ar[piv]
            hit_upper = alpha[pi, p[piv]] < 0
            at_upper[pi, leave[piv]] = hit_upper
            is_basic[pi, leave[piv]] = False
            is_basic[pi, q[piv]] = True
            at_upper[pi, q[piv]] = False
            xB[pi, p[piv]] = np.where(sig[piv] > 0, theta[piv], hi_b[q[piv]] - theta[piv])
            basis[pi, p[piv]] = q[piv]
            pv = np.where(piv, T[ar, p, q], 1.0)
            rowp = T[ar, p, :] / pv[:, None]
            colq = T[ar, :, q] * piv[:, None]
            T -= colq[:, :, None] * rowp[:, None, :]
            T[pi, p[piv], :] = rowp[piv]
            r -= (r[ar, q] * piv)[:, None] * rowp
        degen = np.where(step & (theta <= 1e-12), degen + 1, 0)
        iters[idx] += step
        done = ~has | unbounded
        if done.any():
            status[idx[unbounded]] = UNBOUNDED
            keep = ~done
            # record the final basis of finished problems for verification below
            fin = done & ~unbounded
            stash.append((idx[fin], basis[fin].copy(), at_upper[fin].copy()))
            idx, T, xB, basis = idx[keep], T[keep], xB[keep], basis[keep]
            is_basic, at_upper, r, degen = is_basic[keep], at_upper[keep], r[keep], degen[keep]
    if stash:
        which = np.concatenate([w for w, _, _ in stash])
        bases = np.concatenate([bs for _, bs, _ in stash])
        uppers = np.concatenate([u for _, _, u in stash])
        if which.size:
            x_v, ok = _verify(A[which], b[which], c, hi_b, bases, uppers)
            x_out[which] = x_v
            status[which[ok]] = OPTIMAL
    obj = np.where(status == UNBOUNDED, np.inf, x_out @ c)
    return BatchLP(x=x_out, objective=obj, status=status, iterations=iters)


def _verify(
    A: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    hi: NDArray[np.float64],
    basis: NDArray[np.int64],
    upper: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Refactorise each final basis, recompute x and duals, check optimality."""
    K, M, N = A.shape
    ar = np.arange(K)
    x = np.where(upper, np.where(np.isinf(hi), 0.0, hi), 0.0)
    nonbasic = np.ones((K, N), dtype=bool)
    nonbasic[ar[:, None], basis] = False
    x = np.where(nonbasic, x, 0.0)
    Bm = np.take_along_axis(A, basis[:, None, :], axis=2)  # (K, M, M)
    rhs = b - np.einsum("kmn,kn->km", A, x)
    try:
        xB = np.linalg.solve(Bm, rhs[..., None])[..., 0]
        y = np.linalg.solve(np.transpose(Bm, (0, 2, 1)), c[basis][..., None])[..., 0]
    except np.linalg.LinAlgError:  # a singular final basis somewhere: let the caller re-solve
        return x, np.zeros(K, dtype=bool)
    res_p = np.abs(np.einsum("kmj,kj->km", Bm, xB) - rhs).max(axis=1)
    ok = np.isfinite(xB).all(axis=1) & (res_p <= LP_FEAS_TOL * (1.0 + np.abs(xB).max(axis=1)))
    x[ar[:, None], basis] = xB
    red = c[None, :] - np.einsum("km,kmn->kn", y, A)
    scale = 1.0 + np.abs(xB).max(axis=1)
    primal = (xB >= -LP_FEAS_TOL * scale[:, None]) & (xB <= hi[basis] + LP_FEAS_TOL * scale[:, None])
    movable = hi > 0
    dual_bad = nonbasic & movable[None, :] & np.where(upper, red < -1e-7, red > 1e-7)
    ok &= primal.all(axis=1) & ~dual_bad.any(axis=1)
    return np.clip(x, 0.0, np.where(np.isinf(hi), np.inf, hi)), ok
