"""Wrench matrices of point contacts, and their numerical rank.

A frictionless point contact at ``r_i`` with unit inward normal ``n_i`` can only push along
``n_i``; the unit wrench it applies to the part is ``w_i = [n_i; (r_i - o) x n_i]`` with
moments about a reference point ``o``. Stacking the columns gives the normal wrench matrix
``W_n`` of Trinkle (1992), eq. (4) and (6). In the plane the moment is the scalar
``(r_i - o) x n_i`` and ``W_n`` is 3 x n.

The null space of ``W`` (everything the closure tests use) does not depend on ``o`` or on the
length unit: moving ``o`` or rescaling lengths mixes the rows of ``W`` by an invertible matrix.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from synth.errors import CandidateError, InputError
from synth.scores.arguments import center_arg
from synth.tolerances import MOMENT_NOISE_RTOL, NORMAL_NORM_TOL, RANK_RTOL

__all__ = ["wrench_matrix", "check_contacts", "balance_rows", "numerical_rank"]


def check_contacts(
    points: ArrayLike, normals: ArrayLike, *, name: str = "contacts"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validate contact points and normals; return them as float arrays with unit normals.

    Parameters
    ----------
    points : (n, d) float
        Contact positions, ``d`` = 2 (planar) or 3 (spatial).
    normals : (n, d) float
        Inward contact normals (any positive length; they are normalised).
    name : str
        What to call the contact set in error messages (e.g. ``"candidate 3"``).

    Returns
    -------
    points : (n, d) float
    normals : (n, d) float
        Unit length.

    Raises
    ------
    CandidateError
        Wrong shapes, mismatched lengths, NaN or infinite values, or a zero-length normal.
    """
    try:
        P = np.asarray(points, dtype=np.float64)
        N = np.asarray(normals, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise CandidateError(f"{name}: points and normals must be numeric arrays ({e})") from e
    for field, A in (("points", P), ("normals", N)):
        if A.ndim != 2 or A.shape[1] not in (2, 3):
            raise CandidateError(
                f"{name}: field '{field}' must have shape (n, 2) or (n, 3), got {A.shape}"
            )
        if not np.all(np.isfinite(A)):
            bad = int(np.nonzero(~np.all(np.isfinite(A), axis=1))[0][0])
            raise CandidateError(f"{name}: field '{field}' row {bad} is not finite: {A[bad]}")
    if P.shape != N.shape:
        raise CandidateError(
            f"{name}: 'points' has shape {P.shape} but 'normals' has shape {N.shape}"
        )
    if P.shape[0] == 0:
        raise CandidateError(f"{name}: no contacts")
    length = np.linalg.norm(N, axis=1)
    if np.any(length <= NORMAL_NORM_TOL):
        bad = int(np.nonzero(length <= NORMAL_NORM_TOL)[0][0])
        raise CandidateError(f"{name}: field 'normals' row {bad} has zero length")
    return P, N / length[:, None]


def wrench_matrix(
    points: ArrayLike, normals: ArrayLike, center: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Normal wrench matrix ``W_n`` of frictionless point contacts.

    Parameters
    ----------
    points : (n, 3) or (n, 2) float
        Contact positions.
    normals : (n, 3) or (n, 2) float
        Contact normals pointing into the object; normalised here.
    center : (3,) or (2,) float, optional
        Reference point for the moments. Default: the centroid of ``points``.

    Returns
    -------
    W : (6, n) or (3, n) float
        Columns ``[n_i; (r_i - center) x n_i]``.

    Examples
    --------
    >>> W = wrench_matrix([[1, 0, 0], [-1, 0, 0]], [[-1, 0, 0], [1, 0, 0]])
    >>> W.shape
    (6, 2)
    """
    P, N = check_contacts(points, normals)
    d = P.shape[1]
    o = P.mean(axis=0) if center is None else center_arg(center, d)
    R = P - o
    if d == 3:
        return np.vstack([N.T, np.cross(R, N).T])
    return np.vstack([N.T, (R[:, 0] * N[:, 1] - R[:, 1] * N[:, 0])[None, :]])


def balance_rows(W: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Scale the moment rows of wrench matrices to the size of the force rows.

    Force rows are dimensionless, moment rows carry a length, so a relative rank tolerance
    applied to the raw matrix would depend on the unit. The moment block is divided by the
    ratio of its Frobenius norm to the force block's (rotation invariant, unit free). Row
    scaling leaves the null space, and so every closure measure, unchanged. A moment block
    smaller than ``MOMENT_NOISE_RTOL`` times the force block is round-off and is not scaled.

    Parameters
    ----------
    W : (..., m, n) float
        Wrench matrices with m = 6 (3 force rows, 3 moment rows) or m = 3 (2 + 1).

    Returns
    -------
    Ws : (..., m, n) float
        Balanced matrices.
    scale : (..., m) float
        Row factors, ``Ws = scale[..., :, None] * W``.
    """
    W = np.asarray(W, dtype=np.float64)
    m = W.shape[-2]
    nf = {6: 3, 3: 2}.get(m)
    scale = np.ones(W.shape[:-1])
    if nf is None:
        return W, scale
    f = np.sqrt(np.sum(W[..., :nf, :] ** 2, axis=(-2, -1)))
    t = np.sqrt(np.sum(W[..., nf:, :] ** 2, axis=(-2, -1)))
    # a moment block that is round-off next to the force block (contacts on a sphere, whose
    # normals all pass through one point) is left alone rather than blown up to unit size
    real = (f > 0) & (t > MOMENT_NOISE_RTOL * f)
    ratio = np.where(real, f / np.where(real, t, 1.0), 1.0)
    scale[..., nf:] = ratio[..., None]
    return W * scale[..., :, None], scale


def numerical_rank(W: ArrayLike) -> NDArray[np.int64] | int:
    """Rank of (batched) wrench matrices after :func:`balance_rows`.

    A singular value counts when it exceeds ``RANK_RTOL`` times the largest one.

    Parameters
    ----------
    W : (m, n) or (B, m, n) float

    Returns
    -------
    rank : int or (B,) int
    """
    try:
        A = np.asarray(W, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"W: expected a numeric matrix, got {W!r:.80}") from None
    if A.ndim not in (2, 3) or not np.isfinite(A).all():
        raise InputError(f"W: expected a finite (m, n) or (B, m, n) matrix, got shape {A.shape}"
                         + ("" if A.ndim not in (2, 3) else " with NaN or infinite entries"))
    Ws, _ = balance_rows(A)
    s = np.linalg.svd(Ws, compute_uv=False)
    r = np.sum(s > RANK_RTOL * s[..., :1], axis=-1)
    return int(r) if np.ndim(r) == 0 else r.astype(np.int64)
