"""Trinkle's strong force closure test (1992, Section III, eq. (22)-(24)).

A frictionless grasp has strong force closure (Lakshminarayana's "partial restraint") when it
does not have form closure but some contacts can still be squeezed without bound: ``W`` has a
nonzero null vector with all entries >= 0. Trinkle's LP maximises ``y = 1^T c_null`` over such
vectors in the box ``0 <= c_null <= 1``, with the external wrench balanced by a row-space part.

Which contacts are squeezable is the support of the nonnegative null cone
``K = {c >= 0 : W c = 0}``. The paper solves one LP per contact when the nullity exceeds one.
Because ``K`` is a convex cone, the sum of vectors that make each contact positive is in ``K``
and makes all of them positive at once, so one LP finds the maximal support: maximise
``sum(s)`` subject to ``W c = 0``, ``c >= s``, ``0 <= s <= 1``, ``c >= 0`` (``c`` unbounded
above); at the optimum ``s`` is exactly the indicator of the squeezable contacts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.scores.form import check_wrench, form_closure
from synth.tolerances import D_STAR_TOL

__all__ = ["StrongForceClosure", "strong_force_closure", "squeezable_contacts"]


@dataclass(frozen=True)
class StrongForceClosure:
    """Result of :func:`strong_force_closure`.

    Attributes
    ----------
    y_star : float
        Optimum of eq. (22): the largest ``sum(c_null)`` over nonnegative null vectors in the
        unit box (0 when there is none, or when ``g_ext`` cannot be balanced).
    c_null : (n,) float
        The optimal null-space intensities.
    c_row : (n,) float
        Intensities balancing ``g_ext`` (zeros when no external wrench was given).
    closure : str
        ``"form"``, ``"strong force"`` or ``"force"``.
    squeezable : (n,) bool
        Contacts whose normal intensity can grow without bound.
    balanced : bool
        False when the LP found no ``c_row + c_null >= 0`` balancing ``g_ext``.
    d_star : float
        The form-closure measure of the same ``W``.
    """

    y_star: float
    c_null: NDArray[np.float64] = field(repr=False)
    c_row: NDArray[np.float64] = field(repr=False)
    closure: str
    squeezable: NDArray[np.bool_]
    balanced: bool
    d_star: float


def squeezable_contacts(W: ArrayLike) -> NDArray[np.bool_]:
    """Contacts whose normal intensity can be increased without bound, with a single LP.

    Parameters
    ----------
    W : (m, n) float

    Returns
    -------
    squeezable : (n,) bool
    """
    A = check_wrench(W)
    m, n = A.shape
    # x = [c (n), s (n)]; maximise sum(s)
    cost = np.concatenate([np.zeros(n), -np.ones(n)])
    A_ub = np.hstack([-np.eye(n), np.eye(n)])  # s - c <= 0
    A_eq = np.hstack([A, np.zeros((m, n))])
    res = linprog(
        cost,
        A_ub=A_ub,
        b_ub=np.zeros(n),
        A_eq=A_eq,
        b_eq=np.zeros(m),
        bounds=[(0.0, None)] * n + [(0.0, 1.0)] * n,
        method="highs",
    )
    if res.status != 0:
        raise SolverError(f"squeezable-contact LP failed: {res.message}")
    return np.asarray(res.x[n:] > 0.5)


def strong_force_closure(W: ArrayLike, g_ext: ArrayLike | None = None) -> StrongForceClosure:
    """Trinkle's strong force closure LP, eq. (22)-(24), with the box ``0 <= c_null <= 1``.

    Parameters
    ----------
    W : (m, n) float
        Normal wrench matrix.
    g_ext : (m,) float, optional
        External wrench to balance (default: none).

    Returns
    -------
    StrongForceClosure

    Examples
    --------
    >>> r = strong_force_closure([[0, -1, -1, 1], [1, 0, 0, 0], [0, -1, 1, 0.4]])
    >>> r.closure, round(r.y_star, 6), r.squeezable.tolist()
    ('strong force', 2.0, [False, True, True, True])
    """
    A = check_wrench(W)
    m, n = A.shape
    g = np.zeros(m) if g_ext is None else np.asarray(g_ext, dtype=np.float64)
    if g.shape != (m,) or not np.all(np.isfinite(g)):
        raise InputError(f"g_ext must be a finite ({m},) vector, got shape {g.shape}")
    # x = [c_null (n), c_row (n)]; maximise 1^T c_null
    cost = np.concatenate([-np.ones(n), np.zeros(n)])
    A_eq = np.block([[A, np.zeros((m, n))], [np.zeros((m, n)), A]])
    b_eq = np.concatenate([np.zeros(m), -g])
    A_ub = np.hstack([-np.eye(n), -np.eye(n)])  # c_row + c_null >= 0
    res = linprog(
        cost,
        A_ub=A_ub,
        b_ub=np.zeros(n),
        A_eq=A_eq,
        b_eq=b_eq,
        bounds=[(0.0, 1.0)] * n + [(None, None)] * n,
        method="highs",
    )
    fc = form_closure(A)
    squeeze = squeezable_contacts(A)
    if res.status == 2:  # infeasible: g_ext cannot be balanced by pushing contacts
        return StrongForceClosure(
            y_star=0.0,
            c_null=np.zeros(n),
            c_row=np.zeros(n),
            closure="form" if fc.is_form_closure else "force",
            squeezable=squeeze,
            balanced=False,
            d_star=fc.d_star,
        )
    if res.status != 0:
        raise SolverError(f"strong-force-closure LP failed: {res.message}")
    y = float(-res.fun)
    y_star = y if y > D_STAR_TOL else 0.0
    if fc.is_form_closure:
        closure = "form"
    elif y_star > 0.0:
        closure = "strong force"
    else:
        closure = "force"
    return StrongForceClosure(
        y_star=y_star,
        c_null=np.asarray(res.x[:n]),
        c_row=np.asarray(res.x[n:]),
        closure=closure,
        squeezable=squeeze,
        balanced=True,
        d_star=fc.d_star,
    )
