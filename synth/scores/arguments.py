"""Arguments every public measure takes (a moment centre, cone edges, a length), checked once
and named in the error: text, None, NaN or a wrong shape get an :class:`InputError` that
says what was expected, not numpy's conversion error or a NaN result."""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError
from synth.limits import MAX_EDGES, MIN_EDGES

__all__ = ["center_arg", "coefficients_arg", "columns_arg", "edges_arg", "length_arg",
           "numbers_arg"]


def center_arg(value: Any, d: int = 3, name: str = "center") -> NDArray[np.float64]:
    """``value`` as a finite (d,) point.

    Raises
    ------
    InputError
        Not numbers, another shape, NaN or infinite.
    """
    try:
        c = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        c = None
    if value is None or c is None or c.shape != (d,) or not np.isfinite(c).all():
        raise InputError(f"{name}: expected {d} finite numbers, got {value!r}")
    return c


def numbers_arg(value: Any, name: str) -> NDArray[np.float64]:
    """``value`` (a number or an array of them, such as friction coefficients) as floats.

    Raises
    ------
    InputError
        None, text or objects that are not numbers.
    """
    try:
        if value is None:
            raise TypeError
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name}: expected a number or an array of numbers, got "
                         f"{value!r:.80}") from None


def coefficients_arg(value: Any, name: str, shapes: tuple[tuple[int, ...], ...]
                     ) -> NDArray[np.float64]:
    """Friction or torsion coefficients: finite numbers >= 0 of one of ``shapes``."""
    a = numbers_arg(value, name)
    if a.shape not in shapes or not (np.isfinite(a).all() and (a >= 0).all()):
        raise InputError(f"{name}: expected finite numbers >= 0 of shape "
                         f"{' or '.join(map(str, shapes))}, got {value!r:.80}")
    return a


def columns_arg(value: Any, n: int, name: str = "free") -> tuple[int, ...]:
    """Column indices of an (m, n) matrix, any iterable of whole numbers from 0 to n - 1, as
    a sorted tuple without repeats."""
    items = None if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__") \
        else list(value)
    if items is None or not all(isinstance(i, numbers.Real) and not isinstance(i, bool)
                                and float(i).is_integer() for i in items):
        raise InputError(f"{name}: expected a list of column indices, got {value!r:.80}")
    out = tuple(sorted({int(i) for i in items}))
    if out and (out[0] < 0 or out[-1] >= n):
        raise InputError(f"{name}: expected column indices from 0 to {n - 1}, got {items}")
    return out


def edges_arg(value: Any) -> int:
    """The number of edges of a linearised friction cone, an integer in
    ``MIN_EDGES..MAX_EDGES``."""
    x = float(value) if isinstance(value, numbers.Real) and not isinstance(value, bool) \
        else math.nan
    if not (x.is_integer() and MIN_EDGES <= x <= MAX_EDGES):
        raise InputError(f"edges must be an integer from {MIN_EDGES} to {MAX_EDGES}, got "
                         f"{value!r}")
    return int(x)


def length_arg(value: Any, name: str = "length") -> float:
    """A positive finite length (a moment scale)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (
            math.isfinite(float(value)) and float(value) > 0):
        raise InputError(f"{name}: expected a positive finite number, got {value!r}")
    return float(value)
