"""Second opinions beside d*: conditioning of W and the Ferrari-Canny epsilon.

Both need moments in a length unit, so contacts are taken relative to a reference point
(the part's centre of mass) and moments are divided by a characteristic length ``L`` (the
part's bounding-box diagonal); the numbers are then unit free and comparable across parts.

conditioning
    ``sigma_min / sigma_max`` of the scaled 6 x n wrench matrix: 0 for a rank-deficient grasp,
    small for a grasp that barely resists some motion (d* can stay high there; see the
    "traps" in DOMAIN notes), 1 at best.
epsilon
    Ferrari and Canny's (1992) largest-ball measure: the distance from the origin to the
    boundary of the convex hull of the unit contact wrenches (with friction: the unit-force
    wrenches of the cone edges); 0 when the origin is not strictly inside. Computed with qhull
    (facets unmerged, checked, and merged where the check fails).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull, QhullError

from synth.errors import InputError
from synth.scores.arguments import center_arg, length_arg
from synth.scores.cones import check_contacts_batch, cone_wrenches_batch

__all__ = ["scaled_wrenches", "grasp_wrenches", "conditioning", "conditioning_at_least",
           "epsilon_quality"]


def scaled_wrenches(
    points: ArrayLike, normals: ArrayLike, center: ArrayLike, length: float
) -> NDArray[np.float64]:
    """Unit-normal wrenches with moments about ``center`` divided by ``length``.

    Parameters
    ----------
    points, normals : (..., k, 3) float
        Contacts and unit inward normals.
    center : (3,) float
    length : float

    Returns
    -------
    W : (..., 6, k) float
    """
    P = np.asarray(points, dtype=np.float64)
    N = np.asarray(normals, dtype=np.float64)
    N = N / np.sqrt(np.add.reduce(N * N, axis=-1, keepdims=True))  # = np.linalg.norm
    R = P - np.asarray(center, dtype=np.float64)
    # written out (the same operations as np.cross, in place): the scorer's hot path, 3x
    # faster than np.cross and a concatenation on a batch of 1024 grasps, bit for bit equal,
    # and laid out as before ((..., k, 6) in memory) so that products with it round the same
    W = np.empty(N.shape[:-1] + (6,))
    W[..., :3] = N
    (r0, r1, r2), (n0, n1, n2), L = np.moveaxis(R, -1, 0), np.moveaxis(N, -1, 0), float(length)
    W[..., 3] = (r1 * n2 - r2 * n1) / L
    W[..., 4] = (r2 * n0 - r0 * n2) / L
    W[..., 5] = (r0 * n1 - r1 * n0) / L
    return W.swapaxes(-1, -2)


def grasp_wrenches(
    points: ArrayLike,
    normals: ArrayLike,
    center: ArrayLike,
    length: float,
    mu: float = 0.0,
    edges: int = 8,
) -> NDArray[np.float64]:
    """The wrench matrix whose conditioning is reported: contact wrenches without friction,
    cone-edge wrenches with it; moments about ``center`` divided by ``length``.

    Parameters
    ----------
    points, normals : (k, 3) or (B, k, 3) float
    center : (3,) float
    length : float
    mu : float
    edges : int

    Returns
    -------
    W : (6, k) or (6, k * edges), batched as (B, 6, ...) for batched input
    """
    if mu == 0:
        return scaled_wrenches(points, normals, center, length)
    P = np.asarray(points, dtype=np.float64)
    N = np.asarray(normals, dtype=np.float64)
    single = P.ndim == 2
    G = cone_wrenches_batch(P[None] if single else P, N[None] if single else N,
                            mu, np.asarray(center, dtype=np.float64), edges)
    G[:, 3:] /= float(length)
    return G[0] if single else G


def conditioning(W: ArrayLike) -> NDArray[np.float64] | float:
    """``sigma_min / sigma_max`` of (batched) scaled wrench matrices (0 when rank < rows).

    Parameters
    ----------
    W : (6, k) or (B, 6, k) float
        From :func:`scaled_wrenches`.

    Returns
    -------
    float or (B,) float
    """
    try:
        A = np.asarray(W, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InputError(f"W: expected a numeric matrix ({e})") from None
    if A.ndim < 2 or A.shape[-2] not in (3, 6) or not np.isfinite(A).all():
        raise InputError(f"W: expected finite (6, k) or (B, 6, k) wrenches (3 rows planar), "
                         f"got shape {A.shape}")
    s = np.linalg.svd(A, compute_uv=False)
    m = A.shape[-2]
    if A.shape[-1] < m:
        out = np.zeros(A.shape[:-2])
    else:
        out = s[..., m - 1] / np.where(s[..., 0] > 0, s[..., 0], 1.0)
    return float(out) if np.ndim(out) == 0 else out


def conditioning_at_least(W: ArrayLike, threshold: float) -> NDArray[np.bool_]:
    """Which of a batch of matrices have ``sigma_min / sigma_max >= threshold``.

    Cheap for the clear cases: ``(sigma_max / sigma_min)^2 <= trace(G) trace(G^-1)`` with
    ``G = W W^T`` (:func:`synth.scores.gram.gram_inverse_factor`), so a small bound settles a
    matrix without an SVD; only the others get :func:`conditioning`'s exact value.

    Parameters
    ----------
    W : (B, m, k) float
    threshold : float

    Returns
    -------
    (B,) bool
    """
    from synth.scores.gram import gram_inverse_factor

    A = np.asarray(W, dtype=np.float64)
    out = np.zeros(A.shape[0], bool)
    if A.shape[0] == 0 or A.shape[-1] < A.shape[-2]:
        return out
    X, _ = gram_inverse_factor(A)
    with np.errstate(all="ignore"):
        bound = np.einsum("bij,bij->b", A, A) * np.einsum("bij,bij->b", X, X)
    sure = np.isfinite(bound) & (bound > 0) & (bound * threshold**2 <= 1.0 - 1e-9)
    out[sure] = True
    rest = np.flatnonzero(~sure)
    if len(rest):
        out[rest] = np.asarray(conditioning(A[rest])).reshape(-1) >= threshold
    return out


def epsilon_quality(
    points: ArrayLike,
    normals: ArrayLike,
    center: ArrayLike,
    length: float,
    mu: float = 0.0,
    edges: int = 8,
    torsion: float = 0.0,
) -> float:
    """Ferrari-Canny epsilon of one grasp (unit forces, moments scaled by ``length``).

    Parameters
    ----------
    points, normals : (k, 3) float
    center : (3,) float
    length : float
    mu : float
        Friction coefficient (0: the contact wrenches themselves).
    edges : int
        Cone edges with friction.
    torsion : float
        Torsional coefficient of soft contacts (a length, default 0): the hull is then that of
        the soft cones' generators (:mod:`synth.scores.cones`), each scaled to a unit force.

    Returns
    -------
    float
        >= 0; 0 when the origin is not strictly inside the hull.

    Examples
    --------
    >>> P = [[1.0, 0, 0], [-1.0, 0, 0]]; N = [[-1.0, 0, 0], [1.0, 0, 0]]
    >>> epsilon_quality(P, N, [0, 0, 0], 2.0, mu=0.5) == 0.0  # two point contacts: no closure
    True
    """
    try:
        P0, N0 = np.asarray(points, dtype=np.float64), np.asarray(normals, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"points and normals: expected (k, 3) arrays of numbers, got "
                         f"{points!r:.60} and {normals!r:.60}") from None
    P, N = (a[0] for a in check_contacts_batch(P0[None], N0[None]))
    c = center_arg(center)
    length = length_arg(length)
    if not all(isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)
               and x >= 0 for x in (mu, torsion)):
        raise InputError(f"mu and torsion: expected finite numbers >= 0, got {mu!r} and "
                         f"{torsion!r}")
    if not (np.linalg.norm(N, axis=1) > 0).all():
        raise InputError("normals: expected unit inward normals, got one of length 0")
    if mu > 0 or torsion > 0:
        G = cone_wrenches_batch(P[None], N[None], mu, c, edges, torsion)[0]
        G = G / np.linalg.norm(G[:3], axis=0)  # unit force along each generator
        G[3:] /= float(length)
    else:
        G = scaled_wrenches(P, N, c, length)
    equations = _hull_equations(G.T)
    if equations is None:
        return 0.0
    return float(max(0.0, (-equations[:, -1]).min()))


def _hull_equations(W: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Facet planes ``(n, d)`` (unit outward ``n``, ``n . x + d <= 0`` inside) of the convex
    hull of the rows of ``W`` (m, 6); None where qhull finds no full-dimensional hull.

    qhull is run first without merging facets (option ``Q0``: about 3x faster in 6-D than
    its default merging). Unmerged facets can come out flipped where points are nearly
    coplanar; every point is then checked to lie inside every facet (to 1e-9 of the points'
    size), and where one does not, the hull is computed again with qhull's default merging.
    Facets that all support the points give the same least distance as the merged hull."""
    try:
        hull = ConvexHull(W, qhull_options="Q0")
        eq = hull.equations
        scale = float(np.abs(W).max())
        if (W @ eq[:, :-1].T + eq[:, -1]).max() <= 1e-9 * scale:
            return eq
    except (QhullError, ValueError):
        pass
    try:
        return ConvexHull(W).equations
    except (QhullError, ValueError):
        return None
