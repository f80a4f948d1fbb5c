"""The coordinates' precision and bounds, against plain numpy on the whole array."""

from __future__ import annotations

import numpy as np
import pytest

from synth.part.tolerances import bounds, coordinate_precision


@pytest.mark.parametrize("n", [1, 5, 65_536, 200_001])
def test_float32_test_spans_every_block(n: int) -> None:
    """Coordinates that are all float32 read as float32 (half an ulp of the largest, in
    float32); one float64 value anywhere, the last row included, makes them float64."""
    rng = np.random.default_rng(n)
    v = (rng.normal(size=(n, 3)) * 1e3 - 5e3).astype(np.float32).astype(np.float64)
    top = float(np.abs(v).max())
    assert coordinate_precision(v) == pytest.approx(top * 2.0**-24, rel=1e-12)
    v[-1, 2] += 1e-9 * top
    assert coordinate_precision(v) < 1e-12 * top
    lo, hi = bounds(v)
    assert np.array_equal(lo, v.min(axis=0)) and np.array_equal(hi, v.max(axis=0))


def test_a_small_part_written_with_four_decimals_keeps_their_rounding() -> None:
    """A sphere of radius 0.003 written with four decimals: none of its values has three
    significant digits (0.0012), but many need the fourth decimal, so it was written with
    four and its coordinates are only that precise; round values (0.5, 5e-8) on every grid
    say nothing of the decimals."""
    import trimesh

    written = np.round(trimesh.creation.icosphere(radius=0.003).vertices, 4)
    assert coordinate_precision(written) == 5e-5
    assert coordinate_precision(np.array([[0.5, -0.5, 0.5]])) < 1e-7
    assert coordinate_precision(np.array([[5e-8, -5e-8, 5e-8]])) < 1e-20
