"""How hard must point fingers press to hold the part against its weight in any orientation?

A form-closure grasp holds any load only if its fingers may press hard enough. This module
gives the least finger force, per unit of the part's weight, that holds the part against
gravity in *every* orientation, for the hand ``synth sim`` simulates: stiff fingers of equal
stiffness that first press with a fixed *balanced squeeze* (internal forces, which the part
feels as no net wrench), each limited to the grip force.

The stiff hand, frictionless contacts
-------------------------------------
Let ``W`` (6 x k) be the frictionless wrench matrix of the k contacts with moments about the
centre of mass, so that the weight ``m g d`` (``d`` a unit direction) loads the part with
``w = m g (d, 0)``. With fingers of equal stiffness ``kappa`` along their normals, a small
twist ``delta`` of the part changes the normal forces by ``-kappa W^T delta``; equilibrium
``W dlam = -w`` gives ``delta = (W W^T)^-1 w / kappa`` and

    dlam = -W^+ w = -m g A d,    A = (W^+)[:, :3]   (k x 3),

whatever the stiffness and the unit of length (the response is the least-norm solution, which
does not change when moments are taken about another point or in other units). The fingers
start from a preload ``p`` in the null space of ``W`` (a squeeze that does not move the part),
so in orientation ``d`` finger ``i`` presses with ``p_i - m g A_i . d``, which over every unit
``d`` ranges over ``p_i -+ m g |A_i|``. The part is held in every orientation with no finger
letting go and none above the grip force ``F`` exactly when

    p_i >= m g |A_i|   and   p_i + m g |A_i| <= F   for every finger i.

Per unit weight, the least ``F`` is the LP ``min F' s.t. p' = Z y, p' >= |A|, p' + |A| <= F'``
(``Z`` a basis of the null space). For the usual 7 contacts the null space is one vector ``c >
0`` and the answer is closed: ``t = max_i |A_i| / c_i``, ``F' = max_i (t c_i + |A_i|)``, the
preload ``p' = t c`` (scaled by ``F / F'`` it is the squeeze that holds the largest weight with
grip ``F``). This is exact for every orientation, not sampled.

Other grasps
------------
With friction, or with a fingertip touching at several contacts (a groove, an inside corner),
the response is not fixed by the stiffnesses alone; the measure is then the least squeeze of
:func:`synth.scores.gravity.gravity_hold_batch` (each finger free to press with any force up
to ``F``, a certified bound over every orientation), which can only be lower than a fixed
preload's.

The weight is not all a grasp must bear: a part's centre of mass is rarely known exactly, and
a grasp that resists a turn about it only barely (a tessellated sphere's) holds its weight and
nothing else. So the loads are the weight in any direction plus any moment up to
``COM_RTOL`` times weight times size (the weight acting that far from the centre of mass):
with ``T = (W^+)[:, 3:]`` (moments scaled by the size), finger ``i``'s force ranges over
``p_i -+ m g (|A_i| + COM_RTOL |T_i|)``, and ``|A_i|`` above reads ``|A_i| + COM_RTOL |T_i|``.

The number ``F'`` is the grasp's *squeeze per weight*: a grip of ``F`` newtons per finger holds
a part of weight ``m g`` in every orientation when ``F >= F' m g``; its *margin* is
``F / (F' m g)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.scores.cones import check_contacts_batch
from synth.scores.gram import GramFactors, gram_factors
from synth.scores.quality import scaled_wrenches

__all__ = ["FingerHold", "finger_hold_batch", "stiff_hold_batch", "internal_squeeze",
           "HOLD_MODELS", "COM_RTOL"]

#: The hand models a :class:`FingerHold` may describe.
HOLD_MODELS = ("stiff", "any")
#: The measure holds the weight plus any moment up to this many times weight times size:
#: the weight acting up to this far from the centre of mass (a part's mass distribution is
#: rarely known exactly), or a small push off its centre. It also keeps out grasps that
#: resist a turn about the centre of mass only barely (a tessellated sphere's).
COM_RTOL: float = 0.02
#: Relative size of the smallest singular value of the scaled wrench matrix below which it is
#: treated as rank deficient (the part has a free motion: no squeeze holds it).
_RANK_RTOL = 1e-9


@dataclass(frozen=True)
class FingerHold:
    """Least finger force per weight of a batch of grasps (see the module).

    Attributes
    ----------
    squeeze_per_weight : (B,) float
        Least grip force per finger, over the part's weight, that holds it in every
        orientation; ``inf`` where none does.
    preload : (B, k) float
        The balanced squeeze per weight, normal force of each contact (``stiff`` model;
        zeros under ``any`` and where ``squeeze_per_weight`` is inf).
    response : (B, k, 3) float
        ``A``: per unit weight along ``d``, contact ``i``'s normal force changes by
        ``-A_i . d`` (``stiff`` model; zeros under ``any``).
    model : str
        ``"stiff"`` (equal-stiffness fingers from a fixed balanced squeeze, exact) or
        ``"any"`` (each finger free to press with any force, a certified LP bound).
    torque_response : (B, k, 3) float
        Per unit moment (over weight times size) about each axis, contact ``i``'s normal
        force changes by ``-T_i . m`` (``stiff`` model; zeros under ``any``).
    """

    squeeze_per_weight: NDArray[np.float64]
    preload: NDArray[np.float64]
    response: NDArray[np.float64]
    model: str
    torque_response: NDArray[np.float64] | None = None

    def margin(self, grip: float, weight: float) -> NDArray[np.float64]:
        """Grip force over the least force that holds a part of ``weight`` (same unit)."""
        with np.errstate(divide="ignore"):
            return float(grip) / (self.squeeze_per_weight * float(weight))


def stiff_hold_batch(points: ArrayLike, normals: ArrayLike, center_mass: ArrayLike,
                     length: float, factors: GramFactors | None = None,
                     at_most: float = np.inf, forces: ArrayLike | None = None) -> FingerHold:
    """The stiff hand's least force per weight of frictionless grasps (module notes).

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and unit normals into the part, one finger per contact, k >= 7.
    center_mass : (3,) float
    length : float
        The part's size (scales moments; no effect on the result).
    factors : GramFactors, optional
        :func:`synth.scores.gram.gram_factors` of these grasps' scaled wrenches
        (:func:`synth.scores.quality.scaled_wrenches` with ``center_mass`` and ``length``),
        when the caller already has them; computed here otherwise.
    at_most : float, optional
        A caller that only asks whether the squeeze is at most this (the planner's physical
        floor): a grasp of more than seven contacts for which a feasible preload (the
        better of the all-ones squeeze and ``forces``, each projected onto the null space,
        where every entry is positive) needs no more gets that preload and its squeeze, an
        upper bound of the least, instead of the LP's least (no LP). Default: every squeeze
        exact.
    forces : (B, k) float, optional
        Normal forces of each grasp that leave the part at rest, every entry positive where
        known, zeros elsewhere (:attr:`synth.scores.batch.BatchScores.forces`, which the d*
        LP finds): with more than seven contacts they are a second start for the bound and
        the LP, so that a grasp whose all-ones squeeze has an entry that is not positive is
        solved in the batch too, not one at a time.

    Returns
    -------
    FingerHold
        ``model`` ``"stiff"``.

    Examples
    --------
    Seven fingers on the unit cube:

    >>> from tests.cli_support import CUBE_FC  # doctest: +SKIP
    >>> h = stiff_hold_batch([CUBE_FC["points"]], [CUBE_FC["normals"]], [0, 0, 0], 3 ** .5)
    """
    P, N = check_contacts_batch(points, normals)
    B, k, _ = P.shape
    spw = np.full(B, np.inf)
    pre = np.zeros((B, k))
    A = np.zeros((B, k, 3))
    T = np.zeros((B, k, 3))
    if B == 0 or k < 7:
        return FingerHold(spw, pre, A, "stiff", T)
    if factors is None:
        factors = gram_factors(scaled_wrenches(P, N, np.asarray(center_mass, float),
                                               float(length)))
    elif factors.wrenches.shape != (B, 6, k):
        raise InputError(f"factors: of matrices of shape {factors.wrenches.shape}, expected "
                         f"{(B, 6, k)} for {B} grasps of {k} contacts")
    W = factors.wrenches  # (B, 6, k)
    g = None if forces is None else np.asarray(forces, float)
    if g is not None and g.shape != (B, k):
        raise InputError(f"forces: of shape {g.shape}, expected {(B, k)} for {B} grasps of "
                         f"{k} contacts")
    rest = np.arange(B)
    # certified full rank: the pseudo-inverse from the Gram factor (with more than seven
    # contacts only when a bound may spare the LP, which needs a null-space basis)
    rows = np.flatnonzero(factors.certified) if k == 7 or np.isfinite(at_most) else rest[:0]
    if len(rows):
        # of the balanced rows S W: (S W)^+ = W^T G^-1 S^-1 with G = W W^T, so that
        # W^+ = (S W)^+ S; the null space is the same for both
        Xc = factors.inverse_factor[rows]
        Ginv = np.einsum("bji,bjk->bik", Xc, Xc)  # (S W W^T S)^-1
        pinv = (np.einsum("bji,bjk->bik", factors.balanced[rows], Ginv)
                * factors.scale[rows, None, :])  # W^+, (b, k, 6)
        A[rows], T[rows] = pinv[:, :, :3], pinv[:, :, 3:]
        r = _reach(A[rows], T[rows])
        if k == 7:
            _closed_form(r, factors.null[rows], rows, pre, spw)
            rest = np.flatnonzero(~factors.certified)
        else:  # a start within the bound: projected by I - W^+ W, no basis needed
            Wr = W[rows]
            p0, F0 = _best_start(lambda x: x - np.einsum("bkm,bm->bk", pinv, np.einsum(
                "bmk,bk->bm", Wr, x)), r, None if g is None else g[rows])
            within = F0 <= at_most
            pre[rows[within]], spw[rows[within]] = p0[within], F0[within]
            rest = np.setdiff1d(rest, rows[within], assume_unique=True)
    if len(rest):
        U, s, Vt = np.linalg.svd(W[rest])
        full = s[:, -1] > _RANK_RTOL * s[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            pinv = np.einsum("bji,bj,bkj->bik", Vt[:, :6], 1.0 / s, U)  # (b, k, 6)
        A[rest[full]], T[rest[full]] = pinv[full, :, :3], pinv[full, :, 3:]
        Z = np.swapaxes(Vt[:, 6:], 1, 2)  # (b, k, k - 6) null-space basis
        r = _reach(A, T)
        if k == 7:
            _closed_form(r[rest[full]], Z[full, :, 0], rest[full], pre, spw)
        else:
            lp = np.flatnonzero(full)
            if len(lp):
                # the start: the better of the all-ones squeeze and the given forces, each
                # projected onto the null space, Z Z^T x
                Zl = Z[lp]
                p0, F0 = _best_start(lambda x: np.einsum("bkn,bn->bk", Zl, np.einsum(
                    "bkn,bk->bn", Zl, x)), r[rest[lp]], None if g is None else g[rest[lp]])
                # (False where there is no such preload, F0 inf, and without a bound)
                within = (F0 <= at_most) & np.isfinite(at_most)
                pre[rest[lp[within]]], spw[rest[lp[within]]] = p0[within], F0[within]
                start = np.isfinite(F0) & ~within
                solved = _stiff_lp_batch(Z[lp[start]], r[rest[lp[start]]], p0[start],
                                         F0[start])
                ok = np.isfinite(solved[1])
                pre[rest[lp[start][ok]]], spw[rest[lp[start][ok]]] = (solved[0][ok],
                                                                      solved[1][ok])
                lp = np.concatenate([lp[start][~ok], lp[~np.isfinite(F0)]])
            for j in lp:  # no positive start, or the batch could not verify its answer
                b = rest[j]
                got = _stiff_lp(Z[j], r[b])
                if got is not None:
                    pre[b] = got
                    spw[b] = float(np.max(got + r[b]))
    A[~np.isfinite(spw)] = 0.0
    T[~np.isfinite(spw)] = 0.0
    return FingerHold(spw, pre, A, "stiff", T)


def _reach(A: NDArray[np.float64], T: NDArray[np.float64]) -> NDArray[np.float64]:
    """The most each finger's force changes, per unit weight, over the loads the measure
    covers: the weight in any direction (``|A_i|``) and any moment up to ``COM_RTOL`` times
    weight times size (``COM_RTOL |T_i|``, moments scaled by the size). (b, k)."""
    return np.linalg.norm(A, axis=2) + COM_RTOL * np.linalg.norm(T, axis=2)


def _closed_form(r: NDArray[np.float64], c: NDArray[np.float64], rows: NDArray[np.int64],
                 pre: NDArray[np.float64], spw: NDArray[np.float64]) -> None:
    """The seven-contact answer (module notes) for the grasps ``rows``, whose reaches are
    ``r`` (b, 7) and null vectors ``c`` (b, 7), written into ``pre`` and ``spw``."""
    p, F = _scaled_preload(c * np.where(c.sum(axis=1, keepdims=True) < 0, -1.0, 1.0), r)
    ok = np.isfinite(F)
    pre[rows[ok]] = p[ok]
    spw[rows[ok]] = F[ok]


def _best_start(project: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                r: NDArray[np.float64], forces: NDArray[np.float64] | None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The better (:func:`_scaled_preload`) of two squeezes for grasps of more than seven
    contacts whose reaches are ``r`` (b, k): the all-ones squeeze and ``forces`` (b, k), when
    given, each mapped onto the null space by ``project`` ((b, k) -> (b, k))."""
    p0, F0 = _scaled_preload(project(np.ones_like(r)), r)
    if forces is not None:
        p1, F1 = _scaled_preload(project(forces), r)
        better = F1 < F0
        p0[better], F0[better] = p1[better], F1[better]
    return p0, F0


