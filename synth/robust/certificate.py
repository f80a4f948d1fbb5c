"""Certified form closure over contact regions: the null vector as a multi-affine polynomial.

With ``k = m + 1`` frictionless contacts (7 in space, 4 in the plane) the normal wrench matrix
``W`` (``m x k``) has a one-dimensional null space spanned by the signed cofactors
``c_j = (-1)^j det W_{-j}`` (``W`` without column ``j``). The grasp is form closure exactly
when every ``c_j`` is non-zero and all have one sign, and then Trinkle's d* is
``min_j |c_j| / max_j |c_j|``.

A contact that slides on a plane (or along a straight edge) by ``x_i`` in its feature's frame
changes only the moment rows of its column, linearly: ``w_i(x_i) = w_i + D_i x_i``. A
determinant is linear in each column, so every ``c_j`` is a polynomial that is affine in each
``x_i`` separately; and since the changed columns all lie in the 3-dimensional moment subspace
(1-dimensional in the plane), products of more than three (one) of them vanish::

    c_j(x) = c0_j + sum_i g_ji . x_i + sum_{i<l} x_i' B_jil x_l
                  + sum_{i<l<n} T_jiln(x_i, x_l, x_n)

Over a product of convex regions the linear part's minimum is the sum of per-region minima
(exact: at a vertex of each polygon); the higher terms are bounded by the spectral and
Frobenius norms of their coefficients times the regions' radii. This bound is exact to first
order in the regions' size; :func:`certify` tightens it by branch and bound until it proves
every ``c_j`` positive over the regions (form closure for every choice of one point per
region, with a certified lower bound of d*) or finds a choice where one is not (see
``tests/test_robust.py`` for comparisons with an independent search).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from itertools import combinations

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError

__all__ = ["Certificate", "Expansion", "certify", "expand", "minor_scale"]

#: A cofactor (or its bound) counts as non-zero above this fraction of the Hadamard bound of
#: the 6 x 6 minors (:func:`minor_scale`): an absolute scale, so the rounding noise of a
#: rank-deficient matrix (all cofactors zero) never passes for one sign. Determinants are
#: computed to about 1e-15 of that bound; 1e-9 leaves room for the bound's sums.
CERT_RTOL = 1e-9


@dataclass(frozen=True)
class Expansion:
    """The signed cofactors of a ``m x (m + 1)`` wrench matrix as polynomials of the
    contacts' in-feature displacements, oriented so that ``c0.sum() >= 0``.

    Attributes
    ----------
    c0 : (k,) float
        Cofactors at the planned contacts.
    g : (k, k, 2) float
        Linear coefficients: ``g[j, i]`` acts on contact ``i``'s displacement (zero for
        ``i == j``).
    pairs : (P, 2) int
        Contact pairs ``i < l`` of the second-order terms.
    B : (k, P, 2, 2) float
    triples : (Q, 3) int
        Contact triples ``i < l < n`` of the third-order terms.
    T : (k, Q, 2, 2, 2) float
    scale : float
        Hadamard bound of the cofactors (:func:`minor_scale` of the planned ``W``).
    """

    c0: NDArray[np.float64]
    g: NDArray[np.float64]
    pairs: NDArray[np.int64]
    B: NDArray[np.float64]
    triples: NDArray[np.int64]
    T: NDArray[np.float64]
    scale: float

    @cached_property
    def dense(self) -> tuple[NDArray[np.float64], ...]:
        """The expansion as dense tensors (see :func:`_full`), computed once."""
        return _full(self)

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The cofactors at displacements ``x`` ``(..., k, 2)``, shape ``(..., k)``."""
        out = self.c0 + np.einsum("jia,...ia->...j", self.g, x)
        if len(self.pairs):
            xi, xl = x[..., self.pairs[:, 0], :], x[..., self.pairs[:, 1], :]
            out = out + np.einsum("jpab,...pa,...pb->...j", self.B, xi, xl)
        if len(self.triples):
            t = self.triples
            out = out + np.einsum("jqabc,...qa,...qb,...qc->...j", self.T, x[..., t[:, 0], :],
                                  x[..., t[:, 1], :], x[..., t[:, 2], :])
        return out


@lru_cache(maxsize=8)
def _layout(k: int, order: int) -> tuple[NDArray[np.int64], list[tuple[int, int, tuple]]]:
    """Column selections of every determinant the expansion needs.

    Columns ``0..k-1`` of the extended matrix are ``W``'s, ``k + 2 i + a`` is contact ``i``'s
    derivative along its frame axis ``a``. Returns the selections ``(E, k - 1)`` and, per
    row, ``(j, order, (contacts, axes))``.
    """
    rows: list[list[int]] = []
    meta: list[tuple[int, int, tuple]] = []
    for j in range(k):
        cols = [i for i in range(k) if i != j]
        rows.append(cols)
        meta.append((j, 0, ()))
        for o in range(1, order + 1):
            for S in combinations(cols, o):
                for axes in np.ndindex(*(2,) * o):
                    sel = list(cols)
                    for i, a in zip(S, axes, strict=True):
                        sel[cols.index(i)] = k + 2 * i + a
                    rows.append(sel)
                    meta.append((j, o, (S, axes)))
    return np.array(rows, dtype=np.int64), meta


