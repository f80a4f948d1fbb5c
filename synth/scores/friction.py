"""Frictional form closure with linearised Coulomb cones (Trinkle 1992, Section II.B).

Each contact's friction cone ``|f_t| <= mu f_n`` is replaced by the inscribed pyramid spanned by
``edges`` unit-normal-component forces ``e_ij = n_i + mu_i (cos a_j u_i + sin a_j v_i)``,
``a_j = 2 pi j / edges`` (a conservative approximation: every pyramid force lies in the true
cone). In the plane the cone has exactly two edges ``n_i +- mu_i t_i`` and ``edges`` is ignored.

A contact force is ``sum_j lam_ij e_ij`` with ``lam >= 0``; its normal intensity is
``c_i = sum_j lam_ij``. The measure keeps Trinkle's LP and box over normal intensities:

    maximise d  s.t.  G lam = 0,  lam_ij >= d / edges,  sum_j lam_ij <= 1,

where ``G`` holds the edge wrenches. A positive optimum means an internal force strictly inside
every (linearised) cone, so the grasp can be squeezed as hard as one likes; with full row rank
of ``G`` this is frictional form closure (what Murray, Li and Sastry call force closure).
With ``mu = 0`` all edges coincide, the optimum spreads ``c_i`` evenly over them and the LP
is exactly :func:`synth.form_closure`'s, so both give the same d*.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.scores.escape import describe_twist, escape_twist
from synth.scores.wrench import check_contacts, numerical_rank
from synth.tolerances import D_STAR_TOL

__all__ = [
    "FrictionalFormClosure",
    "frictional_form_closure",
    "friction_cone_wrenches",
    "tangent_basis",
]


@dataclass(frozen=True)
class FrictionalFormClosure:
    """Result of :func:`frictional_form_closure`.

    Attributes
    ----------
    d_star : float
        The frictional measure (equal to the frictionless d* when every mu is 0).
    closure : str
        ``"frictional form"`` (some mu > 0), ``"form"`` (all mu = 0) or ``"force"``.
    c_normal : (n,) float
        Normal intensities of the optimal internal force.
    lam : (n, edges) float
        Intensities along the cone edges.
    rank : int
        Numerical rank of the edge wrench matrix ``G``.
    m : int
        6 in space, 3 in the plane.
    mu : (n,) float
        Friction coefficient of each contact.
    edges : int
        Cone edges per contact actually used (2 in the plane).
    escape : (m,) float or None
        A twist no contact force in the pyramids resists, for grasps without closure.
    escape_words : str or None
    solve_time : float
    """

    d_star: float
    closure: str
    c_normal: NDArray[np.float64] = field(repr=False)
    lam: NDArray[np.float64] = field(repr=False)
    rank: int
    m: int
    mu: NDArray[np.float64] = field(repr=False)
    edges: int
    escape: NDArray[np.float64] | None = field(repr=False)
    escape_words: str | None
    solve_time: float = field(default=0.0, repr=False)

    @property
    def is_closure(self) -> bool:
        """True for (frictional) form closure."""
        return self.closure != "force"


def tangent_basis(normals: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit tangents ``u, v`` per normal with ``(u, v, n)`` orthonormal.

    Parameters
    ----------
    normals : (n, 3) float
        Unit normals.

    Returns
    -------
    u, v : (n, 3) float
    """
    N = np.asarray(normals, dtype=np.float64)
    helper = np.where(np.abs(N[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(N, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(N, u)


def _check_mu(mu: ArrayLike, n: int) -> NDArray[np.float64]:
    mu_a = np.broadcast_to(np.asarray(mu, dtype=np.float64), (n,)) if np.ndim(mu) == 0 else (
        np.asarray(mu, dtype=np.float64)
    )
    if mu_a.shape != (n,) or not np.all(np.isfinite(mu_a)) or np.any(mu_a < 0):
        raise InputError(
            f"mu must be a nonnegative finite scalar or one value per contact ({n}), got {mu!r}"
        )
    return np.array(mu_a)


def friction_cone_wrenches(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
) -> NDArray[np.float64]:
    """Wrenches of the edges of each contact's linearised friction cone.

    Parameters
    ----------
    points : (n, 3) or (n, 2) float
    normals : (n, 3) or (n, 2) float
        Inward normals.
    mu : float or (n,) float
        Coulomb coefficients, >= 0.
    center : (3,) or (2,) float, optional
        Moment reference (default: centroid of the points).
    edges : int
        Edges per cone in space (>= 3); the plane always uses 2.

    Returns
    -------
    G : (m, n, E) float
        ``G[:, i, j]`` is the unit-normal-intensity wrench of edge ``j`` of contact ``i``.
    """
    P, N = check_contacts(points, normals)
    n, d = P.shape
    mu_a = _check_mu(mu, n)
    o = P.mean(axis=0) if center is None else np.asarray(center, dtype=np.float64)
    if o.shape != (d,):
        raise InputError(f"center must be a ({d},) vector, got {o.shape}")
    if d == 2:
        R = P - o
        T = np.stack([-N[:, 1], N[:, 0]], axis=1)
        F = N[:, None, :] + mu_a[:, None, None] * np.stack([T, -T], axis=1)  # (n, 2, 2)
        tau = R[:, None, 0] * F[..., 1] - R[:, None, 1] * F[..., 0]
        return np.concatenate([F.transpose(2, 0, 1), tau[None]], axis=0)
    if int(edges) != edges or edges < 3:
        raise InputError(f"edges must be an integer >= 3, got {edges!r}")
    from synth.scores.friction_batch import friction_edge_wrenches_batch

    E = int(edges)
    G = friction_edge_wrenches_batch(P[None], N[None], mu_a, o, E)[0]  # (6, n * E)
    return G.reshape(6, n, E)


def frictional_form_closure(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
) -> FrictionalFormClosure:
    """Frictional form-closure measure of point contacts with Coulomb friction.

    Parameters
    ----------
    points : (n, 3) or (n, 2) float
    normals : (n, 3) or (n, 2) float
        Inward normals.
    mu : float or (n,) float
        Coulomb friction coefficients (0 gives the frictionless test).
    center : (3,) or (2,) float, optional
        Moment reference; d* does not depend on it.
    edges : int
        Edges of each linearised cone in space (default 8, at least 3).

    Returns
    -------
    FrictionalFormClosure

    Examples
    --------
    >>> pts = [[1, 0, 0], [-1, 0, 0], [0, 1, 0]]
    >>> nrm = [[-1, 0, 0], [1, 0, 0], [0, -1, 0]]
    >>> frictional_form_closure(pts, nrm, mu=0.5).closure
    'force'
    """
    G3 = friction_cone_wrenches(points, normals, mu, center=center, edges=edges)
    m, n, E = G3.shape
    mu_a = _check_mu(mu, n)
    G = G3.reshape(m, n * E)
    t0 = time.perf_counter()
    # x = [lam (n*E), d]; minimise -d
    cost = np.zeros(n * E + 1)
    cost[-1] = -1.0
    A_ub = np.zeros((n * E + n, n * E + 1))
    A_ub[: n * E, : n * E] = -np.eye(n * E)  # d/E - lam <= 0
    A_ub[: n * E, -1] = 1.0 / E
    A_ub[n * E :, : n * E] = np.kron(np.eye(n), np.ones((1, E)))  # sum_j lam_ij <= 1
    b_ub = np.concatenate([np.zeros(n * E), np.ones(n)])
    res = linprog(
        cost,
        A_ub=A_ub,
        b_ub=b_ub,
        A_eq=np.hstack([G, np.zeros((m, 1))]),
        b_eq=np.zeros(m),
        bounds=[(0.0, None)] * (n * E + 1),
        method="highs",
    )
    solve_time = time.perf_counter() - t0
    if res.status != 0:
        raise SolverError(f"frictional form-closure LP failed: {res.message}")
    d = float(res.x[-1])
    d_star = d if d > D_STAR_TOL else 0.0
    lam = np.asarray(res.x[:-1]).reshape(n, E)
    rank = int(numerical_rank(G))
    ok = d_star > 0.0 and rank == m
    closure = ("frictional form" if np.any(mu_a > 0) else "form") if ok else "force"
    esc = words = None
    if not ok:
        esc = escape_twist(G, (), rank_deficient=rank < m)
        if esc is not None:
            both = bool(np.max(np.abs(G.T @ esc)) <= 1e-9 * np.abs(G).max())
            P, _ = check_contacts(points, normals)
            o = P.mean(axis=0) if center is None else np.asarray(center, dtype=np.float64)
            words = describe_twist(esc, o, both_senses=both)
    return FrictionalFormClosure(
        d_star=d_star,
        closure=closure,
        c_normal=lam.sum(axis=1),
        lam=lam,
        rank=rank,
        m=m,
        mu=mu_a,
        edges=E,
        escape=esc,
        escape_words=words,
        solve_time=solve_time,
    )
