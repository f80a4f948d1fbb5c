"""Convex planar pieces of face regions, and the best contact positions on them by one LP.

For contacts on fixed planes the normals are fixed, and substituting ``q_i = c_i x_i`` (the
intensity times the in-plane position) makes the moment balance linear; a convex polygon
``A x <= b`` scaled by ``c_i`` is the linear constraint ``A q_i <= c_i b``. So for a fixed
assignment of contacts to convex planar pieces the largest d* over all positions is one LP in
``3 k + 1`` variables (this answers the question Trinkle's paper closes with: reason over
whole planar faces instead of evaluating huge numbers of grasps).

The LP's optimum is often degenerate (rank W < 6, e.g. two opposite contacts on one line);
the planner verifies every answer with the exact scorer and refines it locally.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linprog

from synth.part.pieces import PlanarPiece, convex_piece

__all__ = ["PlanarPiece", "convex_piece", "best_positions"]


def best_positions(
    pieces: list[PlanarPiece], center: NDArray[np.float64], length: float
) -> tuple[NDArray[np.float64], float] | None:
    """Contact positions on the pieces that maximise d*, by one LP.

    Parameters
    ----------
    pieces : list of PlanarPiece
        One per contact (a piece may repeat).
    center : (3,) float
        Moment reference.
    length : float
        Moment scale (keeps the LP well conditioned).

    Returns
    -------
    (points (k, 3), d) or None if the LP has no positive optimum.
    """
    k = len(pieces)
    nv = 3 * k + 1
    A_eq = np.zeros((6, nv))
    rows_ub = []
    b_ub = []
    for i, pc in enumerate(pieces):
        n = pc.normal
        A_eq[:3, i] = n
        A_eq[3:, i] = np.cross(pc.origin - center, n) / length
        A_eq[3:, k + i] = np.cross(pc.u, n) / length
        A_eq[3:, 2 * k + i] = np.cross(pc.v, n) / length
        for a, bb in zip(pc.A, pc.b, strict=True):
            row = np.zeros(nv)
            row[k + i], row[2 * k + i], row[i] = a[0], a[1], -bb
            rows_ub.append(row)
            b_ub.append(0.0)
        row = np.zeros(nv)
        row[i], row[-1] = -1.0, 1.0  # d <= c_i
        rows_ub.append(row)
        b_ub.append(0.0)
    cost = np.zeros(nv)
    cost[-1] = -1.0
    res = linprog(
        cost, A_ub=np.array(rows_ub), b_ub=np.array(b_ub), A_eq=A_eq, b_eq=np.zeros(6),
        bounds=[(0, 1)] * k + [(None, None)] * (2 * k) + [(0, 1)], method="highs",
    )
    # c_i >= d; below 1e-6 the positions q_i / c_i are round-off (HiGHS's feasibility
    # tolerance is 1e-7)
    if res.status != 0 or res.x[-1] <= 1e-6 or res.x[:k].min() <= 1e-7:
        return None
    c = res.x[:k]
    xy = np.stack([res.x[k : 2 * k] / c, res.x[2 * k : 3 * k] / c], axis=1)
    pts = np.array([pc.to_3d(xy[i]) for i, pc in enumerate(pieces)])
    return pts, float(res.x[-1])
