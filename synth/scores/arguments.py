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

__all__ = ["center_arg", "edges_arg", "length_arg", "numbers_arg"]


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
