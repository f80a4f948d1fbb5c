"""Batched full-rank certificates and null vectors from the Gram matrix ``G = W W^T``.

``np.linalg.svd`` calls LAPACK once per matrix, which costs about 10 us for a 6 x n wrench
matrix, more than everything else the batched scorer does. Most wrench matrices a planner
scores are far from rank loss, and for those a cheap certificate settles the rank:

* ``sigma_max^2 <= trace(G)`` and ``sigma_min^2 >= 1 / trace(G^-1)``, so
  ``(sigma_max / sigma_min)^2 <= trace(G) trace(G^-1)``.
* ``G^-1 = L^-T L^-1`` from a Cholesky factor ``L``, vectorised over the batch in numpy
  (an m x m loop, m = 6 or 3), so ``trace(G^-1) = ||L^-1||_F^2``.

When the bound says ``sigma_min / sigma_max >= 1 / sqrt(GRAM_COND2_MAX) = 1e-5``, the matrix has
full row rank with an order of magnitude to spare over ``RANK_RTOL = 1e-6`` (the computed
bound itself is accurate to about ``cond(G) * eps <= 1e-5`` relative, and the SVD's singular
values to ``eps * sigma_max``), so :func:`synth.scores.wrench.numerical_rank` reports full rank
too. Every matrix without the certificate gets the exact SVD rank, so the ranks are identical.

The same factor gives the null vector of a certified m x (m + 1) matrix (nullity one): the
projector ``I - W^T G^-1 W`` has rank one, one of its columns spans the null space, and one step
of iterative refinement brings the round-off of forming ``G`` (``cond(G) * eps``) down to
``eps`` level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from synth.scores.wrench import balance_rows
from synth.tolerances import RANK_RTOL

__all__ = ["GRAM_COND2_MAX", "GramFactors", "gram_factors", "gram_inverse_factor",
           "rank_of_balanced", "null_vector_m1"]

#: Largest certified ``trace(G) trace(G^-1)`` (a bound on ``cond(W)^2``): 1e10 means
#: ``sigma_min / sigma_max >= 1e-5``, above ``RANK_RTOL`` (1e-6) and far below double round-off.
GRAM_COND2_MAX: float = 1e10


def gram_inverse_factor(
    W: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Inverse Cholesky factor of ``G = W W^T`` and the full-rank certificate.

    Parameters
    ----------
    W : (B, m, n) float
        Matrices (wrench matrices after :func:`synth.scores.wrench.balance_rows`).

    Returns
    -------
    X : (B, m, m) float
        ``L^-1`` with ``G = L L^T`` (lower triangular; garbage where not certified), so
        ``G^-1 = X^T X``.
    certified : (B,) bool
        True where ``trace(G) trace(G^-1) <= GRAM_COND2_MAX``: full row rank, for sure.
    """
    B, m, _ = W.shape
    G = np.matmul(W, np.transpose(W, (0, 2, 1)))
    trG = np.trace(G, axis1=1, axis2=2)
    ok = trG > 0
    with np.errstate(all="ignore"):  # uncertified matrices may overflow; they are discarded
        try:  # LAPACK is fast, but one matrix that is not positive definite fails the stack
            L = np.linalg.cholesky(G)
            ok &= (np.diagonal(L, axis1=1, axis2=2) > 0).all(axis=1)
        except np.linalg.LinAlgError:
            L = _cholesky(G, ok)
        X = _tri_inverse(L)
        bound = trG * np.einsum("bij,bij->b", X, X)
    certified = ok & np.isfinite(bound) & (bound <= GRAM_COND2_MAX)
    return X, certified