def minor_scale(W: NDArray[np.float64]) -> NDArray[np.float64] | float:
    """Hadamard bound of the ``m x m`` minors of ``m x (m + 1)`` matrices (..., m, m + 1):
    the product of the column norms over the smallest one. No cofactor exceeds it."""
    norms = np.linalg.norm(np.asarray(W, dtype=np.float64), axis=-2)
    return np.prod(norms, axis=-1) / np.maximum(norms.min(axis=-1), 1e-300)


def expand(W: NDArray[np.float64], D: NDArray[np.float64]) -> Expansion:
    """Expand the signed cofactors of ``W`` in the contacts' displacements.

    Parameters
    ----------
    W : (m, m + 1) float
        Wrench matrix of the planned grasp (``m`` = 6 in space, 3 in the plane).
    D : (m + 1, 2, m) float
        ``D[i, a]``: change of contact ``i``'s wrench per unit displacement along its frame
        axis ``a`` (zero for axes the contact cannot move along). Only the moment rows may
        be non-zero.

    Returns
    -------
    Expansion
    """
    try:
        W, D = np.asarray(W, dtype=np.float64), np.asarray(D, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError("expand: W and D must be arrays of numbers") from None
    if W.ndim != 2 or W.shape[1] != W.shape[0] + 1 or D.shape != (W.shape[1], 2, W.shape[0]):
        raise InputError(f"expand: W must be m x (m + 1) and D (m + 1, 2, m); got {W.shape} "
                         f"and {D.shape}")
    if not (np.isfinite(W).all() and np.isfinite(D).all()):
        raise InputError("expand: W and D must be finite (found NaN or inf)")
    m, k = W.shape
    order = 3 if m == 6 else 1
    sel, meta = _layout(k, order)
    ext = np.concatenate([W.T, D.reshape(2 * k, m)])  # rows are columns
    dets = np.linalg.det(ext[sel])
    c0 = np.zeros(k)
    g = np.zeros((k, k, 2))
    pairs = np.array(list(combinations(range(k), 2)), dtype=np.int64) if order >= 2 else \
        np.zeros((0, 2), np.int64)
    triples = np.array(list(combinations(range(k), 3)), dtype=np.int64) if order >= 3 else \
        np.zeros((0, 3), np.int64)
    pidx = {tuple(p): n for n, p in enumerate(pairs.tolist())}
    tidx = {tuple(t): n for n, t in enumerate(triples.tolist())}
    B = np.zeros((k, len(pairs), 2, 2))
    T = np.zeros((k, len(triples), 2, 2, 2))
    for value, (j, o, key) in zip(dets * (-1.0) ** np.array([mm[0] for mm in meta]), meta,
                                  strict=True):
        if o == 0:
            c0[j] = value
        elif o == 1:
            g[j, key[0][0], key[1][0]] = value
        elif o == 2:
            B[(j, pidx[key[0]]) + tuple(key[1])] = value
        else:
            T[(j, tidx[key[0]]) + tuple(key[1])] = value
    s = -1.0 if c0.sum() < 0 else 1.0
    return Expansion(s * c0, s * g, pairs, s * B, triples, s * T, float(minor_scale(W)))


@dataclass(frozen=True)
class Certificate:
    """The outcome of :func:`certify`.

    Attributes
    ----------
    closure : bool or None
        True: every choice of one point per region is form closure (certified). False: a
        choice that is not was found (``counterexample``). None: undecided within the work
        limit (treat as not certified).
    lower, upper : (k,) float
        Certified bounds of every oriented cofactor over the regions.
    d_star_min : float
        Certified lower bound of d* over the regions (0 unless ``closure``).
    counterexample : (k, 2) float or None
        Displacements (frame coordinates) at which some cofactor is not positive.
    boxes : int
        Sub-problems examined.
    """

    closure: bool | None
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    d_star_min: float
    counterexample: NDArray[np.float64] | None
    boxes: int


def _full(e: Expansion) -> tuple[NDArray[np.float64], ...]:
    """The expansion as dense symmetric tensors over the flattened displacement
    ``x = (x_0, ..., x_{k-1})`` (length ``2 k``), one per cofactor: ``c_j(x) = c0_j + g_j . x
    + x' B_j x / 2 + T_j(x, x, x) / 6``. Returns ``g`` (k, 2k), ``B`` (k, 2k, 2k), ``T``
    (k, 2k, 2k, 2k) and the Frobenius norms of ``T``'s contact blocks (k, k, k, k)."""
    k = len(e.c0)
    B = np.zeros((k, k, k, 2, 2))
    for p, (i, m) in enumerate(e.pairs.tolist()):
        B[:, i, m] = e.B[:, p]
        B[:, m, i] = np.swapaxes(e.B[:, p], 1, 2)
    T = np.zeros((k, k, k, k, 2, 2, 2))
    for q, idx in enumerate(e.triples.tolist()):
        for perm in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
            T[(slice(None),) + tuple(idx[p] for p in perm)] = np.transpose(
                e.T[:, q], (0,) + tuple(1 + p for p in perm))
    tn = np.sqrt((T ** 2).sum(axis=(4, 5, 6)))
    Bf = B.transpose(0, 1, 3, 2, 4).reshape(k, 2 * k, 2 * k)
    Tf = T.transpose(0, 1, 4, 2, 5, 3, 6).reshape(k, 2 * k, 2 * k, 2 * k)
    return e.g.reshape(k, 2 * k), Bf, Tf, tn


def _pad(polys: list[NDArray[np.float64]]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Polygons as one ``(k, M, 2)`` array (padded with the first vertex) and their counts."""
    M = max(len(p) for p in polys)
    out = np.empty((len(polys), M, 2))
    for i, p in enumerate(polys):
        out[i, : len(p)] = p
        out[i, len(p):] = p[0]
    return out, np.array([len(p) for p in polys], dtype=np.int64)


def _at(c0: NDArray, g: NDArray, B: NDArray, T: NDArray, x: NDArray) -> tuple[NDArray, ...]:
    """Value (z,), gradient (z, 2k) and Hessian (z, 2k, 2k) of cofactors given per box
    (``c0`` (z,), ``g`` (z, 2k), ``B`` (z, 2k, 2k), ``T`` (z, 2k, 2k, 2k)) at ``x`` (z, 2k)."""
    n = x.shape[1]
    Tx = (T.reshape(len(x), n * n, n) @ x[:, :, None]).reshape(len(x), n, n)
    Bx = (B @ x[:, :, None])[:, :, 0]
    Txx = (Tx @ x[:, :, None])[:, :, 0]
    grad = g + Bx + 0.5 * Txx
    val = c0 + (x * (g + 0.5 * Bx + Txx / 6.0)).sum(axis=1)
    return val, grad, B + Tx


def _spectral2(M: NDArray[np.float64]) -> NDArray[np.float64]:
    """Largest singular value of 2 x 2 matrices (..., 2, 2), in closed form."""
    f2 = (M ** 2).sum(axis=(-2, -1))
    det = M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]
    return np.sqrt(np.maximum(0.5 * (f2 + np.sqrt(np.maximum(f2 * f2 - 4 * det * det, 0))), 0))


def _box_bounds(poly: tuple[NDArray, NDArray, NDArray, NDArray], tn: NDArray,
                V: NDArray[np.float64], member: NDArray[np.bool_]
                ) -> tuple[NDArray[np.float64], ...]:
    """Bounds of each box's cofactor (``poly``: its ``c0, g, B, T`` per box, as :func:`_at`
    takes them; ``tn`` its :func:`_full` block norms) over box ``z``, which lets contact
    ``i`` take the vertices
    ``V[i, member[z, i]]`` (and, the cofactor being affine in each contact, so their convex
    hull). Each box is expanded about the mean of its vertices. Returns lower and upper
    bounds, the linear term's worst vertex of each contact (vertex indices; a real choice),
    and each contact's share of the higher-order error."""
    nb, k = member.shape[:2]
    w = member / member.sum(axis=2, keepdims=True)
    xc = np.einsum("zim,ima->zia", w, V)  # (nb, k, 2)
    val, gc, H = _at(*poly, xc.reshape(nb, 2 * k))
    Y = V[None] - xc[:, :, None]  # (nb, k, M, 2)
    lin = (Y * gc.reshape(nb, k, 1, 2)).sum(axis=3)
    lmin = np.where(member, lin, np.inf)
    worst = lmin.argmin(axis=2)
    lo = val + lmin.min(axis=2).sum(axis=1)
    hi = val + np.where(member, lin, -np.inf).max(axis=2).sum(axis=1)
    R = np.where(member, np.sqrt((Y ** 2).sum(axis=3)), 0.0).max(axis=2)  # (nb, k)
    q = _spectral2(H.reshape(nb, k, 2, k, 2).transpose(0, 1, 3, 2, 4)) * R[:, :, None] \
        * R[:, None, :]  # (nb, k, k), symmetric, zero diagonal
    t3 = ((tn * R[:, None, None, :]).sum(axis=3) * R[:, None, :]).sum(axis=2)  # (nb, k)
    err = 0.5 * q.sum(axis=(1, 2)) + (t3 * R).sum(axis=1) / 6.0
    share = q.sum(axis=2) + 0.5 * t3 * R
    return lo - err, hi + err, worst, share


def certify(e: Expansion, polygons: list[NDArray[np.float64]], *, max_boxes: int = 2000
            ) -> Certificate:
    """Decide whether every choice of one point per region keeps all cofactors positive,
    by branch and bound over the regions' vertices.

    A cofactor is affine in each contact's position, so over a product of convex polygons its
    extremes are at vertex choices: each contact's domain is its polygon's vertex cycle. A
    box gives each contact a run of consecutive vertices and is bounded, over the runs' convex
    hulls, with the expansion recentred in it: the linear part exactly (its worst vertex),
    the rest by the spectral and Frobenius norms of the recentred coefficients times the
    runs' radii. A box that is not certified has the run with the largest share of the error
    cut into two runs that share no vertex (the boxes need only cover every vertex choice). The
    value at each box's worst-vertex choice is a real value, so a non-positive one is a
    counterexample.

    Parameters
    ----------
    e : Expansion
    polygons : list of (v_i, 2) float
        Each contact's convex region in its frame, vertices in order around it, the planned
        point inside (a segment's two ends for a contact with one free axis; one vertex for
        a fixed contact).
    max_boxes : int
        Work limit per cofactor; past it the answer is None (undecided).

    Returns
    -------
    Certificate
    """
    if not isinstance(e, Expansion):
        raise InputError(f"certify: e must come from expand(), got {type(e).__name__}")
    k = len(e.c0)
    if not isinstance(polygons, (list, tuple)) or len(polygons) != k:
        raise InputError(f"certify: polygons: expected a list of {k} regions, got "
                         f"{type(polygons).__name__}")
    for i, given in enumerate(polygons):
        try:
            corners = np.asarray(given, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            corners = np.zeros((0, 0))
        if corners.ndim != 2 or corners.shape[1] != 2 or not len(corners) or not np.isfinite(
                corners).all():
            raise InputError(f"certify: polygons[{i}]: expected (v, 2) finite corners, v >= 1, "
                             f"got shape {corners.shape}")
    tol = CERT_RTOL * e.scale
    lower, upper = np.full(k, np.inf), np.full(k, -np.inf)
    if e.c0.min() <= tol:  # the planned grasp itself (zero displacement) is not closure
        return Certificate(False, e.c0.copy(), e.c0.copy(), 0.0, np.zeros((k, 2)), 0)
    g, B, T, tn = e.dense
    V, count = _pad(polygons)
    M = V.shape[1]
    idx = np.arange(M)
    boxes = 0
    # every cofactor's boxes advance together: box z bounds cofactor jz[z]
    jz = np.arange(k)
    start = np.zeros((k, k), np.int64)
    size = np.repeat(count[None], k, axis=0)
    while len(jz):
        member = ((idx[None, None] - start[:, :, None]) % count[None, :, None]
                  < size[:, :, None]) & (idx[None, None] < count[None, :, None])
        poly = (e.c0[jz], g[jz], B[jz], T[jz])
        lo, hi, worst, share = _box_bounds(poly, tn[jz], V, member)
        boxes += len(jz)
        np.maximum.at(upper, jz, hi)
        pick = V[np.arange(k), worst]  # (nb, k, 2)
        actual = _at(*poly, pick.reshape(len(jz), 2 * k))[0]
        if actual.min() <= tol:
            z = int(actual.argmin())
            return Certificate(False, np.minimum(lower, lo.min()), upper, 0.0, pick[z], boxes)
        bad = np.flatnonzero(lo <= tol)
        if boxes > max_boxes * k and bad.size:
            np.minimum.at(lower, jz, lo)
            return Certificate(None, lower, upper, 0.0, None, boxes)
        good = lo > tol
        np.minimum.at(lower, jz[good], lo[good])
        # cut the run with the largest error share (runs of one vertex are exact)
        sh = np.where(size[bad] > 1, share[bad], -1.0)
        i = sh.argmax(axis=1)
        s0, n0 = start[bad], size[bad]
        r = np.arange(len(bad))
        half = n0[r, i] // 2
        a_start, a_size = s0.copy(), n0.copy()
        a_size[r, i] = half  # the halves split the run's vertices (all a box must cover)
        b_start, b_size = s0.copy(), n0.copy()
        b_start[r, i] = (s0[r, i] + half) % count[i]
        b_size[r, i] = n0[r, i] - half
        jz = np.concatenate([jz[bad], jz[bad]])
        start = np.concatenate([a_start, b_start])
        size = np.concatenate([a_size, b_size])
    d_min = min(float(lower.min() / upper.max()), float(e.c0.min() / e.c0.max()))
    return Certificate(True, lower, upper, d_min, None, boxes)
