"""Random contact pools and a plain scipy LP of d*, for the swap climb's tests."""

import numpy as np
from scipy.optimize import linprog


def pool(n, seed):
    """Random contacts on a unit sphere with inward normals, and their wrench columns."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    p *= 1.0 + 0.3 * rng.random((n, 1))  # not a sphere: torques about the centre too
    nrm = -p / np.linalg.norm(p, axis=1, keepdims=True)
    nrm += 0.4 * rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return p, nrm


def columns(p, nrm):
    return np.concatenate([nrm, np.cross(p, nrm)], axis=1).T  # (6, n)


def lp_d_star(W):
    """Trinkle's frictionless d* with intensities scaled to at most 1: max d subject to
    W c = 0, d <= c_i <= 1 (0 when the best d is not positive)."""
    m, k = W.shape
    cost = np.zeros(k + 1)
    cost[-1] = -1.0
    a_eq = np.hstack([W, np.zeros((m, 1))])
    a_ub = np.hstack([-np.eye(k), np.ones((k, 1))])  # d - c_i <= 0
    res = linprog(cost, A_ub=a_ub, b_ub=np.zeros(k), A_eq=a_eq, b_eq=np.zeros(m),
                  bounds=[(0, 1)] * k + [(None, None)], method="highs")
    assert res.status == 0
    return max(0.0, -res.fun)
