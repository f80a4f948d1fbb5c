"""Frictional form closure (Trinkle 1992, Section II.B) with linearised Coulomb cones.

The paper's test, from its equilibrium (1)-(3) and LP (12)-(14), (18), (19): each contact
pushes with a normal intensity ``c_in`` and tangential intensities ``c_it, c_io`` of either
sign; the measure is

    maximise d  s.t.  W_n c_n + W_t c_t + W_o c_o = 0,   c_n >= d,   -1 <= c_n <= 1,
                      every contact force inside its friction cone.

``d`` bounds the normal intensities only (inequality (13) is left as it is, the paper says), and
the box of Example 1 applies to them. The cone ``|(c_it, c_io)| <= mu_i c_in`` is replaced by
the inscribed pyramid spanned by ``edges`` forces ``e_ij = n_i + mu_i (cos a_j u_i + sin a_j
v_i)``, ``a_j = 2 pi j / edges``, so every force the test uses lies in the true cone and a
"yes" is never optimistic. With ``lam_ij >= 0`` along the edges the force of contact ``i`` is
``sum_j lam_ij e_ij`` and its normal intensity ``c_in = sum_j lam_ij``:

    maximise d  s.t.  G lam = 0,   sum_j lam_ij >= d,   sum_j lam_ij <= 1,   lam >= 0.

In the plane a cone has exactly its two edges ``n_i +- mu_i t_i`` and ``edges`` is ignored; on
the paper's Example 2 (contact 3 with mu = 0.3 > tan 15 deg) this reproduces Table 2 exactly.
With every mu = 0 the edges coincide with the normals and d* is :func:`synth.form_closure`'s.

Soft contacts (``torsion`` = gamma > 0, a length) also resist a moment about their normal, in
MuJoCo's condim-4 cone ``f_n^2 >= |f_t|^2 / mu^2 + tau^2 / gamma^2`` linearised by inscribed
generators (:mod:`synth.scores.cones`); the LP is the same with those generators. Two soft
contacts closing on a part (a parallel-jaw grasp) are frictional form closure exactly when the
line between them lies strictly inside both (linearised) friction cones and gamma > 0; two point
contacts never are (the rotation about that line is free). Exactly on a cone's boundary (a case
of measure zero) the paper's LP, which bounds only the normal intensities, still finds its
internal force and reports closure.

The paper first finds which normal intensities can grow without bound once friction counts
(its footnote 2) and adds only those contacts' friction columns. When d* > 0 every contact is
such a contact, so d* needs no separate step; :func:`frictional_squeezable` finds that set with
one LP (the cone of internal forces is closed under addition, so one internal force makes every
squeezable contact push) and with it the frictional closure class: frictional form, strong
force or force.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.limits import MAX_MU
from synth.scores.arguments import center_arg
from synth.scores.cones import cone_wrenches_batch
from synth.scores.escape import describe_twist, escape_twist
from synth.scores.friction_lp import solve_frictional_lp
from synth.scores.wrench import balance_rows, check_contacts, numerical_rank, wrench_matrix
from synth.tolerances import D_STAR_TOL

__all__ = [
    "FrictionalFormClosure",
    "FrictionalSqueeze",
    "frictional_form_closure",
    "frictional_squeezable",
    "friction_cone_wrenches",
]


@dataclass(frozen=True)
class FrictionalFormClosure:
    """Result of :func:`frictional_form_closure`.

    Attributes
    ----------
    d_star : float
        Trinkle's frictional measure: the largest ``min_i c_in`` over internal forces in the
        (linearised) cones with normal intensities in ``[0, 1]``; equal to the frictionless d*
        when every mu is 0.
    closure : str
        ``"frictional form"`` (some mu > 0), ``"form"`` (all mu = 0) or ``"force"``; see
        :func:`frictional_squeezable` for the strong-force class.
    c_normal : (n,) float
        Normal intensities of the optimal internal force.
    lam : (n, edges) float
        Its intensities along the cone edges.
    rank : int
        Numerical rank of the edge wrench matrix ``G`` (that of ``[W_n W_t W_o]`` restricted
        to the contacts with friction, for mu > 0).
    m : int
        6 in space, 3 in the plane.
    mu : (n,) float
        Friction coefficient of each contact.
    edges : int
        Cone edges per contact actually used (2 in the plane); a soft contact's cone has
        ``3 edges + 2`` generators (``lam`` has that many columns).
    torsion : (n,) float
        Torsional coefficient (a length) of each contact; 0 for point contacts.
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
    torsion: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def is_closure(self) -> bool:
        """True for (frictional) form closure."""
        return self.closure != "force"


