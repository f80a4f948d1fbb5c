"""A batched bounded-variable primal simplex for many small LPs at once.

Solves, for each of ``B`` problems of the same shape,

    maximise  c^T x   subject to  A x = b,  0 <= x <= hi,

starting from a basis whose columns form the identity (slacks or artificials fixed at 0) and
which is feasible with every other variable at 0 (optionally, when ``b = 0``, a crash basis of
movable columns replaces the artificials first). Pricing is Dantzig's rule, switching to
Bland's rule (which cannot cycle) for a problem after a run of degenerate pivots.

Two routes run the same pivot rules. In numpy, all problems pivot in lock step, in revised
form: each keeps its basis inverse, updated by a batched rank-one correction per pivot, and
prices the columns from its duals; finished ones leave the working set in batches. With numba
installed, :mod:`synth.scores.simplex_compiled` pivots each problem's own dense tableau in
compiled code, which is 3-4x faster on large batches (:func:`compiled_for` chooses).

Either way, every answer is then checked against the LP itself: the final point must satisfy
``A x = b`` and its bounds, and its duals must price every basic column at zero and no
nonbasic column out of its bound, which proves optimality by LP duality. A problem that fails
the check (or hits the iteration cap) is reported as unverified so the caller can re-solve it
another way.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError, SolverError
from synth.tolerances import LP_FEAS_TOL

__all__ = ["BatchLP", "COMPILED_MIN_PROBLEMS", "compiled_for", "solve_batch"]

_PIVOT_TOL = 1e-9
#: Degenerate pivots in a row after which a problem switches to Bland's rule. Bland cannot
#: cycle but is slow: the frictional d* LPs of 7 contacts (which start fully degenerate at
#: the origin) took 46 pivots on average and up to 384 switching after 8, 21 and up to 42
#: after 32. A problem that cycles anyway hits the iteration cap and is re-solved by HiGHS.
_DEGENERATE_RUN = 32
_COMPACT = 0.75
#: Smallest batch that loads the compiled kernel by default: importing numba and loading the
#: cached kernel costs about 0.5 s once per process (and compiling it, on first use after an
#: install, about 10 s). The kernel saves 25-65 us a frictional LP and about 10 us a
#: frictionless one, so 20,000 frictional LPs repay the import; once loaded, the kernel serves
#: every batch. (The planner never uses it: see :class:`synth.plan.batch.Scorer`.)
COMPILED_MIN_PROBLEMS = 20_000
_kernel_loaded = False
#: Crash pivots must exceed this fraction of the row's largest entry in ``A``.
_CRASH_TOL = 1e-6
#: Largest reduced cost of the wrong sign (or on a basic column) an optimum may show.
_DUAL_TOL = 1e-7
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
    crash: bool = False,
    compiled: bool | None = None,
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
    crash : bool
        Replace the basic fixed columns (artificials) by movable ones before the simplex
        starts, by Gauss-Jordan pivots on each row's largest entry. Only valid when ``b = 0``
        (then every basis is feasible at ``x = 0``).
    compiled : bool, optional
        Run the pivots in numba-compiled code (:mod:`synth.scores.simplex_compiled`), one
        problem at a time, instead of the numpy lock-step loop. Default:
        :func:`compiled_for` ``(B)``. Both routes end in the same optimality check.

    Returns
    -------
    BatchLP

    Notes
    -----
    Revised simplex: each problem keeps its basis inverse ``Binv`` (K, M, M), updated by a
    batched rank-one correction per pivot, and prices the movable columns (``hi > 0``; a fixed
    column can never enter) from the duals, ``r = c - (c_B Binv) A``: one pass over ``A`` a
    pivot, where updating a full (M + 1) x N tableau costs three. Measured, that is about 10%
    faster on the 7-contact frictional LP and 5-7% slower on the narrow frictionless ones:
    numpy's per-call cost over the pivots dominates either way. Problems that finish stay in
    the arrays, inert, until a quarter of the working set has finished; then the set is
    compacted (fewer copies than compacting every iteration). The compiled route runs a
    dense tableau per problem instead (see :mod:`synth.scores.simplex_compiled`).
    """
    Bn, M, N = A.shape
    c = np.asarray(c, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    basis0 = np.asarray(basis0, dtype=np.int64)
    if compiled is None:
        compiled = compiled_for(Bn)
    pivots = _compiled_module() if compiled else None
    if compiled and pivots is None:
        raise SolverError("compiled pivots need numba (pip install 'synth[fast]')")
    wcols = np.nonzero(hi > 0)[0]  # working (movable) columns
    if pivots is not None:
        global _kernel_loaded
        _kernel_loaded = True
        fixed0 = np.unique(basis0[hi[basis0] <= 0])
        cols = np.concatenate([wcols, fixed0])
        tpos = np.full(N, -1, dtype=np.int64)
        tpos[cols] = np.arange(cols.size)
        bt, upper_w, xB, y, run, iters = pivots(
            A, cols, wcols.size, np.ascontiguousarray(b, dtype=np.float64), c[cols], hi[cols],
            tpos[basis0], max_iter, crash, LP_FEAS_TOL, _PIVOT_TOL, _CRASH_TOL, _DEGENERATE_RUN)
        status = np.where(run == 1, UNBOUNDED, UNVERIFIED).astype(np.int64)
        which = np.nonzero(run == 0)[0]
        bases, upper_w, xB, y = cols[bt[which]], upper_w[which], xB[which], y[which]
    else:
        which, bases, upper_w, xB, y, status, iters = _pivot_lockstep(A, b, c, hi, wcols, basis0,
                                                                      max_iter, crash)
    x_out = np.zeros((Bn, N))
    if which.size:
        every = which.size == Bn  # which is increasing: then it is every problem, in order
        x, ok = _certify(A if every else A[which], b if every else b[which], c, hi, wcols,
                         bases, upper_w, xB, y)
        x_out[which] = x
        status[which[ok]] = OPTIMAL
    obj = np.where(status == UNBOUNDED, np.inf, x_out @ c)
    return BatchLP(x=x_out, objective=obj, status=status, iterations=iters)


@lru_cache(maxsize=1)
def _compiled_module() -> Any:
    """:func:`synth.scores.simplex_compiled.pivot_each`, or None without numba."""
    try:
        from synth.scores.simplex_compiled import pivot_each
    except ImportError:
        return None
    return pivot_each


def compiled_for(n_problems: int) -> bool:
    """Whether :func:`solve_batch` runs ``n_problems`` LPs through the numba kernel by default.

    ``SYNTH_SIMPLEX`` in the environment chooses: ``numpy`` (never), ``numba`` (always; an
    error without numba) or ``auto`` (the default: when numba is installed and either the
    batch has at least :data:`COMPILED_MIN_PROBLEMS` LPs, which repay loading the kernel, or
    an earlier batch of this process loaded it already). Both routes give the same optima to
    about 1e-12; callers whose output must not depend on numba at all (the planner) pass
    ``compiled=False`` to :func:`solve_batch` instead.

    Parameters
    ----------
    n_problems : int

    Returns
    -------
    bool
    """
    mode = os.environ.get("SYNTH_SIMPLEX", "auto") or "auto"
    if mode not in ("auto", "numpy", "numba"):
        raise InputError(f"SYNTH_SIMPLEX must be auto, numpy or numba, got {mode!r}")
    if mode == "numpy" or (mode == "auto" and n_problems < COMPILED_MIN_PROBLEMS
                           and not _kernel_loaded):
        return False
    if _compiled_module() is None:
        if mode == "numba":
            raise SolverError("SYNTH_SIMPLEX=numba needs numba (pip install 'synth[fast]')")
        return False
    return True


def _pivot_lockstep(
    A: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    hi: NDArray[np.float64],
    wcols: NDArray[np.int64],
    basis0: NDArray[np.int64],
    max_iter: int,
    crash: bool,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_], NDArray[np.float64],
           NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Run the pivots of :func:`solve_batch` for all problems in lock step, in numpy.

    Parameters
    ----------
    A : (B, M, N) float
    b : (B, M) float
    c, hi : (N,) float
    wcols : (Nw,) int
        The movable columns of ``A``.
    basis0 : (M,) int
    max_iter : int
    crash : bool

    Returns
    -------
    which : (K,) int
        Problems that finished bounded (to check), in increasing order.
    bases : (K, M) int
        Their final bases (columns of ``A``).
    upper : (K, Nw) bool
        Their nonbasic movable columns at the upper bound.
    xB, y : (K, M) float
        Their basic values and duals.
    status : (B,) int
        UNBOUNDED where found so, else UNVERIFIED.
    iterations : (B,) int
    """
    Bn, M, N = A.shape
    Nw = wcols.size
    if Nw and wcols[-1] - wcols[0] == Nw - 1:  # a slice copies faster than a gather
        Aw = np.ascontiguousarray(A[:, :, wcols[0] : wcols[0] + Nw])
    else:
        Aw = A[:, :, wcols]
    status = np.full(Bn, UNVERIFIED, dtype=np.int64)
    iters = np.zeros(Bn, dtype=np.int64)
    wpos = np.full(N, -1, dtype=np.int64)  # original column -> working column (or -1)
    wpos[wcols] = np.arange(Nw)
    hi_w = hi[wcols]
    c_w = c[wcols]
    finite_w = np.isfinite(hi_w)
    idx = np.arange(Bn)
    Binv = np.broadcast_to(np.eye(M), (Bn, M, M)).copy()
    xB = b.astype(np.float64, copy=True)
    basis = np.broadcast_to(np.asarray(basis0, dtype=np.int64), (Bn, M)).copy()
    sgn = np.ones((Bn, Nw))  # -1 where a nonbasic column sits at its upper bound, else +1
    basic = np.zeros((Bn, Nw), dtype=bool)  # working columns in the basis
    basic[:, wpos[basis0][wpos[basis0] >= 0]] = True
    degen = np.zeros(Bn, dtype=np.int64)
    n_it = np.zeros(Bn, dtype=np.int64)
    live = np.ones(Bn, dtype=bool)
    stash: list[tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_],
                      NDArray[np.float64], NDArray[np.float64]]] = []

    def retire(mask: NDArray[np.bool_], y: NDArray[np.float64]) -> None:
        """Record basis, basic values and duals ``y`` of finished, bounded problems."""
        if mask.any():
            stash.append((idx[mask], basis[mask], sgn[mask] < 0, xB[mask], y[mask]))

    if crash:
        # crash basis, replacing the degenerate pivots that would drive out the artificials
        # (with b = 0 every basis is feasible at x = 0): each row still holding an artificial
        # takes its largest movable entry (Gauss-Jordan with row-wise complete pivoting)
        ar = np.arange(Bn)
        rowscale = np.abs(A).max(axis=2)  # one pass: a strided row at a time costs 6x more
        for i in range(M):
            if wpos[basis0[i]] >= 0:
                continue
            row = np.einsum("km,kmn->kn", Binv[:, i, :], Aw)  # row i of Binv A
            q = np.argmax(np.abs(row), axis=1)
            colq = np.einsum("kmj,kj->km", Binv, Aw[ar, :, q])
            go = np.abs(colq[:, i]) > _CRASH_TOL * rowscale[:, i]
            _pivot(Binv, colq, np.full(Bn, i), go)
            basis[:, i] = np.where(go, wcols[q], basis[:, i])
            basic[ar[go], q[go]] = True
    for _ in range(max_iter):
        K = idx.size
        if K == 0:
            break
        ar = np.arange(K)
        # pricing: gain per unit step of each nonbasic column in its feasible direction
        y = np.einsum("km,kmj->kj", c[basis], Binv)
        gain = c_w - np.einsum("km,kmn->kn", y, Aw)
        gain *= sgn
        gain[basic] = 0.0  # round-off only
        q = np.argmax(gain, axis=1)
        has = (gain[ar, q] > LP_FEAS_TOL) & live
        bland = (degen >= _DEGENERATE_RUN) & has
        any_bland = bool(bland.any())
        if any_bland:  # Bland: the lowest-index improving column
            q[bland] = np.argmax(gain[bland] > LP_FEAS_TOL, axis=1)
        up_q = sgn[ar, q] < 0
        colq = np.einsum("kmj,kj->km", Binv, Aw[ar, :, q])  # entering column, (K, M)
        alpha = colq.copy()
        np.negative(alpha, out=alpha, where=up_q[:, None])
        # ratio test (lower bounds are all 0)
        absa = np.abs(alpha)
        num = np.where(alpha > 0, xB, hi[basis] - xB)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # inf: no bound
            ratio = np.where(absa > _PIVOT_TOL, num / absa, np.inf)
        np.maximum(ratio, 0.0, out=ratio)
        theta_r = ratio.min(axis=1)
        ties = ratio <= theta_r[:, None] + 1e-12
        p = np.argmax(np.where(ties, absa, -1.0), axis=1)
        if any_bland:
            p[bland] = np.argmin(np.where(ties[bland], basis[bland], N + 1), axis=1)
        theta_f = hi_w[q]
        flip = finite_w[q] & (theta_f <= theta_r)
        unbounded = has & ~flip & np.isinf(theta_r)
        step = has & ~unbounded
        theta = np.where(step, np.where(flip, theta_f, theta_r), 0.0)
        theta[~np.isfinite(theta)] = 0.0
        xB -= theta[:, None] * alpha
        fl = step & flip
        if fl.any():
            sgn[ar[fl], q[fl]] *= -1.0
        piv = step & ~flip
        if piv.any():
            leave = basis[ar, p]
            lw = wpos[leave]
            pi = ar[piv & (lw >= 0)]
            sgn[pi, lw[pi]] = np.where(alpha[pi, p[pi]] < 0, -1.0, 1.0)
            basic[pi, lw[pi]] = False
            sgn[ar[piv], q[piv]] = 1.0
            basic[ar[piv], q[piv]] = True
            xB[ar, p] = np.where(piv, np.where(up_q, hi_w[q] - theta, theta), xB[ar, p])
            basis[ar, p] = np.where(piv, wcols[q], leave)
            _pivot(Binv, colq, p, piv)
        degen += 1
        degen *= step & (theta <= 1e-12)
        n_it += step
        done = live & (~has | unbounded)
        if done.any():
            status[idx[unbounded & live]] = UNBOUNDED
            retire(done & ~unbounded, y)  # no pivot this round: y is still theirs
            live &= ~done
            if live.sum() <= _COMPACT * K:
                iters[idx] = n_it
                idx, Aw, Binv, xB, basis = idx[live], Aw[live], Binv[live], xB[live], basis[live]
                sgn, basic, degen = sgn[live], basic[live], degen[live]
                n_it, live = n_it[live], live[live]
    iters[idx] = n_it
    if not stash:
        return (np.zeros(0, np.int64), np.zeros((0, M), np.int64), np.zeros((0, Nw), bool),
                np.zeros((0, M)), np.zeros((0, M)), status, iters)
    which, bases, upper, xBs, ys = (np.concatenate(part) for part in zip(*stash, strict=True))
    order = np.argsort(which)
    return (which[order], bases[order], upper[order], xBs[order], ys[order], status, iters)


def _pivot(Binv: NDArray[np.float64], col: NDArray[np.float64], p: NDArray[np.int64],
           piv: NDArray[np.bool_]) -> None:
    """Update the basis inverses ``Binv`` (K, M, M) in place after a pivot.

    The entering columns ``col`` (K, M) (``Binv`` times the column) replace basic position
    ``p`` (K,) where ``piv`` (K,) is set: row p becomes row p / pivot and every other row r
    loses ``col[r]`` times it (a rank-one correction; problems that do not pivot get none).
    """
    ar = np.arange(len(p))
    pv = np.where(piv, col[ar, p], 1.0)
    new_row = Binv[ar, p, :] / pv[:, None]
    f = np.where(piv[:, None], col, 0.0)
    f[ar, p] = np.where(piv, col[ar, p] - 1.0, 0.0)  # so that row p ends as new_row
    Binv -= f[:, :, None] * new_row[:, None, :]


def _certify(
    A: NDArray[np.float64],
    b: NDArray[np.float64],
    c: NDArray[np.float64],
    hi: NDArray[np.float64],
    wcols: NDArray[np.int64],
    basis: NDArray[np.int64],
    upper_w: NDArray[np.bool_],
    xB: NDArray[np.float64],
    y: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Check each final point and its duals against the LP itself (an optimality certificate).

    The point ``x`` (basic values ``xB``, nonbasic columns at 0 or at their upper bound) must
    satisfy ``A x = b`` and the bounds, and the reduced costs ``r = c - y^T A`` must vanish on
    the basis and not point out of the box elsewhere (``r <= 0`` at a lower bound, ``r >= 0``
    at an upper bound): then ``x`` is optimal by LP duality. Nothing here comes from the
    pivots' arithmetic except the candidate pair ``(x, y)``.

    Parameters
    ----------
    A : (K, M, N) float
    b : (K, M) float
    c, hi : (N,) float
    wcols : (Nw,) int
        Movable columns (``hi > 0``); fixed ones carry no sign condition.
    basis : (K, M) int
    upper_w : (K, Nw) bool
        Nonbasic movable columns at their upper bound.
    xB, y : (K, M) float

    Returns
    -------
    x : (K, N) float
        The points, clipped to their bounds.
    ok : (K,) bool
    """
    K, M, N = A.shape
    ar = np.arange(K)[:, None]
    upper = np.zeros((K, N), dtype=bool)
    upper[:, wcols] = upper_w
    x = np.where(upper, np.where(np.isinf(hi), 0.0, hi), 0.0)
    x[ar, basis] = xB
    scale = 1.0 + np.abs(xB).max(axis=1)
    slack = LP_FEAS_TOL * scale[:, None]
    res_p = np.abs(np.einsum("kmn,kn->km", A, x) - b).max(axis=1)
    ok = np.isfinite(xB).all(axis=1) & np.isfinite(y).all(axis=1)
    ok &= res_p <= LP_FEAS_TOL * scale
    ok &= ((xB >= -slack) & (xB <= hi[basis] + slack)).all(axis=1)
    red = c[None, :] - np.einsum("km,kmn->kn", y, A)
    movable = np.zeros(N, dtype=bool)
    movable[wcols] = True
    nonbasic = np.ones((K, N), dtype=bool)
    nonbasic[ar, basis] = False
    dual_bad = nonbasic & movable[None, :] & np.where(upper, red < -_DUAL_TOL, red > _DUAL_TOL)
    ok &= ~dual_bad.any(axis=1)
    ok &= (np.abs(np.take_along_axis(red, basis, axis=1)) <= _DUAL_TOL).all(axis=1)
    return np.clip(x, 0.0, np.where(np.isinf(hi), np.inf, hi)), ok
