"""Ascent directions of d* for grasps whose wrench matrix has nullity one.

With m + 1 contacts (7 in space) and full rank the null space of ``W`` is a line, spanned by a
unit vector ``v``, and ``d* = min(v) / max(v)`` (when all entries share a sign). Moving contact
``i`` by ``delta`` along its tangent plane (normal fixed) changes its column by
``dw_i = [0; (delta x n_i) / L]`` and the null vector by ``dv = -W^+ dw_i v_i`` (the component
along ``v`` is zero for a unit vector), so the derivative of every ``v_j`` with respect to the
two tangential coordinates of every contact comes from one pseudo-inverse per grasp.

``d*`` is a ratio of a minimum and a maximum, not smooth where entries tie, and optimal grasps
have many ties. The direction returned ascends a smoothed ratio: soft minimum over soft
maximum with a temperature ``SOFT_TEMPERATURE`` times the mean entry, which weighs every
nearly smallest entry (a plain subgradient would push one of them and drop another).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["SOFT_TEMPERATURE", "tangent_frames", "ascent_directions"]

#: Temperature of the soft minimum and maximum, relative to the mean null-vector entry.
SOFT_TEMPERATURE: float = 0.03


def tangent_frames(normals: NDArray[np.float64]) -> NDArray[np.float64]:
    """Two unit tangents per normal: (..., 2, 3) with ``(t0, t1, n)`` orthonormal."""
    n = normals
    helper = np.where(np.abs(n[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    t0 = np.cross(n, helper)
    t0 /= np.linalg.norm(t0, axis=-1, keepdims=True)
    return np.stack([t0, np.cross(n, t0)], axis=-2)


def ascent_directions(points: NDArray[np.float64], normals: NDArray[np.float64],
                      center: NDArray[np.float64], length: float
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Directions (B, k, 3), in each contact's tangent plane, that raise the smoothed d*.

    Parameters
    ----------
    points, normals : (B, k, 3) float
        Contacts and unit inward normals, k = 7.
    center : (3,) float
        Moment reference.
    length : float
        Moment scale.

    Returns
    -------
    directions : (B, k, 3) float
        Gradient of the smoothed ratio with respect to each contact's position (zero where
        ``W`` is rank deficient); the largest contact move is scaled to 1.
    ratio : (B,) float
        The smoothed ratio itself (a lower bound of min/max).
    """
    P, N = points, normals
    B, k, _ = P.shape
    R = (P - center) / length
    W = np.concatenate([N, np.cross(R, N)], axis=2).transpose(0, 2, 1)  # (B, 6, k)
    _, S, Vt = np.linalg.svd(W)
    v = Vt[:, -1, :]
    v = v * np.sign(v.sum(axis=1, keepdims=True) + (v.sum(axis=1, keepdims=True) == 0))
    full = S[:, -1] > 1e-9 * S[:, 0]
    Wp = np.linalg.pinv(W)  # (B, k, 6)
    T = tangent_frames(N)  # (B, k, 2, 3)
    dtau = np.cross(T, N[:, :, None, :]) / length  # (B, k, 2, 3): moment of each move
    # dv_j / d(contact i, direction a) = -(Wp[:, j, 3:] . dtau[i, a]) v_i
    J = -np.einsum("bjx,biax->bjia", Wp[:, :, 3:], dtau) * v[:, None, :, None]  # (B, k, k, 2)
    tau = SOFT_TEMPERATURE * np.abs(v).mean(axis=1, keepdims=True)
    lo = np.exp(-(v - v.min(axis=1, keepdims=True)) / tau)
    hi = np.exp((v - v.max(axis=1, keepdims=True)) / tau)
    w_lo, w_hi = lo / lo.sum(axis=1, keepdims=True), hi / hi.sum(axis=1, keepdims=True)
    m = v.min(axis=1) - tau[:, 0] * np.log(lo.sum(axis=1))  # soft minimum
    M = v.max(axis=1) + tau[:, 0] * np.log(hi.sum(axis=1))  # soft maximum
    df_dv = (w_lo * M[:, None] - m[:, None] * w_hi) / (M**2)[:, None]
    g = np.einsum("bj,bjia->bia", df_dv, J)  # (B, k, 2)
    dirs = np.einsum("bia,biax->bix", g, T)
    scale = np.linalg.norm(dirs, axis=2).max(axis=1)
    dirs = np.where((full & (scale > 0))[:, None, None],
                    dirs / np.where(scale > 0, scale, 1.0)[:, None, None], 0.0)
    return dirs, m / M
