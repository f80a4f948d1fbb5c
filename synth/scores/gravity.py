"""Does a grasp hold the part's weight? The least squeeze against gravity, by LP.

A gripper squeezes the part with its pads; the part's weight ``m g`` pulls along a gravity
direction ``d``. With every contact force inside its linearised cone (point or soft contact,
:mod:`synth.scores.cones`) and moments about the centre of mass (where gravity has none), the
grasp holds with squeeze ``F`` when some contact forces balance the weight with every normal
force at most ``F``:

    G lam + m g (d, 0) = 0,   sum_j lam_ij <= F for every contact i,   lam >= 0.

The least such ``F`` divided by ``m g`` is the *squeeze per weight* of the grasp in direction
``d``, a number without units (1 / (2 mu) for a box pinched at its centre of mass with gravity
along the pads); it is ``inf`` when no squeeze holds. Writing ``s = m g / F`` and
``lam' = lam / F`` gives one LP per grasp and direction with a feasible start,

    maximise s  s.t.  G lam' + s (d, 0) = 0,   sum_j lam'_ij + g_i = 1,   lam', g, s >= 0,

solved for all grasps and directions at once by the batched simplex of
:mod:`synth.scores.simplex` (unverified optima are re-solved with HiGHS). The model: each pad
can press with any normal force up to the squeeze, the difference between the two pads being
taken by the gripper's mechanism, which holds its fingers symmetric.

In every orientation
--------------------
The squeeze per weight ``f(d)`` is sublinear in ``d`` (positively homogeneous and convex: two
loads are held by the sum of their forces). So on the cone of a spherical triangle with
vertices ``s_1, s_2, s_3`` it is at most ``max f(s_i) / h``, ``h`` being the distance from the
origin to the triangle's plane. synth evaluates ``f`` at the 162 vertices of an icosphere
(320 triangles, ``h >= 0.982``) and reports the largest of those bounds: a value that holds in
every orientation for certain, at most 1.8% above the worst sampled direction (both are in
the result). Not every direction needs its LP: the icosahedron's 12 are solved, and each
finer direction halves an edge ``v_a v_b`` of the coarser sphere, where sublinearity gives
``f <= (f(v_a) + f(v_b)) / |v_a + v_b|``; a direction whose bound stays below both the worst
value and the bound found so far cannot change either, and is skipped (about 44 of the 162
LPs are solved for a typical pinch; the results are those of solving all 162).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.scores.arguments import center_arg, coefficients_arg, length_arg, numbers_arg
from synth.scores.cones import check_contacts_batch, cone_name, cone_wrenches_batch
from synth.scores.simplex import UNVERIFIED, compiled_for, solve_batch

__all__ = ["GRAVITY", "GravityHold", "gravity_hold_batch", "least_squeeze_batch",
           "ICOSPHERE_LEVEL", "MAX_LEVEL"]

#: Standard gravity, m/s^2, to turn a mass in kg into a weight in newtons.
GRAVITY: float = 9.80665
#: Subdivisions of the icosahedron whose vertices are the gravity directions evaluated.
ICOSPHERE_LEVEL: int = 2
#: Finest icosphere ``gravity_hold_batch`` takes (6: 40,962 directions, an LP each).
MAX_LEVEL: int = 6
#: Largest number of LPs per solver call (keeps the LP matrices in cache).
_CHUNK = 2048
#: A direction is skipped only when its bound stays below the worst value (and the bound)
#: found so far by this relative margin, above the LPs' accuracy (optimality to 1e-7, HiGHS's
#: default tolerances), so that LP noise cannot decide what is skipped.
_SKIP_MARGIN = 1e-6


@dataclass(frozen=True)
class GravityHold:
    """Result of :func:`gravity_hold_batch`.

    Attributes
    ----------
    squeeze_per_weight : (B,) float
        Least squeeze, divided by the part's weight, that holds each grasp against gravity in
        every orientation (a certified upper bound over all directions) or in the given
        direction; ``inf`` where some direction cannot be held by any squeeze.
    sampled : (B,) float
        The worst value among the directions evaluated (equal to ``squeeze_per_weight`` for
        a given direction): the true worst case lies between the two.
    worst_direction : (B, 3) float
        The evaluated gravity direction (unit, pointing down) needing the most squeeze.
    directions : int
        Gravity directions evaluated per grasp.
    cone : str
        The linearised contact cone used (see :func:`synth.scores.cones.cone_name`).
    """

    squeeze_per_weight: NDArray[np.float64]
    sampled: NDArray[np.float64]
    worst_direction: NDArray[np.float64]
    directions: int
    cone: str


@lru_cache(maxsize=4)
def _icosphere(level: int) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Vertices (V, 3), triangles (T, 3) and each triangle's plane distance (T,)."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=level)
    V = np.asarray(ico.vertices, float)
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    F = np.asarray(ico.faces, np.int64)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    h = np.abs(np.einsum("ij,ij->i", n, V[F[:, 0]]))
    return V, F, h


def least_squeeze_batch(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    torsion: ArrayLike,
    center_mass: ArrayLike,
    length: float,
    directions: ArrayLike,
    edges: int = 8,
    compiled: bool | None = None,
) -> NDArray[np.float64]:
    """Squeeze per weight of every grasp in every given gravity direction.

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and inward normals.
    mu : float or (k,) float
        Coulomb coefficients.
    torsion : float or (k,) float
        Torsional coefficients of soft contacts (lengths in the points' unit), 0 for point
        contacts.
    center_mass : (3,) float
        The part's centre of mass (moments are taken about it).
    length : float
        The part's characteristic length (moment rows are divided by it; no effect on the
        optimum, only on the LP's scaling).
    directions : (D, 3) float
        Gravity directions (normalised here).
    edges : int
    compiled : bool, optional
        Simplex route (see :func:`synth.scores.simplex.compiled_for`).

    Returns
    -------
    (B, D) float
        Least squeeze divided by the weight; ``inf`` where no squeeze holds.

    Examples
    --------
    >>> P = [[[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]]]; N = [[[-1.0, 0, 0], [1.0, 0, 0]]]
    >>> least_squeeze_batch(P, N, 0.5, 0.01, [0, 0, 0], 1.0, [[0, 0, -1.0]]).round(6).tolist()
    [[1.0]]
    """
    P, N, mu_a, gam, cm, length = _checked(points, normals, mu, torsion, center_mass, length)
    return _least_squeeze(P, N, mu_a, gam, cm, length, _directions(directions), edges,
                          compiled)


def _checked(points: ArrayLike, normals: ArrayLike, mu: ArrayLike, torsion: ArrayLike,
             center_mass: ArrayLike, length: float
             ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                        NDArray[np.float64], NDArray[np.float64], float]:
    """The arguments both public measures here take, checked: contacts (B, k, 3), mu of one,
    k or (B, k) values, torsion (k,), the centre of mass and the length."""
    P, N = check_contacts_batch(points, normals)
    k = P.shape[1]
    mu_a = coefficients_arg(mu, "mu", ((), (1,), (k,), (len(P), k)))
    gam = np.broadcast_to(coefficients_arg(torsion, "torsion", ((), (1,), (k,))), (k,))
    return P, N, mu_a, gam, center_arg(center_mass, name="center_mass"), length_arg(length)


def _least_squeeze(P: NDArray[np.float64], N: NDArray[np.float64], mu: NDArray[np.float64],
                   gam: NDArray[np.float64], center_mass: NDArray[np.float64], length: float,
                   Dn: NDArray[np.float64], edges: int, compiled: bool | None
                   ) -> NDArray[np.float64]:
    """:func:`least_squeeze_batch` of checked arguments and unit directions (D, 3)."""
    B = len(P)
    pairs = np.stack(np.meshgrid(np.arange(B), np.arange(len(Dn)), indexing="ij"),
                     -1).reshape(-1, 2)
    G = _wrenches(P, N, mu, gam, center_mass, length, edges)
    if compiled is None:  # the route for the whole batch, not for each chunk of it
        compiled = compiled_for(len(pairs))
    return _squeeze_pairs(G, P.shape[1], Dn, pairs[:, 0], pairs[:, 1], compiled).reshape(
        B, len(Dn))


def _directions(directions: ArrayLike) -> NDArray[np.float64]:
    Dn = numbers_arg(directions, "directions")
    if Dn.ndim not in (1, 2) or Dn.shape[-1] != 3 or not Dn.size:
        raise InputError(f"directions: expected gravity directions (3,) or (n, 3), got shape "
                         f"{Dn.shape}")
    Dn = Dn.reshape(-1, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        Dn = Dn / np.linalg.norm(Dn, axis=1, keepdims=True)
    if not np.all(np.isfinite(Dn)):
        raise InputError("gravity directions must be finite and nonzero")
    return Dn


def _wrenches(P: NDArray[np.float64], N: NDArray[np.float64], mu: NDArray[np.float64],
              gam: NDArray[np.float64], center_mass: NDArray[np.float64], length: float,
              edges: int) -> NDArray[np.float64]:
    """The grasps' cone generators as wrenches (B, 6, k M), moment rows divided by length
    (the arguments checked by :func:`_checked`)."""
    soft = bool(np.any(gam > 0))
    G = cone_wrenches_batch(P, N, mu, center_mass, edges, gam, soft)
    G[:, 3:] /= length
    return G


def _squeeze_pairs(G: NDArray[np.float64], k: int, Dn: NDArray[np.float64],
                   pb: NDArray[np.int64], pd: NDArray[np.int64], compiled: bool
                   ) -> NDArray[np.float64]:
    """Squeeze per weight of grasp ``pb[i]`` (rows of ``G``) in direction ``Dn[pd[i]]``."""
    kM = G.shape[2]
    M = kM // k
    # columns: lam' (kM) | s | g (k) | artificials (6); rows: 6 wrench rows | k contact rows
    ncol = kM + 1 + k + 6
    hi = np.concatenate([np.full(kM + 1 + k, np.inf), np.zeros(6)])
    c = np.zeros(ncol)
    c[kM] = 1.0
    basis0 = np.concatenate([np.arange(kM + 1 + k, ncol), np.arange(kM + 1, kM + 1 + k)])
    s = np.zeros(len(pb))
    b = np.zeros((min(len(pb), _CHUNK), 6 + k))
    b[:, 6:] = 1.0
    for lo in range(0, len(pb), _CHUNK):
        qb, qd = pb[lo : lo + _CHUNK], pd[lo : lo + _CHUNK]
        A = np.zeros((len(qb), 6 + k, ncol))
        A[:, :6, :kM] = G[qb]
        A[:, :3, kM] = Dn[qd]
        rowmax = np.abs(A[:, :6, : kM + 1]).max(axis=2, keepdims=True)
        A[:, :6, : kM + 1] /= np.where(rowmax > 0, rowmax, 1.0)
        A[:, 6:, :kM] = np.kron(np.eye(k), np.ones((1, M)))
        A[:, 6:, kM + 1 : kM + 1 + k] = np.eye(k)
        A[:, :6, kM + 1 + k :] = np.eye(6)
        sol = solve_batch(A, b[: len(qb)], c, hi, basis0, compiled=compiled)
        s_chunk = sol.x[:, kM]
        for j in np.flatnonzero(sol.status == UNVERIFIED):
            s_chunk[j] = _solve_highs(A[j], kM, k)
        s[lo : lo + len(qb)] = s_chunk
    with np.errstate(divide="ignore"):
        return np.where(s > 1e-12, 1.0 / np.maximum(s, 1e-300), np.inf)


def _solve_highs(A: NDArray[np.float64], kM: int, k: int) -> float:
    """One squeeze LP (rows of ``A`` as built by :func:`least_squeeze_batch`) with HiGHS."""
    n = kM + 1 + k
    cost = np.zeros(n)
    cost[kM] = -1.0
    res = linprog(cost, A_eq=A[:, :n], b_eq=np.concatenate([np.zeros(6), np.ones(k)]),
                  bounds=[(0.0, None)] * n, method="highs")
    if res.status != 0:
        raise SolverError(f"gravity squeeze LP failed: {res.message}")
    return float(res.x[kM])


def gravity_hold_batch(
    points: ArrayLike,
    normals: ArrayLike,
    mu: ArrayLike,
    torsion: ArrayLike,
    center_mass: ArrayLike,
    length: float,
    gravity: ArrayLike | None = None,
    edges: int = 8,
    compiled: bool | None = None,
    level: int = ICOSPHERE_LEVEL,
) -> GravityHold:
    """Least squeeze per weight that holds each grasp in every orientation (or one).

    Parameters
    ----------
    points, normals : (B, k, 3) float
    mu, torsion : float or (k,) float
    center_mass : (3,) float
    length : float
    gravity : (3,) float, optional
        A gravity direction in the part's frame (e.g. ``(0, 0, -1)``); default: every
        orientation (a certified bound from the icosphere's directions, see the module).
    edges : int
    compiled : bool, optional
    level : int
        Icosphere subdivisions for every orientation: 2 (default) evaluates 162 directions
        and bounds within 1.8% of the worst of them, 1 evaluates 42 within 7.1%.

    Returns
    -------
    GravityHold

    Examples
    --------
    >>> P = [[[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]]]; N = [[[-1.0, 0, 0], [1.0, 0, 0]]]
    >>> h = gravity_hold_batch(P, N, 0.5, 0.01, [0, 0, 0], 1.0, gravity=[0, 0, -1])
    >>> round(float(h.squeeze_per_weight[0]), 6)  # 1 / (2 mu)
    1.0
    """
    P, N, mu_a, gam, cm, length = _checked(points, normals, mu, torsion, center_mass, length)
    if isinstance(level, bool) or not isinstance(level, numbers.Integral) \
            or not 0 <= level <= MAX_LEVEL:
        raise InputError(f"level: expected an integer from 0 to {MAX_LEVEL}, got {level!r}")
    name = cone_name(edges, bool(np.any(gam > 0)))
    if gravity is not None:
        g = np.asarray(gravity, dtype=np.float64).reshape(-1)
        if g.shape != (3,) or not np.all(np.isfinite(g)) or not np.any(g != 0):
            raise InputError(f"gravity must be a nonzero finite 3-vector, got {gravity!r}")
        f = _least_squeeze(P, N, mu_a, gam, cm, length, _directions(g[None]), edges,
                           compiled)[:, 0]
        worst = np.broadcast_to(g / np.linalg.norm(g), (len(P), 3)).copy()
        return GravityHold(f, f.copy(), worst, 1, name)
    V, F, h = _icosphere(int(level))
    if not len(P):
        return GravityHold(np.zeros(0), np.zeros(0), np.zeros((0, 3)), len(V), name)
    f = _pruned(P, N, mu_a, gam, cm, length, edges, compiled, int(level))
    worst = f.argmax(axis=1)
    bound = (f / _least_distance(int(level))).max(axis=1)
    return GravityHold(bound, f.max(axis=1), V[worst], len(V), name)


@lru_cache(maxsize=4)
def _least_distance(level: int) -> NDArray[np.float64]:
    """Per icosphere vertex, the least plane distance of its triangles: the bound of the
    module, ``max_t max_{i in t} f_i / h_t``, is ``max_i f_i`` divided by this."""
    V, F, h = _icosphere(level)
    least = np.full(len(V), np.inf)
    for corner in range(3):
        np.minimum.at(least, F[:, corner], h)
    return least


@lru_cache(maxsize=4)
def _levels(level: int) -> list[tuple[int, int, NDArray[np.int64], NDArray[np.int64],
                                      NDArray[np.float64]]]:
    """How the icosphere of ``level`` grows from the icosahedron: per subdivision, the range
    ``lo:hi`` of its new vertices (a subdivision keeps the coarser vertices first), the two
    ends ``a, b`` of the coarser edge each new vertex halves, and ``1 / |v_a + v_b|``."""
    V = _icosphere(level)[0]
    out = []
    for lv in range(1, level + 1):
        Vc, Fc, _ = _icosphere(lv - 1)
        E = np.unique(np.sort(np.concatenate([Fc[:, [0, 1]], Fc[:, [1, 2]], Fc[:, [2, 0]]]),
                              axis=1), axis=0)
        mid = Vc[E[:, 0]] + Vc[E[:, 1]]
        norm = np.linalg.norm(mid, axis=1)
        lo, hi = len(Vc), len(Vc) + len(E)
        near = np.argmax(V[lo:hi] @ (mid / norm[:, None]).T, axis=1)  # the edge each halves
        if not np.allclose(V[lo:hi], mid[near] / norm[near, None], atol=1e-12):
            raise SolverError("icosphere vertices are not the midpoints of the coarser edges")
        out.append((lo, hi, E[near, 0], E[near, 1], 1.0 / norm[near]))
    return out


def _pruned(P: NDArray[np.float64], N: NDArray[np.float64], mu: NDArray[np.float64],
            gam: NDArray[np.float64], center_mass: NDArray[np.float64], length: float, edges: int,
            compiled: bool | None, level: int) -> NDArray[np.float64]:
    """The squeeze per weight (B, V) at the icosphere's vertices wherever it can decide the
    worst value or the bound; elsewhere an upper bound below both (the maximum, its
    direction and the bound are those of evaluating every vertex).

    The icosahedron's 12 vertices are evaluated; each subdivision's new vertex halves an edge
    ``v_a v_b``, so by sublinearity ``f(v) <= (f(v_a) + f(v_b)) / |v_a + v_b|`` (with the ends'
    own bounds where they were skipped), and it is evaluated only where that bound reaches
    the worst value evaluated so far or, divided by the vertex's least plane distance, the
    largest bound (within the relative ``_SKIP_MARGIN``)."""
    V = _icosphere(level)[0]
    levels = _levels(level)
    n0 = levels[0][0] if levels else len(V)
    G = _wrenches(P, N, mu, gam, center_mass, length, edges)
    k, B = P.shape[1], len(P)
    if compiled is None:  # once for the call: at most B x V LPs, typically a third of them
        compiled = compiled_for(B * len(V))
    least = _least_distance(level)
    rows = np.repeat(np.arange(B), n0)
    f = np.full((B, len(V)), -np.inf)  # -inf: not evaluated
    f[:, :n0] = _squeeze_pairs(G, k, V, rows, np.tile(np.arange(n0), B), compiled).reshape(
        B, n0)
    ub = f.copy()
    for lo, hi, a, b, inv in levels:
        worst = f.max(axis=1, keepdims=True)
        top = (f / least).max(axis=1, keepdims=True)
        with np.errstate(invalid="ignore"):
            u = (ub[:, a] + ub[:, b]) * inv
            skip = (u * (1.0 + _SKIP_MARGIN) < worst) & (
                u / least[lo:hi] * (1.0 + _SKIP_MARGIN) < top)
        ub[:, lo:hi] = u
        pb, pd = np.nonzero(~skip)
        if len(pb):
            f[pb, lo + pd] = ub[pb, lo + pd] = _squeeze_pairs(G, k, V, pb, lo + pd, compiled)
    return f
