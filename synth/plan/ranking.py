"""The one order of grasps every command prints: ``plan``, ``rank``, ``db top`` (and ``score``).

Tables print d* with ``D_STAR_DIGITS`` decimals. Ranked by d*, grasps are ordered by d*
*as printed* (rounded to those digits), and rows that print the same d* by conditioning,
best first: a reader sees why each row is where it is (values such as 0.5000004 and
0.4999988 both print 0.50000, and differ by less than the LPs' accuracy anyway). Ranked by
conditioning, epsilon or placement tolerance, by that measure (largest first), then as by d*;
ranked by margin, by the least squeeze per weight (smallest first), then as by d*.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeVar

from synth.errors import InputError
from synth.plan.params import RANK_BY

__all__ = ["RANK_BY", "D_STAR_DIGITS", "shown_d_star", "rank_grasps"]

#: Decimals of d* in every printed table.
D_STAR_DIGITS = 5

G = TypeVar("G")


def shown_d_star(d: float) -> float:
    """d* as the tables print it (``D_STAR_DIGITS`` decimals); NaN stays NaN.

    Examples
    --------
    >>> shown_d_star(0.4999988), shown_d_star(0.5000004)
    (0.5, 0.5)
    """
    return float(f"{d:.{D_STAR_DIGITS}f}")


def _measure(value: Any) -> float:
    """A measure for sorting, largest first: None and NaN (not computed) count as lowest."""
    return -math.inf if value is None or math.isnan(value) else float(value)


def rank_grasps(grasps: Sequence[G], rank_by: str = "d_star") -> list[G]:
    """Grasps best first.

    Parameters
    ----------
    grasps : sequence
        Anything with ``d_star``, ``conditioning`` and ``epsilon`` (and ``tolerance`` for
        ``rank_by="tolerance"``); a measure that is None or NaN ranks last.
    rank_by : {"d_star", "conditioning", "epsilon", "tolerance", "margin"}
        ``margin`` orders by ``squeeze_per_weight``, smallest first.

    Returns
    -------
    list
        The same objects, reordered (the sort is stable).
    """
    if rank_by not in RANK_BY:
        raise InputError(f"rank_by: expected one of {', '.join(RANK_BY)}, got {rank_by!r}")

    def by_d_star(g: Any) -> tuple[float, float]:
        return (-_measure(shown_d_star(g.d_star) if g.d_star is not None else None),
                -_measure(g.conditioning))

    if rank_by == "d_star":
        return sorted(grasps, key=by_d_star)
    def by_margin(g: Any) -> tuple[float, float, float]:
        return (-_measure(-g.squeeze_per_weight if g.squeeze_per_weight is not None else None),
                *by_d_star(g))

    if rank_by == "margin":  # the least squeeze per weight, smallest first; unknown last
        return sorted(grasps, key=by_margin)
    return sorted(grasps, key=lambda g: (-_measure(getattr(g, rank_by)), *by_d_star(g)))