def _cholesky(G: NDArray[np.float64], ok: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Cholesky factors ``G = L L^T`` (B, m, m), vectorised over the stack; clears ``ok`` where
    a pivot is not positive (that factor is then garbage, but finite or inf, never raising)."""
    B, m, _ = G.shape
    L = np.zeros((B, m, m))
    tiny = np.abs(np.trace(G, axis1=1, axis2=2)) * 1e-300 + 1e-300
    for j in range(m):
        d = G[:, j, j] - np.einsum("bk,bk->b", L[:, j, :j], L[:, j, :j])
        ok &= d > 0
        ljj = np.sqrt(np.maximum(d, tiny))
        L[:, j, j] = ljj
        if j + 1 < m:
            s = G[:, j + 1 :, j] - np.einsum("bik,bk->bi", L[:, j + 1 :, :j], L[:, j, :j])
            L[:, j + 1 :, j] = s / ljj[:, None]
    return L


def _tri_inverse(L: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inverses (B, m, m) of lower-triangular matrices (B, m, m), by forward substitution."""
    m = L.shape[1]
    X = np.zeros_like(L)
    for i in range(m):
        row = -np.einsum("bk,bkj->bj", L[:, i, :i], X[:, :i, :])
        row[:, i] += 1.0
        X[:, i, :] = row / L[:, i, i : i + 1]
    return X


def rank_of_balanced(
    W: NDArray[np.float64], certified: NDArray[np.bool_] | None = None
) -> NDArray[np.int64]:
    """Numerical rank of balanced wrench matrices, identical to ``numerical_rank``.

    Certified matrices (see :func:`gram_inverse_factor`) have rank ``m``; the others get
    ``np.linalg.svd`` with the relative tolerance ``RANK_RTOL``.

    Parameters
    ----------
    W : (B, m, n) float
        Balanced wrench matrices.
    certified : (B,) bool, optional
        A certificate already computed for ``W``.

    Returns
    -------
    rank : (B,) int
    """
    B, m, _ = W.shape
    if certified is None:
        _, certified = gram_inverse_factor(W)
    rank = np.full(B, m, dtype=np.int64)
    rest = np.nonzero(~certified)[0]
    if rest.size:
        S = np.linalg.svd(W[rest], compute_uv=False)
        rank[rest] = np.sum(S > RANK_RTOL * S[:, :1], axis=1)
    return rank


def null_vector_m1(W: NDArray[np.float64], X: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit null vectors of full-rank m x (m + 1) matrices from their Gram inverse factor.

    Parameters
    ----------
    W : (B, m, m + 1) float
        Certified matrices (full row rank, see :func:`gram_inverse_factor`).
    X : (B, m, m) float
        Their ``L^-1``.

    Returns
    -------
    v : (B, m + 1) float
        ``W v = 0``, ``|v| = 1`` (sign arbitrary).
    """
    B, m, n = W.shape
    Y = np.matmul(X, W)  # L^-1 W: rows orthonormal
    P = np.eye(n)[None] - np.matmul(np.transpose(Y, (0, 2, 1)), Y)  # null-space projector
    k = np.argmax(np.diagonal(P, axis1=1, axis2=2), axis=1)
    v = P[np.arange(B), :, k]
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(2):  # refinement: project out the residual's row-space component
        z = np.einsum("bji,bj->bi", X, np.einsum("bij,bj->bi", X, np.einsum("bij,bj->bi", W, v)))
        v -= np.einsum("bij,bi->bj", W, z)
        v /= np.linalg.norm(v, axis=1, keepdims=True)
    return v


@dataclass(frozen=True, eq=False)
class GramFactors:
    """Wrench matrices with their balanced rows, Gram factors and null lines, computed once
    and read by both d* (:func:`synth.scores.batch.form_closure_batch`) and the stiff hand's
    hold (:func:`synth.scores.hold.stiff_hold_batch`) of the same grasps.

    Attributes
    ----------
    wrenches : (B, m, n) float
        The matrices as given.
    balanced : (B, m, n) float
        ``scale[:, :, None] * wrenches`` (:func:`synth.scores.wrench.balance_rows`).
    scale : (B, m) float
    inverse_factor : (B, m, m) float
        :func:`gram_inverse_factor` of ``balanced``.
    certified : (B,) bool
        Full row rank, for sure.
    null : (B, n) float
        Unit null vectors of the certified matrices when ``n == m + 1`` (zeros elsewhere,
        and everywhere for other shapes); the null space of ``balanced`` is that of
        ``wrenches``.
    """

    wrenches: NDArray[np.float64]
    balanced: NDArray[np.float64]
    scale: NDArray[np.float64]
    inverse_factor: NDArray[np.float64]
    certified: NDArray[np.bool_]
    null: NDArray[np.float64]

    def take(self, rows: NDArray[np.bool_] | NDArray[np.int64]) -> GramFactors:
        """The factors of the grasps ``rows`` (a mask or indices)."""
        return GramFactors(self.wrenches[rows], self.balanced[rows], self.scale[rows],
                           self.inverse_factor[rows], self.certified[rows], self.null[rows])


def gram_factors(W: NDArray[np.float64]) -> GramFactors:
    """Balance, factor and (for m x (m + 1) matrices) find the null lines of ``W``.

    Parameters
    ----------
    W : (B, m, n) float
        Finite wrench matrices, m = 6 or 3.

    Returns
    -------
    GramFactors
    """
    W = np.asarray(W, dtype=np.float64)
    B, m, n = W.shape
    Wb, scale = balance_rows(W)
    X, certified = gram_inverse_factor(Wb)
    null = np.zeros((B, n))
    if n == m + 1 and certified.any():
        null[certified] = null_vector_m1(Wb[certified], X[certified])
    return GramFactors(W, Wb, scale, X, certified, null)
