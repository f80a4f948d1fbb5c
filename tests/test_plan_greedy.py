"""Greedy randomized starts (synth.plan.greedy), against determinants and a plain scipy LP."""

import numpy as np
import pytest

from synth.plan.climb import SwapPool
from synth.plan.greedy import greedy_starts
from tests.pool_cases import columns as _columns
from tests.pool_cases import lp_d_star as _lp_d_star
from tests.pool_cases import pool as _pool


def _swaps(X, clash=None):
    n = X.shape[1]
    clash = np.zeros((n, n), bool) if clash is None else clash
    return SwapPool((X,), (X.astype(np.float32),), clash)


def test_the_plain_greedy_takes_the_most_wrench_volume_at_each_step():
    n = 60
    p, nrm = _pool(n, 4)
    X = _columns(p, nrm)
    starts = greedy_starts(_swaps(X), np.random.default_rng(0), 6, choice=1)
    assert len(starts) > 0
    for s in starts:
        taken = [int(s[0])]
        for _ in range(5):
            # the volume the taken wrenches span with each candidate: a Gram determinant
            vol = np.full(n, -1.0)
            for q in range(n):
                if q not in taken:
                    W = X[:, taken + [q]]
                    vol[q] = np.linalg.det(W.T @ W)
            taken.append(int(np.argmax(vol)))
        assert s[:6].tolist() == taken


def test_the_seventh_contact_gives_the_six_the_highest_d_star_of_the_pool():
    n = 80
    p, nrm = _pool(n, 5)
    X = _columns(p, nrm)
    starts = greedy_starts(_swaps(X), np.random.default_rng(1), 30)
    assert len(starts) >= 6
    for s in starts:
        six = s[:6].tolist()
        d = np.array([_lp_d_star(X[:, six + [q]]) if q not in six else 0.0 for q in range(n)])
        assert d.max() > 0
        assert d[s[6]] == pytest.approx(d.max(), abs=2e-4)


def test_fingertips_that_overlap_are_never_taken_together():
    n = 80
    p, nrm = _pool(n, 6)
    X = _columns(p, nrm)
    rng = np.random.default_rng(7)
    clash = np.zeros((n, n), bool)
    pairs = rng.choice(n, (400, 2))
    clash[pairs[:, 0], pairs[:, 1]] = clash[pairs[:, 1], pairs[:, 0]] = True
    np.fill_diagonal(clash, False)
    free = greedy_starts(_swaps(X), np.random.default_rng(8), 40)
    starts = greedy_starts(_swaps(X, clash), np.random.default_rng(8), 40)
    assert len(starts) > 0
    assert any(clash[np.ix_(s, s)].any() for s in free)  # the clashes would be taken
    for s in starts:
        assert len(set(s.tolist())) == 7
        assert not clash[np.ix_(s, s)].any()


@pytest.mark.parametrize("n", [40, 60])
def test_a_crowded_pool_loses_starts_only_where_they_cannot_close(n):
    """Each fingertip overlaps its two neighbours' on a ring and every step draws among all
    the contacts still allowed (``choice`` = n): fewer allowed contacts than ``choice`` are
    left, and a start must not be dropped for that, only when no seventh contact closes it
    (about as often as in the same pool without clashes; drawing among the allowed and the
    ruled-out alike dropped about half of the rest)."""
    p, nrm = _pool(n, 11)
    X = _columns(p, nrm)
    ring = np.zeros((n, n), bool)
    i = np.arange(n)
    ring[i, (i + 1) % n] = ring[(i + 1) % n, i] = True
    free = greedy_starts(_swaps(X), np.random.default_rng(0), 100, choice=n)
    crowded = greedy_starts(_swaps(X, ring), np.random.default_rng(0), 100, choice=n)
    assert len(free) >= 20
    assert len(crowded) >= 0.7 * len(free)
    for s in crowded:
        assert not ring[np.ix_(s, s)].any()


def test_small_pools():
    p, nrm = _pool(30, 12)
    X = _columns(p, nrm)
    rng = np.random.default_rng(0)
    assert greedy_starts(_swaps(X[:, :6]), rng, 10).shape == (0, 7)  # fewer than seven
    every = np.ones((30, 30), bool)
    np.fill_diagonal(every, False)  # every fingertip overlaps every other: no second contact
    assert greedy_starts(_swaps(X, every), rng, 10).shape == (0, 7)
    many = greedy_starts(_swaps(X), rng, 100)  # more starts than contacts
    assert len(many) > 0 and many.min() >= 0 and many.max() < 30
    assert all(len(set(s.tolist())) == 7 for s in many)


def test_no_start_where_no_seven_contacts_make_closure():
    n = 60
    p, nrm = _pool(n, 9)
    nrm[:, 2] = np.abs(nrm[:, 2]) + 0.1  # every normal pushes up: nothing balances them
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    starts = greedy_starts(_swaps(_columns(p, nrm)), np.random.default_rng(0), 30)
    assert starts.shape == (0, 7)


def test_the_starts_follow_the_seed():
    p, nrm = _pool(100, 10)
    swaps = _swaps(_columns(p, nrm))
    a = greedy_starts(swaps, np.random.default_rng(3), 20)
    b = greedy_starts(swaps, np.random.default_rng(3), 20)
    c = greedy_starts(swaps, np.random.default_rng(4), 20)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
