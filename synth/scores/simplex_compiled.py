"""The pivots of :func:`synth.scores.simplex.solve_batch`, compiled with numba.

Same algorithm and rules as the numpy lock-step loop (crash basis, Dantzig pricing with
Bland's rule after a run of degenerate pivots, bounded ratio test with bound flips), run one
problem at a time in compiled code on a dense tableau of the movable columns, so a problem
costs its own pivots and no numpy call overhead. Out come the final basis, the basic values
and the duals; :func:`~synth.scores.simplex.solve_batch` then checks that pair against ``A``
(primal feasibility, reduced-cost signs) exactly as it does for the numpy loop, so a bad pivot
here can cost a HiGHS re-solve but never a wrong d*.

numba is optional (the ``fast`` extra): importing this module raises ImportError without it,
and :mod:`synth.scores.simplex` then keeps to its numpy loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["pivot_each"]


@njit(cache=True, nogil=True, error_model="numpy")
def pivot_each(A, cols, nw, b, c_t, hi_t, basis0_t, max_iter, crash, feas_tol, pivot_tol,
               crash_tol, degenerate_run):
    """Run the simplex of every problem (see :func:`synth.scores.simplex.solve_batch`).

    Parameters
    ----------
    A : (B, M, N) float
        Constraint matrices.
    cols : (Nt,) int
        Columns of ``A`` kept in the tableau: first the ``nw`` movable ones (``hi > 0``), then
        the fixed columns of the initial basis (kept for the duals; they never enter).
    nw : int
    b : (B, M) float
        Right-hand sides (the start ``x_B = b`` is feasible).
    c_t, hi_t : (Nt,) float
        Objective and upper bounds of the tableau columns.
    basis0_t : (M,) int
        Tableau column of each initial basic position (``A[:, :, cols[basis0_t]] = I``).
    max_iter : int
    crash : bool
        First pivot a movable column into each position held by a fixed one (``b = 0`` only).
    feas_tol, pivot_tol, crash_tol : float
        Reduced-cost tolerance, smallest usable pivot, smallest crash pivot relative to the
        row's largest entry of ``A``.
    degenerate_run : int
        Degenerate pivots in a row after which Bland's rule is used.

    Returns
    -------
    basis : (B, M) int
        Final tableau column of each basic position.
    upper : (B, nw) bool
        Nonbasic movable columns at their upper bound.
    xB : (B, M) float
        Basic values.
    y : (B, M) float
        Duals (``c_B B^-1``, read off the reduced costs of the initial identity columns).
    status : (B,) int
        0 finished (still to be checked), 1 unbounded, 2 iteration cap.
    iterations : (B,) int
    """
    Bn, M, N = A.shape
    Nt = cols.size
    basis_out = np.empty((Bn, M), dtype=np.int64)
    upper_out = np.zeros((Bn, nw), dtype=np.bool_)
    xB_out = np.empty((Bn, M))
    y_out = np.empty((Bn, M))
    status = np.zeros(Bn, dtype=np.int64)
    iters = np.zeros(Bn, dtype=np.int64)
    T = np.empty((M, Nt))
    prow = np.empty(Nt)
    rowscale = np.empty(M)
    r = np.empty(Nt)
    xB = np.empty(M)
    hB = np.empty(M)
    basis = np.empty(M, dtype=np.int64)
    sgn = np.empty(Nt)  # -1 where a nonbasic column sits at its upper bound, else +1
    isbasic = np.empty(Nt, dtype=np.bool_)
    dirn = np.empty(Nt)  # sgn on nonbasic columns, 0 on basic ones (branch-free pricing)
    ratio = np.empty(M)
    for k in range(Bn):
        for i in range(M):
            for j in range(Nt):
                T[i, j] = A[k, i, cols[j]]
            if crash:
                scale = 0.0
                for j in range(N):
                    a = abs(A[k, i, j])
                    if a > scale:
                        scale = a
                rowscale[i] = scale
            xB[i] = b[k, i]
            basis[i] = basis0_t[i]
            hB[i] = hi_t[basis0_t[i]]
        for j in range(Nt):
            sgn[j] = 1.0
            isbasic[j] = False
            r[j] = c_t[j]
        # reduced costs of the start, r = c - c_B^T T
        for i in range(M):
            q0 = basis[i]
            isbasic[q0] = True
            cb = c_t[q0]
            if cb != 0.0:
                for j in range(Nt):
                    r[j] -= cb * T[i, j]
        for j in range(Nt):
            dirn[j] = 0.0 if isbasic[j] else 1.0
        if crash:
            for i in range(M):
                if basis[i] < nw:
                    continue
                q = -1
                best = 0.0
                for j in range(nw):
                    a = abs(T[i, j] * dirn[j])
                    better = a > best
                    best = a if better else best
                    q = j if better else q
                if q < 0 or best <= crash_tol * rowscale[i]:
                    continue
                isbasic[basis[i]] = False
                _tableau_pivot(T, r, prow, i, q)
                basis[i] = q
                hB[i] = hi_t[q]
                isbasic[q] = True
                dirn[q] = 0.0
        degen = 0
        n_it = 0
        st = 2
        for _ in range(max_iter):
            bland = degen >= degenerate_run
            # pricing (branch-free: mispredicted branches cost more than the arithmetic)
            q = -1
            best = feas_tol
            if bland:  # the lowest-index improving column
                for j in range(nw):
                    if r[j] * dirn[j] > feas_tol:
                        q = j
                        break
            else:  # Dantzig: the steepest gain
                for j in range(nw):
                    g = r[j] * dirn[j]
                    better = g > best
                    best = g if better else best
                    q = j if better else q
            if q < 0:
                st = 0
                break
            up_q = sgn[q] < 0.0
            dq = -1.0 if up_q else 1.0
            # ratio test on alpha = dq T[:, q] (the rate at which x_B falls)
            theta_r = np.inf
            for i in range(M):
                a = dq * T[i, q]
                num = xB[i] if a > 0 else hB[i] - xB[i]
                t = max(num / abs(a), 0.0) if abs(a) > pivot_tol else np.inf
                ratio[i] = t
                theta_r = min(theta_r, t)
            p = -1
            if theta_r < np.inf:  # among ties, the largest pivot (Bland: the lowest column)
                bestp = -1.0
                bestb = Nt
                for i in range(M):
                    if ratio[i] <= theta_r + 1e-12:
                        if bland:
                            if basis[i] < bestb:
                                bestb = basis[i]
                                p = i
                        elif abs(T[i, q]) > bestp:
                            bestp = abs(T[i, q])
                            p = i
            flip = hi_t[q] <= theta_r and hi_t[q] < np.inf
            if not flip and theta_r == np.inf:
                st = 1
                break
            theta = hi_t[q] if flip else theta_r
            for i in range(M):
                xB[i] -= theta * dq * T[i, q]
            if flip:
                sgn[q] = -sgn[q]
                dirn[q] = sgn[q]
            else:
                leave = basis[p]
                sgn[leave] = -1.0 if dq * T[p, q] < 0 else 1.0
                isbasic[leave] = False
                dirn[leave] = sgn[leave]
                sgn[q] = 1.0
                isbasic[q] = True
                dirn[q] = 0.0
                xB[p] = hi_t[q] - theta if up_q else theta
                basis[p] = q
                hB[p] = hi_t[q]
                _tableau_pivot(T, r, prow, p, q)
            n_it += 1
            if theta <= 1e-12:
                degen += 1
            else:
                degen = 0
        status[k] = st
        iters[k] = n_it
        for i in range(M):
            basis_out[k, i] = basis[i]
            xB_out[k, i] = xB[i]
            j0 = basis0_t[i]
            y_out[k, i] = c_t[j0] - r[j0]
        for j in range(nw):
            upper_out[k, j] = (not isbasic[j]) and sgn[j] < 0.0
    return basis_out, upper_out, xB_out, y_out, status, iters


@njit(cache=True, nogil=True, error_model="numpy")
def _tableau_pivot(T, r, prow, p, q):
    """Pivot the tableau ``T`` (M, Nt) and reduced costs ``r`` (Nt,) on entry (p, q).

    ``prow`` (Nt,) is scratch for the scaled pivot row (a separate buffer, so the row updates
    do not alias it and compile to vector instructions).
    """
    M, Nt = T.shape
    Tp = T[p]
    inv = 1.0 / Tp[q]
    for j in range(Nt):
        prow[j] = Tp[j] * inv
    for i in range(M):
        if i == p:
            continue
        Ti = T[i]
        f = Ti[q]
        if f != 0.0:
            for j in range(Nt):
                Ti[j] -= f * prow[j]
    f = r[q]
    if f != 0.0:
        for j in range(Nt):
            r[j] -= f * prow[j]
    Tp[:] = prow