def _scaled_preload(c: NDArray[np.float64], r: NDArray[np.float64]
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The squeezes ``c`` (b, k) in the null space scaled to ``t c`` with ``t = max r_i / c_i``
    (every finger pressing at least its reach ``r`` (b, k)), and their squeeze per weight
    ``max(t c_i + r_i)`` (b,): with seven contacts, where ``c`` is the null line, the least
    (module notes); with more, a feasible preload. The squeeze is ``inf`` where ``c`` has an
    entry that is not positive (no such preload)."""
    ok = c.min(axis=1) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.max(r / np.where(ok[:, None], c, 1.0), axis=1)
    p = np.where(ok[:, None], t[:, None] * c, 0.0)
    return p, np.where(ok, np.max(p + r, axis=1), np.inf)


def _stiff_lp_batch(Z: NDArray[np.float64], r: NDArray[np.float64], p0: NDArray[np.float64],
                    F0: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`_stiff_lp` of many grasps at once (null-space bases ``Z`` (b, k, n), reaches
    ``r`` (b, k)) by the batched simplex (:func:`synth.scores.simplex.solve_batch`), started
    from a feasible preload ``p0`` (b, k) of squeeze ``F0`` (b,): with ``p = p0 + Z d`` and
    ``F = F0 - e``, the slacks ``s = p - r`` and ``u = F - p - r`` are the identity basis of
    the start, feasible at ``d = 0, e = 0``, and the LP maximises ``e`` (``d`` and ``e`` free,
    each split in two). Returns the preloads (b, k) and squeezes (b,), the squeeze ``inf``
    where the simplex could not verify its answer (the caller solves those one by one)."""
    from synth.scores.simplex import OPTIMAL, solve_batch

    nb, k, n = Z.shape
    if nb == 0:
        return np.zeros((0, k)), np.zeros(0)
    A = np.zeros((nb, 2 * k, 2 * k + 2 * n + 2))
    eye = np.eye(k)
    A[:, :k, :k] = eye  # s
    A[:, k:, k:2 * k] = eye  # u
    A[:, :k, 2 * k:2 * k + n] = -Z  # d+
    A[:, :k, 2 * k + n:2 * k + 2 * n] = Z  # d-
    A[:, k:, 2 * k:2 * k + n] = Z
    A[:, k:, 2 * k + n:2 * k + 2 * n] = -Z
    A[:, k:, -2] = 1.0  # e+ (F = F0 - e+ + e-)
    A[:, k:, -1] = -1.0  # e-
    b = np.concatenate([p0 - r, F0[:, None] - p0 - r], axis=1)
    np.maximum(b, 0.0, out=b)  # (round-off of the start: it is feasible)
    c = np.zeros(2 * k + 2 * n + 2)
    c[-2], c[-1] = 1.0, -1.0
    sol = solve_batch(A, b, c, np.full(c.shape, np.inf), np.arange(2 * k), compiled=False)
    x = sol.x
    d = x[:, 2 * k:2 * k + n] - x[:, 2 * k + n:2 * k + 2 * n]
    p = np.maximum(p0 + np.einsum("bkn,bn->bk", Z, d), r)
    F = np.where(sol.status == OPTIMAL, np.max(p + r, axis=1), np.inf)
    return p, F


def _stiff_lp(Z: NDArray[np.float64], r: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """The best preload ``Z y`` of one grasp: ``min F`` with ``Z y >= r``, ``Z y + r <= F``;
    None when no preload keeps every finger pressing."""
    k, n = Z.shape
    cost = np.zeros(n + 1)
    cost[-1] = 1.0
    A_ub = np.block([[-Z, np.zeros((k, 1))], [Z, -np.ones((k, 1))]])
    b_ub = np.concatenate([-r, -r])
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * (n + 1),
                  method="highs")
    if res.status == 2:  # infeasible: not form closure
        return None
    if res.status != 0:
        raise SolverError(f"stiff-hand preload LP failed: {res.message}")
    return np.maximum(Z @ res.x[:n], r)


def internal_squeeze(points: ArrayLike, normals: ArrayLike, center_mass: ArrayLike,
                     length: float, mu: float = 0.0, edges: int = 8
                     ) -> NDArray[np.float64] | None:
    """Normal forces of the most even squeeze that leaves the part at rest, for any grasp.

    The LP ``max s`` over contact forces ``lam`` in the (linearised) friction cones with
    ``W lam = 0`` (no net wrench), every normal force at least ``s`` and at most 1: with
    ``mu = 0`` Trinkle's d* LP. Used as the squeeze of grasps the stiff model does not
    cover (friction, several contacts per fingertip).

    Parameters
    ----------
    points, normals : (k, 3) float
    center_mass : (3,) float
    length : float
    mu : float
    edges : int

    Returns
    -------
    (k,) float or None
        Normal forces, the largest 1; None when no squeeze presses every contact.
    """
    from synth.scores.cones import cone_wrenches_batch

    P, N = check_contacts_batch(np.asarray(points, float)[None], np.asarray(normals, float)[None])
    k = P.shape[1]
    G = cone_wrenches_batch(P, N, float(mu), np.asarray(center_mass, float), int(edges))[0]
    G[3:] /= float(length)
    M = G.shape[1] // k
    n = k * M
    S = np.kron(np.eye(k), np.ones((1, M)))  # normal force of each contact
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    A_ub = np.block([[-S, np.ones((k, 1))], [S, np.zeros((k, 1))]])
    b_ub = np.concatenate([np.zeros(k), np.ones(k)])
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, A_eq=np.hstack([G, np.zeros((6, 1))]),
                  b_eq=np.zeros(6), bounds=[(0.0, None)] * (n + 1), method="highs")
    if res.status != 0:
        raise SolverError(f"internal squeeze LP failed: {res.message}")
    if res.x[-1] <= 1e-9:
        return None
    f = S @ res.x[:n]
    return f / f.max()


def finger_hold_batch(points: ArrayLike, normals: ArrayLike, center_mass: ArrayLike,
                      length: float, mu: float = 0.0, finger: ArrayLike | None = None,
                      edges: int = 8) -> FingerHold:
    """Least finger force per weight that holds each grasp in every orientation.

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and unit normals into the part.
    center_mass : (3,) float
    length : float
    mu : float
        Coulomb coefficient the grasps are planned with (0: frictionless).
    finger : (B, k) int, optional
        Fingertip of each contact (default one each).
    edges : int
        Friction cone edges (with ``mu > 0``).

    Returns
    -------
    FingerHold
        The ``stiff`` model for frictionless grasps with one contact per finger, else ``any``.
    """
    P, N = check_contacts_batch(points, normals)
    B, k, _ = P.shape
    own = finger is None or bool((np.asarray(finger) == np.arange(k)).all())
    if mu == 0 and own:
        return stiff_hold_batch(P, N, center_mass, length)
    from synth.scores.gravity import gravity_hold_batch

    h = gravity_hold_batch(P, N, mu, 0.0, center_mass, length, edges=edges)
    return FingerHold(np.asarray(h.squeeze_per_weight, float), np.zeros((B, k)),
                      np.zeros((B, k, 3)), "any")
