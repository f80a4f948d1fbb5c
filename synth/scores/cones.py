"""Linearised contact cones: the wrenches that span each contact's possible forces.

A contact pushes along its inward normal ``n`` with a normal intensity ``f_n >= 0``. A point
contact with Coulomb friction adds a tangential force ``f_t`` with ``|f_t| <= mu f_n``; a
*soft* contact (a pad pressed on a face) also resists a moment ``tau`` about its normal. synth
uses MuJoCo's soft contact (``condim = 4``), where force and torsion share one cone

    f_n^2 >= |f_t|^2 / mu^2 + tau^2 / gamma^2,

with the torsional coefficient ``gamma`` a length (MuJoCo's third friction parameter). Both
cones are replaced by inscribed polyhedral cones, so every force the linear programs use lies
in the true cone and a "holds" is never optimistic:

* a point contact (``gamma = 0``) by the pyramid of ``edges`` generators
  ``n + mu (cos a_j u + sin a_j v)``, ``a_j = 2 pi j / edges``;
* a soft contact by the generators ``(f, tau) = (n + mu cos(p) (cos a_j u + sin a_j v),
  gamma sin(p))`` on the unit sphere of ``(f_t / mu, tau / gamma)`` at the latitudes
  ``p = 0, +-45`` degrees (``edges`` longitudes each) and the two poles ``p = +-90`` degrees:
  ``3 edges + 2`` generators, all on the elliptic cone's boundary, so their hull lies inside
  it (MuJoCo's own ``cone="pyramidal"`` for condim 4, whose 6 edges are ``n +- mu u``,
  ``n +- mu v`` and ``(n, +-gamma)``, is a subset of it). With 8 edges every direction of
  ``(f_t / mu, tau / gamma)`` reaches at least 0.86 of the ellipsoid (0.924 within the force
  plane, as the point contact's pyramid).

Every generator has unit normal intensity, so a force ``sum_j lam_j g_j`` (``lam >= 0``) has
normal intensity ``sum_j lam_j``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from synth.errors import InputError
from synth.scores.arguments import edges_arg, numbers_arg

__all__ = [
    "SOFT_LATITUDES",
    "check_contacts_batch",
    "cone_directions",
    "cone_name",
    "cone_wrenches_batch",
    "generators_per_contact",
    "tangent_basis",
]

#: Latitudes (radians) of the soft contact's rings of generators, besides its two poles.
SOFT_LATITUDES: tuple[float, ...] = (0.0, np.pi / 4, -np.pi / 4)


def tangent_basis(normals: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit tangents ``u, v`` per normal with ``(u, v, n)`` orthonormal.

    Parameters
    ----------
    normals : (n, 3) float
        Unit normals.

    Returns
    -------
    u, v : (n, 3) float

    Examples
    --------
    >>> u, v = tangent_basis(np.array([[1.0, 0.0, 0.0]]))
    >>> (u + 0.0).tolist(), v.tolist()
    ([[0.0, 0.0, 1.0]], [[0.0, -1.0, 0.0]])
    """
    N = np.asarray(normals, dtype=np.float64)
    x, y, z = N.T
    # u = N x e_x where |N_x| < 0.9, else N x e_y (written out: np.cross costs several times more)
    near_x = np.abs(x) >= 0.9
    u = np.stack([np.where(near_x, -z, 0.0), np.where(near_x, 0.0, z),
                  np.where(near_x, x, -y)], axis=1)
    u /= np.sqrt(np.einsum("ij,ij->i", u, u))[:, None]
    return u, np.cross(N, u)


def generators_per_contact(edges: int, soft: bool) -> int:
    """Generators of one contact's cone: ``edges``, or ``3 edges + 2`` for a soft contact."""
    return 3 * int(edges) + 2 if soft else int(edges)


def cone_name(edges: int, soft: bool) -> str:
    """How the JSON and tables name the linearised cone, e.g. ``"pyramid-8"``."""
    return f"soft-{int(edges)}x3+2" if soft else f"pyramid-{int(edges)}"


