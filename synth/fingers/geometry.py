"""Vectorised geometry for fingers: approach directions in a cone, point and segment distances."""

from __future__ import annotations

import numpy as np

__all__ = [
    "APPROACH_AZIMUTHS",
    "APPROACH_RINGS",
    "approach_directions",
    "point_segment_distance",
    "segment_segment_distance",
    "rotations_to",
    "quaternions_to",
]

#: Number of directions tried on each ring of the approach cone.
APPROACH_AZIMUTHS: int = 6
#: Number of rings (tilts cone * i / APPROACH_RINGS, i = 1..APPROACH_RINGS) tried after the axis.
APPROACH_RINGS: int = 2


def _perpendicular_frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (N, 3) completing each unit ``axis`` (N, 3) to an orthonormal frame."""
    pick = np.argmin(np.abs(axis), axis=1)
    e = np.zeros_like(axis)
    e[np.arange(len(axis)), pick] = 1.0
    u = np.cross(axis, e)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(axis, u)
    return u, v


def approach_directions(
    outward: np.ndarray,
    cone: float,
    azimuths: int = APPROACH_AZIMUTHS,
    rings: int = APPROACH_RINGS,
) -> np.ndarray:
    """Deterministic approach directions in a cone, least tilted first.

    Parameters
    ----------
    outward : (N, 3) float
        Unit cone axes (the outward normals, ``-normal``).
    cone : float
        Half-angle in radians. 0 gives the axis only.
    azimuths, rings : int
        Directions per ring and number of rings.

    Returns
    -------
    (N, m, 3) float
        Unit directions; ``[:, 0]`` is the axis, then ``rings`` rings of ``azimuths`` directions
        at tilts ``cone * i / rings``. ``m = 1`` when ``cone == 0``.

    Examples
    --------
    >>> approach_directions(np.array([[0.0, 0.0, 1.0]]), 0.0).shape
    (1, 1, 3)
    """
    if cone <= 0.0:
        return outward[:, None, :].copy()
    u, v = _perpendicular_frame(outward)
    tilts = cone * np.arange(1, rings + 1) / rings
    phis = 2.0 * np.pi * np.arange(azimuths) / azimuths
    tilt, phi = (g.ravel() for g in np.meshgrid(tilts, phis, indexing="ij"))
    ring = (
        np.cos(tilt)[None, :, None] * outward[:, None, :]
        + (np.sin(tilt) * np.cos(phi))[None, :, None] * u[:, None, :]
        + (np.sin(tilt) * np.sin(phi))[None, :, None] * v[:, None, :]
    )
    return np.concatenate([outward[:, None, :], ring], axis=1)


def rotations_to(axis: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) whose third column is the unit ``axis`` (N, 3)."""
    u, v = _perpendicular_frame(axis)
    return np.stack([u, v, axis], axis=-1)


def quaternions_to(axis: np.ndarray) -> np.ndarray:
    """Unit quaternions (N, 4), order (w, x, y, z), turning +z onto the unit ``axis`` (N, 3).

    The shortest-arc rotation ``(1 + a_z, -a_y, a_x, 0)`` normalised; a half turn about x
    when ``axis`` is (nearly) -z.
    """
    q = np.stack(
        [1.0 + axis[:, 2], -axis[:, 1], axis[:, 0], np.zeros(len(axis))], axis=1
    )
    norm = np.linalg.norm(q, axis=1, keepdims=True)
    flip = norm[:, 0] < 1e-6
    q = q / np.where(flip[:, None], 1.0, norm)
    q[flip] = (0.0, 1.0, 0.0, 0.0)
    return q


def point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance (...,) from points ``p`` (..., 3) to segments ``[a, b]`` (..., 3)."""
    d = b - a
    dd = np.einsum("...x,...x->...", d, d)
    t = np.einsum("...x,...x->...", p - a, d) / np.where(dd > 0, dd, 1.0)
    t = np.clip(np.where(dd > 0, t, 0.0), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * d), axis=-1)


def segment_segment_distance(
    p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray
) -> np.ndarray:
    """Distance (...,) between segments ``[p1, q1]`` and ``[p2, q2]`` (all (..., 3)).

    Ericson, Real-Time Collision Detection, 5.1.9, vectorised; degenerate segments (points)
    are handled.
    """
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...x,...x->...", d1, d1)
    e = np.einsum("...x,...x->...", d2, d2)
    f = np.einsum("...x,...x->...", d2, r)
    c = np.einsum("...x,...x->...", d1, r)
    b = np.einsum("...x,...x->...", d1, d2)
    eps = 1e-300
    a_ok, e_ok = a > eps, e > eps
    denom = a * e - b * b
    general = denom > 1e-12 * np.maximum(a * e, eps)
    s = np.where(general, (b * f - c * e) / np.where(denom > 0, denom, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    t = (b * s + f) / np.where(e_ok, e, 1.0)
    # Re-clamp t, recompute s.
    t_lo, t_hi = t < 0.0, t > 1.0
    t = np.clip(t, 0.0, 1.0)
    s = np.where(t_lo, np.clip(-c / np.where(a_ok, a, 1.0), 0.0, 1.0), s)
    s = np.where(t_hi, np.clip((b - c) / np.where(a_ok, a, 1.0), 0.0, 1.0), s)
    # Degenerate cases.
    s = np.where(a_ok, s, 0.0)
    t = np.where(e_ok, np.where(a_ok, t, np.clip(f / np.where(e_ok, e, 1.0), 0.0, 1.0)), 0.0)
    s = np.where(a_ok & ~e_ok, np.clip(-c / np.where(a_ok, a, 1.0), 0.0, 1.0), s)
    c1 = p1 + s[..., None] * d1
    c2 = p2 + t[..., None] * d2
    return np.linalg.norm(c1 - c2, axis=-1)