@dataclass(frozen=True)
class FrictionalSqueeze:
    """Result of :func:`frictional_squeezable`.

    Attributes
    ----------
    squeezable : (n,) bool
        Contacts whose normal intensity can grow without bound with friction (an internal
        force in the linearised cones pushes on them).
    friction_columns : (n,) bool
        Contacts whose tangential (and torsional) columns the paper's test includes:
        squeezable, with mu > 0 or torsion > 0.
    c_normal : (n,) float
        Normal intensities of an internal force pushing on every squeezable contact (scaled
        so that the smallest positive one is 1).
    rank : int
        Rank of the wrench matrix of the test: every normal column, and the edge columns of
        the contacts in ``friction_columns``.
    closure : str
        ``"frictional form"`` (every contact squeezable, full rank; ``"form"`` when no mu is
        positive), ``"strong force"`` (some but not all squeezable, or full squeezing without
        full rank) or ``"force"`` (none).
    """

    squeezable: NDArray[np.bool_]
    friction_columns: NDArray[np.bool_]
    c_normal: NDArray[np.float64] = field(repr=False)
    rank: int
    closure: str


def _check_mu(mu: ArrayLike, n: int, name: str = "mu") -> NDArray[np.float64]:
    try:
        mu_a = np.broadcast_to(np.asarray(mu, dtype=np.float64), (n,)) if np.ndim(mu) == 0 \
            else np.asarray(mu, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        mu_a = np.full(0, np.nan)
    top = MAX_MU if name == "mu" else np.inf  # past it the LP's numbers lose their meaning
    if mu is None or mu_a.shape != (n,) or not np.all(np.isfinite(mu_a)) or np.any(mu_a < 0) \
            or np.any(mu_a > top):
        raise InputError(
            f"{name} must be a nonnegative finite scalar or one value per contact ({n})"
            + (f", at most {MAX_MU:g}" if name == "mu" else "") + f", got {mu!r:.80}"
        )
    return np.array(mu_a)


def friction_cone_wrenches(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
    torsion: ArrayLike = 0.0,
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
    torsion : float or (n,) float
        Torsional coefficients (lengths) of soft contacts, in space only (default 0: point
        contacts); see :mod:`synth.scores.cones`.

    Returns
    -------
    G : (m, n, E) float
        ``G[:, i, j]`` is the unit-normal-intensity wrench of generator ``j`` of contact ``i``
        (``E = edges``, or ``3 edges + 2`` with torsion).

    Examples
    --------
    >>> friction_cone_wrenches([[1, 0, 0], [-1, 0, 0]], [[-1, 0, 0], [1, 0, 0]], 0.5).shape
    (6, 2, 8)
    """
    P, N = check_contacts(points, normals)
    n, d = P.shape
    mu_a = _check_mu(mu, n)
    gam = _check_mu(torsion, n, "torsion")
    o = P.mean(axis=0) if center is None else center_arg(center, d)
    if d == 2:
        if np.any(gam > 0):
            raise InputError("torsion (a moment about the contact normal) needs contacts in "
                             "space, got planar (n, 2) contacts")
        R = P - o
        T = np.stack([-N[:, 1], N[:, 0]], axis=1)
        F = N[:, None, :] + mu_a[:, None, None] * np.stack([T, -T], axis=1)  # (n, 2, 2)
        tau = R[:, None, 0] * F[..., 1] - R[:, None, 1] * F[..., 0]
        return np.concatenate([F.transpose(2, 0, 1), tau[None]], axis=0)
    G = cone_wrenches_batch(P[None], N[None], mu_a, o, edges, gam)[0]  # (6, n * E)
    return G.reshape(6, n, -1)


def _edge_matrix(points: ArrayLike, normals: ArrayLike, mu: ArrayLike, center: ArrayLike | None,
                 edges: int, torsion: ArrayLike) -> tuple[NDArray[np.float64],
                                                          NDArray[np.float64]]:
    """Generator wrenches (m, n * E) and the mu array (n,)."""
    G3 = friction_cone_wrenches(points, normals, mu, center=center, edges=edges, torsion=torsion)
    m, n, E = G3.shape
    return G3.reshape(m, n * E), _check_mu(mu, n)


def frictional_form_closure(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
    torsion: ArrayLike = 0.0,
) -> FrictionalFormClosure:
    """Trinkle's frictional form-closure measure of point contacts with Coulomb friction.

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
        Edges of each linearised (inscribed) cone in space (default 8, at least 3).
    torsion : float or (n,) float
        Torsional coefficient gamma of soft contacts, a length in the points' unit (default
        0: point contacts).

    Returns
    -------
    FrictionalFormClosure

    Examples
    --------
    >>> pts = [[1, 0, 0], [-1, 0, 0], [0, 1, 0]]
    >>> nrm = [[-1, 0, 0], [1, 0, 0], [0, -1, 0]]
    >>> frictional_form_closure(pts, nrm, mu=0.5).closure
    'force'
    >>> pinch = [[1, 0, 0], [-1, 0, 0]], [[-1, 0, 0], [1, 0, 0]]
    >>> frictional_form_closure(*pinch, mu=0.5, torsion=0.1).closure
    'frictional form'
    """
    G, mu_a = _edge_matrix(points, normals, mu, center, edges, torsion)
    gam = _check_mu(torsion, len(mu_a), "torsion")
    m = G.shape[0]
    n = len(mu_a)
    E = G.shape[1] // n
    t0 = time.perf_counter()
    d, lam = solve_frictional_lp(G, n)
    solve_time = time.perf_counter() - t0
    d_star = d if d > D_STAR_TOL else 0.0
    rank = int(numerical_rank(G))
    ok = d_star > 0.0 and rank == m
    closure = ("frictional form" if np.any(mu_a > 0) or np.any(gam > 0) else "form") if ok \
        else "force"
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
        edges=int(edges) if np.any(gam > 0) else E,
        escape=esc,
        escape_words=words,
        solve_time=solve_time,
        torsion=gam,
    )


def frictional_squeezable(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    center: ArrayLike | None = None,
    edges: int = 8,
    torsion: ArrayLike = 0.0,
) -> FrictionalSqueeze:
    """The contacts that can be squeezed without bound with friction, from one LP.

    The first step of the paper's frictional procedure (Section II.B, footnote 2): the
    internal forces with every contact force in its linearised cone form a convex cone, so
    one LP finds the largest set of contacts such a force can push on,

        maximise sum(s)  s.t.  G lam = 0,  s_i <= sum_j lam_ij,  0 <= s <= 1,  lam >= 0,

    whose optimal ``s`` is the indicator of that set.

    Parameters
    ----------
    points : (n, 3) or (n, 2) float
    normals : (n, 3) or (n, 2) float
        Inward normals.
    mu : float or (n,) float
    center : (3,) or (2,) float, optional
    edges : int
    torsion : float or (n,) float
        Torsional coefficients of soft contacts (default 0).

    Returns
    -------
    FrictionalSqueeze

    Examples
    --------
    >>> pts = [[1, 0, 0], [-1, 0, 0], [0, 1, 0]]
    >>> nrm = [[-1, 0, 0], [1, 0, 0], [0, -1, 0]]
    >>> frictional_squeezable(pts, nrm, mu=0.5).squeezable.tolist()
    [True, True, False]
    """
    G, mu_a = _edge_matrix(points, normals, mu, center, edges, torsion)
    gam = _check_mu(torsion, len(mu_a), "torsion")
    m = G.shape[0]
    n = len(mu_a)
    E = G.shape[1] // n
    sums = np.kron(np.eye(n), np.ones((1, E)))
    # x = [lam (n*E), s (n)]; minimise -sum(s)
    cost = np.concatenate([np.zeros(n * E), -np.ones(n)])
    res = linprog(cost, A_ub=np.hstack([-sums, np.eye(n)]), b_ub=np.zeros(n),
                  A_eq=np.hstack([balance_rows(G)[0], np.zeros((m, n))]), b_eq=np.zeros(m),
                  bounds=[(0.0, None)] * (n * E) + [(0.0, 1.0)] * n, method="highs")
    if res.status != 0:
        raise SolverError(f"frictional squeezable-contact LP failed: {res.message}")
    squeeze = np.asarray(res.x[n * E :] > 0.5)
    c_n = sums @ res.x[: n * E]
    if squeeze.any():
        c_n = c_n / c_n[squeeze].min()
    cols = squeeze & ((mu_a > 0) | (gam > 0))
    # the test's matrix: every normal column, and the edges of the contacts with friction
    # (which span their normal and tangential columns)
    P, N = check_contacts(points, normals)
    o = P.mean(axis=0) if center is None else np.asarray(center, dtype=np.float64)
    rank = int(numerical_rank(np.hstack([wrench_matrix(P, N, o), G[:, np.repeat(cols, E)]])))
    if squeeze.all() and rank == m:
        closure = "frictional form" if cols.any() else "form"
    else:
        closure = "strong force" if squeeze.any() else "force"
    return FrictionalSqueeze(squeeze, cols, c_n, rank, closure)
