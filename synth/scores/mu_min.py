"""The least friction coefficient at which a grasp closes (GraspNet's label), by bisection.

Frictional form closure only grows with mu (every linearised cone grows with it), so
``mu_min = inf {mu : the grasp is frictional form closure}`` is found by bisection on the
batched frictional LP (:func:`synth.scores.friction_batch.frictional_form_closure_batch`),
every grasp of a batch in lock step. The value is that of the cone the LP uses, which the
result names: the inscribed ``edges`` pyramid (``"pyramid-8"``) or, with torsion, the
inscribed soft cone (``"soft-8x3+2"``, :mod:`synth.scores.cones`). Such a cone reaches only
``cos(pi / edges)`` of the circular cone between its edges, so its mu_min can be up to
``1 / cos(pi / edges)`` (1.082 for 8 edges) times the circular cone's.

Two point contacts never close; two soft contacts (torsion > 0) close for every mu above the
angle between the line joining them and their normals (``mu_min = 0`` for an exactly
antipodal pair; numerically at most 2e-6, since friction columns that small fall under the
rank test's ``RANK_RTOL``), which is why jaw grasps need the gravity measure
(:mod:`synth.scores.gravity`) to be told apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from synth.errors import InputError
from synth.limits import MAX_MU
from synth.scores.arguments import coefficients_arg, edges_arg, numbers_arg
from synth.scores.cones import check_contacts_batch, cone_name
from synth.scores.friction_batch import frictional_form_closure_batch

__all__ = ["MU_MIN_TOL", "MuMin", "mu_min", "mu_min_batch"]

#: Absolute accuracy of the bisection: the reported value closes, and one MU_MIN_TOL less
#: does not (or the value is below MU_MIN_TOL).
MU_MIN_TOL: float = 1e-6


@dataclass(frozen=True)
class MuMin:
    """Result of :func:`mu_min_batch`.

    Attributes
    ----------
    mu_min : (B,) float
        Least friction coefficient that closes each grasp, to ``MU_MIN_TOL`` from above (a
        value that closes); ``inf`` when none up to ``MAX_MU`` does.
    cone : str
        The linearised cone the value belongs to, e.g. ``"pyramid-8"``.
    lps : int
        Batched LP calls made (bisection steps).
    """

    mu_min: NDArray[np.float64]
    cone: str
    lps: int


def mu_min_batch(
    points: ArrayLike,
    normals: ArrayLike,
    torsion: ArrayLike = 0.0,
    edges: int = 8,
    compiled: bool | None = None,
) -> MuMin:
    """Least closing friction coefficient of many grasps, by bisection to ``MU_MIN_TOL``.

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and inward normals.
    torsion : float or (k,) float
        Torsional coefficients (lengths) of soft contacts; 0 for point contacts.
    edges : int
        Edges of the linearised cones.
    compiled : bool, optional
        Simplex route, as in :func:`synth.frictional_form_closure_batch`.

    Returns
    -------
    MuMin

    Examples
    --------
    >>> P = [[[1.0, 0.0, 0.1], [-1.0, 0.0, -0.1]]]
    >>> N = [[[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]]
    >>> round(float(mu_min_batch(P, N, torsion=0.05).mu_min[0]), 5)  # tan = 0.2 / 2
    0.1
    """
    P, N = check_contacts_batch(points, normals)
    B, k, _ = P.shape
    edges = edges_arg(edges)
    gam = np.broadcast_to(coefficients_arg(torsion, "torsion", ((), (1,), (k,))), (k,))
    soft = bool(np.any(gam > 0))
    name = cone_name(edges, soft)
    lo = np.zeros(B)
    hi = np.ones(B)
    lps = 0

    def closes(mu: NDArray[np.float64], rows: NDArray[np.int64]) -> NDArray[np.bool_]:
        nonlocal lps
        lps += 1
        m = np.repeat(mu[:, None], k, axis=1)
        if not soft and not np.any(m > 0):
            return np.zeros(len(rows), bool)
        return frictional_form_closure_batch(P[rows], N[rows], m, edges=edges,
                                             compiled=compiled, torsion=gam).closure

    # bracket: double hi until the grasp closes or MAX_MU is passed
    open_ = np.arange(B)
    while len(open_):
        ok = closes(hi[open_], open_)
        lo[open_[~ok]] = hi[open_[~ok]]
        open_ = open_[~ok]
        grow = hi[open_] < MAX_MU
        hi[open_[~grow]] = np.inf
        open_ = open_[grow]
        hi[open_] = np.minimum(2.0 * hi[open_], MAX_MU)
    live = np.flatnonzero(np.isfinite(hi))
    while len(live):
        live = live[hi[live] - lo[live] > MU_MIN_TOL]
        if not len(live):
            break
        mid = 0.5 * (lo[live] + hi[live])
        ok = closes(mid, live)
        hi[live[ok]] = mid[ok]
        lo[live[~ok]] = mid[~ok]
    return MuMin(hi, name, lps)


def mu_min(
    points: ArrayLike, normals: ArrayLike, torsion: ArrayLike = 0.0, edges: int = 8
) -> float:
    """Least closing friction coefficient of one spatial grasp (see :func:`mu_min_batch`).

    Parameters
    ----------
    points, normals : (k, 3) float
    torsion : float or (k,) float
    edges : int

    Returns
    -------
    float
        ``inf`` when no coefficient up to ``MAX_MU`` closes the grasp.

    Examples
    --------
    >>> mu_min([[1, 0, 0], [-1, 0, 0]], [[-1, 0, 0], [1, 0, 0]])  # point contacts never
    inf
    """
    P = numbers_arg(points, "points")
    N = numbers_arg(normals, "normals")
    if N.ndim == 2 and N.shape[-1] == 3 and not (np.linalg.norm(N, axis=1) > 0).all():
        raise InputError("normals: expected unit inward normals, got one of length 0")
    return float(mu_min_batch(P[None], N[None], torsion, edges).mu_min[0])
