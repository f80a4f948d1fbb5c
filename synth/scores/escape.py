"""Escape twists: the motion a grasp fails to prevent, found and put into words.

For a twist ``t = [v; w]`` of the part (velocity of the moment reference point, angular
velocity), contact ``i`` moves along its inward normal at rate ``w_i . t``. A positive rate
lifts the part off that finger, zero keeps the contact, a negative rate would push the part
into the finger. A twist with ``W^T t >= 0`` and ``t != 0`` is therefore a motion none of the
contacts prevent. By Gordan's alternative such a twist exists exactly when ``W`` has no strictly
positive null vector, and a rank-deficient ``W`` always has one with ``W^T t = 0``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError
from synth.scores.arguments import center_arg, columns_arg
from synth.scores.wrench import balance_rows

__all__ = ["escape_twist", "describe_twist"]

_AXES = ("x", "y", "z")


def escape_twist(
    W: ArrayLike, free: tuple[int, ...] = (), *, rank_deficient: bool
) -> NDArray[np.float64] | None:
    """A unit twist the contacts of ``W`` do not prevent, or None if there is none.

    First an LP looks for a twist that lifts the part off as many contacts as it can
    (maximise ``sum(W^T t)`` subject to ``W^T t >= 0`` on ordinary columns, ``= 0`` on
    ``free`` columns, ``-1 <= t <= 1``); if that finds nothing and ``W`` lacks full row rank,
    a left null vector of ``W`` (a motion that keeps every contact) is returned.

    Parameters
    ----------
    W : (m, n) float
    free : tuple of int
        Columns whose intensity may take either sign (friction), which must stay at rate 0.
    rank_deficient : bool
        Whether ``W`` lacks full row rank.

    Returns
    -------
    t : (m,) float or None
        Unit length in the balanced coordinates of :func:`balance_rows`, expressed back in the
        coordinates of ``W``.
    """
    Wb, scale = balance_rows(W)
    m, n = Wb.shape
    is_free = np.zeros(n, dtype=bool)
    is_free[list(columns_arg(free, n))] = True
    nf = 3 if m == 6 else 2
    # a pure translation is the easiest escape to picture, so look for one first
    t_b = _separating_twist(Wb, is_free, nf)
    if t_b is None:
        t_b = _separating_twist(Wb, is_free, m)
    if t_b is None and rank_deficient:
        t_b = np.linalg.svd(Wb)[0][:, -1]
    if t_b is None:
        return None
    t = scale * t_b
    t = t / np.linalg.norm(t)
    if np.max(np.abs(Wb.T @ (t_b / np.linalg.norm(t_b)))) < 1e-9:
        # both senses are free: report the one whose largest component is positive
        t = t * np.sign(t[np.argmax(np.abs(t))])
    return t


def _separating_twist(
    Wb: NDArray[np.float64], is_free: NDArray[np.bool_], k: int
) -> NDArray[np.float64] | None:
    """Twist in the first ``k`` coordinates maximising ``sum(W^T t)`` with ``W^T t >= 0``."""
    m = Wb.shape[0]
    WT = Wb[:k].T
    res = linprog(
        -WT[~is_free].sum(axis=0),
        A_ub=-WT[~is_free],
        b_ub=np.zeros(int((~is_free).sum())),
        A_eq=WT[is_free] if is_free.any() else None,
        b_eq=np.zeros(int(is_free.sum())) if is_free.any() else None,
        bounds=[(-1.0, 1.0)] * k,
        method="highs",
    )
    if res.status != 0 or -res.fun <= 1e-9 * max(1.0, float(np.abs(WT).max())):
        return None
    t = np.zeros(m)
    t[:k] = res.x
    return t


def _direction(u: NDArray[np.float64], tol_deg: float = 5.0) -> str:
    u = u / np.linalg.norm(u)
    k = int(np.argmax(np.abs(u)))
    if np.degrees(np.arccos(min(1.0, abs(u[k])))) <= tol_deg:
        return ("+" if u[k] > 0 else "-") + _AXES[k]
    return "(" + ", ".join(f"{c:+.2f}" for c in u) + ")"


def _point(p: NDArray[np.float64], length: float | None) -> str:
    if length:
        p = np.where(np.abs(p) < 1e-6 * length, 0.0, p)
    return "(" + ", ".join(f"{c:.3g}" for c in p + 0.0) + ")"


def describe_twist(
    t: ArrayLike,
    center: ArrayLike | None = None,
    *,
    both_senses: bool = False,
    length: float | None = None,
) -> str:
    """Put an escape twist into words, e.g. ``"free to translate along +z"``.

    Parameters
    ----------
    t : (6,) or (3,) float
        Twist ``[v; w]`` (spatial) or ``[vx, vy, w]`` (planar) about the moment reference.
    center : (3,) or (2,) float, optional
        Where the moment reference point is, to place a rotation axis in part coordinates.
    both_senses : bool
        Say ``±`` when the motion is free in both senses (the contacts only stay, none lifts).
    length : float, optional
        The part's size: a screw whose pitch is below 1% of it is called a rotation, and
        coordinates below 1e-6 of it print as 0.

    Returns
    -------
    str
    """
    try:
        t = np.asarray(t, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InputError(f"twist: expected numbers ({e})") from None
    if t.shape not in ((6,), (3,)) or not np.isfinite(t).all():
        raise InputError(f"twist: expected 6 (or, planar, 3) finite numbers, got shape "
                         f"{t.shape}")
    planar = t.shape == (3,)
    d = 2 if planar else 3
    o = np.zeros(d) if center is None else center_arg(center, d)
    v, w = (t[:2], t[2:]) if planar else (t[:3], t[3:])
    nv, nw = np.linalg.norm(v), np.linalg.norm(w)
    sign = "±" if both_senses else ""
    if nw <= 1e-9 * max(float(nv), 1e-300) or nw == 0.0:
        dirn = _direction(np.append(v, 0.0) if planar else v)
        return f"free to translate along {sign}{dirn.lstrip('+-') if sign else dirn}"
    if planar:
        p = o + np.array([-v[1], v[0]]) / w[0]
        turn = "counter-clockwise" if w[0] > 0 else "clockwise"
        if both_senses:
            turn = "either way"
        return f"free to rotate {turn} about the point {_point(p, length)}"
    p = o + np.cross(w, v) / nw**2
    pitch = float(np.dot(w, v) / nw**2)
    axis = _direction(w)
    small = 1e-2 * length if length else 1e-3 * nv / nw
    if abs(pitch) <= small or abs(pitch) * nw < 1e-9:
        return (f"free to rotate about {sign}{axis.lstrip('+-') if sign else axis} "
                f"through {_point(p, length)}")
    return (
        f"free to screw about {sign}{axis.lstrip('+-') if sign else axis} "
        f"through {_point(p, length)}"
        f" (pitch {pitch:.3g} per radian)"
    )
