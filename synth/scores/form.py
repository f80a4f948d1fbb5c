"""Trinkle's quantitative form-closure test (1992, eq. (9) and (12)-(15)).

d* is the largest ``d`` such that some null vector ``c`` of ``W`` (``W c = 0``) has every
ordinary entry at least ``d``, within the box ``-1 <= c <= 1``. This is the box of
Trinkle's Example 1 (a cube of edge 2 centred on the origin), so our d* values are directly
comparable with the paper's tables. A grasp has form closure when d* > 0 and ``W`` has full
row rank (Somoff's necessary condition; a rank-deficient ``W`` can have a positive null vector,
for example a planar contact set in space, and still let the part move).

Columns listed in ``free`` are intensities that may take either sign (the tangential columns of
frictional contacts in Trinkle's Example 2, eq. (18)-(21)); they keep the box but are left out of
the ``c_i >= d`` rows.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.scores.arguments import columns_arg
from synth.scores.escape import describe_twist, escape_twist
from synth.scores.wrench import numerical_rank
from synth.tolerances import D_STAR_TOL

__all__ = ["FormClosure", "form_closure", "check_wrench", "check_free"]


@dataclass(frozen=True)
class FormClosure:
    """Result of :func:`form_closure`.

    Attributes
    ----------
    d_star : float
        Trinkle's measure, >= 0 (0 when it does not exceed ``D_STAR_TOL``).
    closure : str
        ``"form"`` (d* > 0 and full row rank) or ``"force"`` (the paper's word for every other
        grasp: equilibrium depends on the external wrench).
    c_null : (n,) float
        The optimal null-space intensities (``W @ c_null`` ~ 0).
    rank : int
        Numerical rank of ``W`` (moment rows balanced, relative tolerance ``RANK_RTOL``).
    m : int
        Rows of ``W``: 6 in space, 3 in the plane.
    escape : (m,) float or None
        For a grasp without form closure, a unit twist ``t`` with ``W^T t >= 0`` (no contact
        resists it); None for form closure.
    escape_words : str or None
        ``escape`` described in words, e.g. ``"free to translate along +z"``.
    free : tuple of int
        The columns treated as free.
    solve_time : float
        Seconds spent in the LP.
    """

    d_star: float
    closure: str
    c_null: NDArray[np.float64] = field(repr=False)
    rank: int
    m: int
    escape: NDArray[np.float64] | None = field(repr=False)
    escape_words: str | None
    free: tuple[int, ...] = ()
    solve_time: float = field(default=0.0, repr=False)

    @property
    def is_form_closure(self) -> bool:
        """True for form closure."""
        return self.closure == "form"

    @property
    def full_rank(self) -> bool:
        """True when ``W`` has full row rank."""
        return self.rank == self.m


def check_wrench(W: ArrayLike, *, name: str = "W") -> NDArray[np.float64]:
    """Validate a wrench matrix (2-D, finite, 3 or 6 rows) and return it as floats."""
    try:
        A = np.asarray(W, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InputError(f"{name} must be a numeric matrix ({e})") from e
    if A.ndim != 2 or A.shape[0] not in (3, 6) or A.shape[1] < 1:
        raise InputError(f"{name} must have shape (6, n) or (3, n) with n >= 1, got {A.shape}")
    if not np.all(np.isfinite(A)):
        raise InputError(f"{name} has NaN or infinite entries")
    return A


def check_free(free: tuple[int, ...] | list[int], n: int) -> tuple[int, ...]:
    """Validate a list of free column indices against ``n`` columns."""
    out = columns_arg(free, n)
    if len(out) == n:
        raise InputError("at least one column must be a normal (non-free) intensity")
    return out


def form_closure(W: ArrayLike, free: tuple[int, ...] | list[int] = ()) -> FormClosure:
    """Trinkle's form-closure LP for one wrench matrix, solved with HiGHS.

    Maximise ``d`` subject to ``W c = 0``, ``c_i >= d`` for ordinary columns, ``d >= 0`` and
    ``-1 <= c <= 1``.

    Parameters
    ----------
    W : (m, n) float
        Wrench matrix, m = 6 (space) or 3 (plane); see :func:`synth.wrench_matrix`.
    free : sequence of int
        Columns whose intensity may take either sign.

    Returns
    -------
    FormClosure

    Examples
    --------
    >>> import numpy as np
    >>> a = 1.2  # Trinkle's Example 1, l = 1
    >>> W = [[0, 0, 1, -np.cos(a)], [1, 1, 0, -np.sin(a)], [-1, 0, 7 / 4, 0]]
    >>> r = form_closure(W)
    >>> r.closure, round(r.d_star, 4)
    ('form', 0.2978)
    """
    A = check_wrench(W)
    m, n = A.shape
    fr = check_free(free, n)
    ordinary = np.setdiff1d(np.arange(n), fr)
    t0 = time.perf_counter()
    # variables x = [c (n), d]; minimise -d
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    # HiGHS's tolerances are absolute: a matrix of entries far from 1 (a wrench in other
    # units, 1e-10 or 1e10) is scaled by a power of two (exactly), which leaves W c = 0 and
    # so d* as they are; one of entries near 1 (every wrench synth builds) is left as given
    top = float(np.abs(A).max())
    scale = 2.0 ** -round(math.log2(top)) if top > 0 and not 2**-10 <= top <= 2**10 else 1.0
    A = A * scale if scale != 1.0 else A  # (the rank and the escape twist do not depend on it)
    A_eq = np.hstack([A, np.zeros((m, 1))])
    A_ub = np.zeros((ordinary.size, n + 1))
    A_ub[np.arange(ordinary.size), ordinary] = -1.0
    A_ub[:, -1] = 1.0
    res = linprog(
        cost,
        A_ub=A_ub,
        b_ub=np.zeros(ordinary.size),
        A_eq=A_eq,
        b_eq=np.zeros(m),
        bounds=[(-1.0, 1.0)] * n + [(0.0, None)],
        method="highs",
    )
    solve_time = time.perf_counter() - t0
    if res.status != 0:
        raise SolverError(f"form-closure LP failed: {res.message}")
    d = float(res.x[-1])
    d_star = d if d > D_STAR_TOL else 0.0
    c_null = np.asarray(res.x[:n], dtype=np.float64)
    rank = int(numerical_rank(A))
    closure = "form" if (d_star > 0.0 and rank == m) else "force"
    esc: NDArray[np.float64] | None = None
    words: str | None = None
    if closure != "form":
        esc = escape_twist(A, fr, rank_deficient=rank < m)
        if esc is not None:
            both = bool(np.max(np.abs(A.T @ esc)) <= 1e-9 * np.abs(A).max())
            words = describe_twist(esc, both_senses=both)
    return FormClosure(
        d_star=d_star,
        closure=closure,
        c_null=c_null,
        rank=rank,
        m=m,
        escape=esc,
        escape_words=words,
        free=fr,
        solve_time=solve_time,
    )