def cone_directions(edges: int, soft: bool) -> NDArray[np.float64]:
    """Generator directions on the unit sphere of ``(f_t / mu, tau / gamma)``.

    Parameters
    ----------
    edges : int
        Longitudes per ring (>= 3).
    soft : bool
        With torsion (three rings and two poles) or without (one ring, torsion 0).

    Returns
    -------
    (M, 3) float
        Columns: the ``u`` and ``v`` tangential parts and the torsional part; ``M`` is
        :func:`generators_per_contact`.
    """
    a = 2.0 * np.pi * np.arange(int(edges)) / int(edges)
    lats = SOFT_LATITUDES if soft else (0.0,)
    rings = [np.stack([np.cos(p) * np.cos(a), np.cos(p) * np.sin(a),
                       np.full(len(a), np.sin(p))], axis=1) for p in lats]
    if soft:
        rings.append(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]))
    return np.concatenate(rings, axis=0)


def check_contacts_batch(points: ArrayLike, normals: ArrayLike
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The contacts of B grasps of k contacts each as float arrays, checked.

    Parameters
    ----------
    points, normals : (B, k, 3) float

    Returns
    -------
    points, normals : (B, k, 3) float

    Raises
    ------
    InputError
        The shapes differ or are not (B, k, 3), or a value is not finite.
    """
    P = numbers_arg(points, "points")
    N = numbers_arg(normals, "normals")
    if P.ndim != 3 or P.shape[2] != 3 or N.shape != P.shape:
        raise InputError(f"points and normals must both have shape (B, k, 3), got {P.shape} "
                         f"and {N.shape}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(N))):
        raise InputError("points and normals must be finite")
    return P, N


def cone_wrenches_batch(
    points: NDArray[np.float64],
    normals: NDArray[np.float64],
    mu: ArrayLike,
    center: ArrayLike,
    edges: int,
    torsion: ArrayLike = 0.0,
    soft: bool | None = None,
) -> NDArray[np.float64]:
    """Generator wrenches of every contact's linearised cone, for a batch of spatial grasps.

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and inward normals (normalised here).
    mu : float, (k,) or (B, k) float
        Coulomb coefficients, >= 0.
    center : (3,) or (B, 3) float
        Moment reference.
    edges : int
        Longitudes per ring (>= 3).
    torsion : float, (k,) or (B, k) float
        Torsional coefficients ``gamma`` (lengths, in the points' unit), >= 0. When every one
        is 0 the contacts are point contacts (``edges`` generators each), else every contact
        gets the soft cone's ``3 edges + 2`` generators (a contact with ``gamma = 0`` then
        has repeated ones).
    soft : bool, optional
        Use the soft cone's generators (default: when some torsion is > 0); a batch split
        into chunks passes the whole batch's choice.

    Returns
    -------
    G : (B, 6, k * M) float
        Column ``i * M + j`` is generator ``j`` of contact ``i`` (unit normal intensity);
        rows are force, then moment about ``center``.

    Examples
    --------
    >>> P = np.array([[[1.0, 0, 0], [-1.0, 0, 0]]]); N = -P
    >>> cone_wrenches_batch(P, N, 0.5, np.zeros(3), 8, torsion=0.1).shape
    (1, 6, 52)
    """
    B, k, _ = points.shape
    edges = edges_arg(edges)
    gam = np.broadcast_to(np.asarray(torsion, dtype=np.float64), (B, k)) if np.ndim(torsion) < 2 \
        else np.asarray(torsion, dtype=np.float64)
    soft = bool(np.any(gam > 0)) if soft is None else bool(soft)
    N = normals / np.linalg.norm(normals, axis=2, keepdims=True)
    u, v = tangent_basis(N.reshape(-1, 3))
    mu_b = np.broadcast_to(np.asarray(mu, dtype=np.float64), (B, k))[..., None]
    Mu, Mv = mu_b * u.reshape(B, k, 3), mu_b * v.reshape(B, k, 3)
    R = points - np.asarray(center, dtype=np.float64).reshape(-1, 1, 3)
    # generator j of contact i is linear in (n, mu u, mu v, gamma n as a pure moment):
    # basis[:, row, i] holds those wrenches, and one matmul spreads them to the generators
    basis = np.zeros((B, 6, k, 4 if soft else 3))
    for col, F in enumerate((N, Mu, Mv)):
        basis[:, :3, :, col] = F.transpose(0, 2, 1)
        basis[:, 3:, :, col] = np.cross(R, F).transpose(0, 2, 1)
    if soft:
        basis[:, 3:, :, 3] = (gam[..., None] * N).transpose(0, 2, 1)
    D = cone_directions(int(edges), soft)
    coef = np.vstack([np.ones(len(D)), D.T[: 3 if soft else 2]])
    G = basis.reshape(-1, coef.shape[0]) @ coef  # one GEMM
    return G.reshape(B, 6, k * len(D))
