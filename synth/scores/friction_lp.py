"""The frictional d* LP of one grasp, built from its cone generators and solved with HiGHS.

With ``lam_ij >= 0`` along generator ``j`` of contact ``i`` (:mod:`synth.scores.cones`, unit
normal intensity each) the paper's frictional test (Section II.B) reads

    maximise d  s.t.  G lam = 0,   sum_j lam_ij >= d,   sum_j lam_ij <= 1,   lam >= 0.

Both :func:`synth.frictional_form_closure` and the batched scorer's re-solves of unverified
problems call :func:`solve_frictional_lp`, so neither needs the other.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linprog

from synth.errors import SolverError
from synth.scores.wrench import balance_rows

__all__ = ["solve_frictional_lp"]


def solve_frictional_lp(G: NDArray[np.float64], n: int) -> tuple[float, NDArray[np.float64]]:
    """Solve the frictional d* LP of one grasp.

    Parameters
    ----------
    G : (m, n * M) float
        Generator wrenches, ``M`` per contact, contact by contact.
    n : int
        Number of contacts.

    Returns
    -------
    d : float
        The optimum (not yet rounded to 0 below ``D_STAR_TOL``).
    lam : (n, M) float
        Generator intensities of the optimal internal force.

    Examples
    --------
    >>> G = np.array([[1.0, -1.0]])  # two opposed frictionless contacts on a line
    >>> solve_frictional_lp(G, 2)[0]
    1.0
    """
    m, cols = G.shape
    M = cols // n
    Gb, _ = balance_rows(G)  # same null space, rows of one size
    sums = np.kron(np.eye(n), np.ones((1, M)))  # c_in = sum_j lam_ij
    cost = np.zeros(cols + 1)
    cost[-1] = -1.0  # x = [lam, d]; minimise -d
    A_ub = np.block([[-sums, np.ones((n, 1))],  # d - c_in <= 0
                     [sums, np.zeros((n, 1))]])  # c_in <= 1
    b_ub = np.concatenate([np.zeros(n), np.ones(n)])
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, A_eq=np.hstack([Gb, np.zeros((m, 1))]),
                  b_eq=np.zeros(m), bounds=[(0.0, None)] * (cols + 1), method="highs")
    if res.status != 0:
        raise SolverError(f"frictional form-closure LP failed: {res.message}")
    return float(res.x[-1]), np.asarray(res.x[:-1]).reshape(n, M)
