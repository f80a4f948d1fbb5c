"""Point and direction arrays given to a part's queries, checked once at the door."""

from __future__ import annotations

from typing import Any

import numpy as np

from synth.errors import InputError

__all__ = ["xyz_rows"]


def xyz_rows(value: Any, name: str, rows: int | None = None) -> np.ndarray:
    """``value`` as a finite (n, 3) float array (a single (3,) vector is one row).

    Parameters
    ----------
    value : array_like
    name : str
        What the caller calls it, for the message (``"points"``, ``"directions"``).
    rows : int, optional
        The number of rows it must have (that of the array it goes with).

    Returns
    -------
    (n, 3) float

    Raises
    ------
    InputError
        Not numbers, not of shape (n, 3) or (3,), another number of rows than ``rows``, or
        NaN or infinite entries (the first such row is named).
    """
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as e:
        raise InputError(f"{name}: expected an (n, 3) array of numbers, got "
                         f"{type(value).__name__} ({e})") from None
    if a.shape == (3,):
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"{name}: expected shape (n, 3), got {a.shape}")
    if rows is not None and len(a) != rows:
        raise InputError(f"{name}: expected {rows} rows (one per point), got {len(a)}")
    finite = np.isfinite(a).all(axis=1)
    if not finite.all():
        raise InputError(f"{name}: row {int(np.argmin(finite))} is not finite (NaN or inf)")
    return a
