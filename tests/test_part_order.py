"""Stable orders by one plain sort, against numpy's stable argsort and unique."""

from __future__ import annotations

import numpy as np
import pytest

from synth.part.order import group_ids, stable_order


@pytest.mark.parametrize("n, high", [(0, 1), (1, 1), (7, 1), (300, 5), (1000, 1000),
                                     (5000, 2**40), (100, 2**62)])
def test_stable_order_is_numpys_stable_argsort(n: int, high: int) -> None:
    """Few and many distinct keys, and keys too large for the positions to fit beside them
    (the merge sort is then numpy's own)."""
    rng = np.random.default_rng(n)
    key = rng.integers(0, high, n)
    order, sorted_key = stable_order(key)
    assert np.array_equal(order, np.argsort(key, kind="stable"))
    assert np.array_equal(sorted_key, np.sort(key))
    v, first, inverse = group_ids(key)
    uv, ufirst, uinverse = np.unique(key, return_index=True, return_inverse=True)
    assert np.array_equal(v, uv) and np.array_equal(first, ufirst)
    assert np.array_equal(inverse, uinverse.ravel())


def test_stable_order_with_a_bound() -> None:
    """A given bound gives the same order as a found one; ties keep their positions."""
    key = np.array([3, 1, 3, 0, 1, 3])
    order, sorted_key = stable_order(key, bound=10)
    assert order.tolist() == [3, 1, 4, 0, 2, 5]
    assert sorted_key.tolist() == [0, 1, 1, 3, 3, 3]


def test_stable_order_at_the_limit_of_its_packing() -> None:
    """Two keys below 2**62 pack up to 2**63 - 2, the largest room there is (one plain sort);
    three do not fit (numpy's merge sort then); a bound given as a numpy integer does not
    wrap."""
    for key in ([2**62 - 1, 0], [2**62 - 1, 0, 2**62 - 1]):
        k = np.array(key)
        for bound in (2**62, np.int64(2**62)):
            order, sorted_key = stable_order(k, bound)
            assert np.array_equal(order, np.argsort(k, kind="stable"))
            assert np.array_equal(sorted_key, np.sort(k))
