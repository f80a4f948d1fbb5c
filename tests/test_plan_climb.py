"""The swap climb's screen and its kicked starts (synth.plan.climb), against a plain scipy LP."""

import numpy as np
import pytest

from synth.plan.climb import _KICK_TOP, _kick, _screen
from tests.pool_cases import columns as _columns
from tests.pool_cases import lp_d_star as _lp_d_star
from tests.pool_cases import pool as _pool


@pytest.mark.parametrize("readings", [1, 2])
def test_screened_swaps_have_the_d_star_of_a_plain_lp(readings):
    n = 300
    p, nrm = _pool(n, 0)
    sets = [nrm]
    if readings == 2:  # a second reading of the normals: d* is the smaller of the two
        alt = nrm + 0.05 * np.random.default_rng(1).normal(size=nrm.shape)
        sets.append(alt / np.linalg.norm(alt, axis=1, keepdims=True))
    Xs = [_columns(p, s) for s in sets]
    clash = np.zeros((n, n), bool)
    rng = np.random.default_rng(2)
    members = np.array([rng.choice(n, 7, replace=False) for _ in range(8)])
    checked = 0
    for j in range(7):
        d = _screen(Xs, [X.astype(np.float32) for X in Xs], clash, members, j)
        assert d.shape == (8, n) and d.dtype == np.float32
        for m in range(8):
            # the member's own contacts are not swaps
            assert (d[m, members[m]] == 0).all()
            best = np.argsort(-d[m])[:3]
            for q in np.concatenate([best, rng.choice(n, 5, replace=False)]):
                if q in members[m]:
                    continue
                row = members[m].copy()
                row[j] = q
                want = min(_lp_d_star(X[:, row]) for X in Xs)
                assert d[m, q] == pytest.approx(want, abs=2e-4), (j, m, q)
                checked += want > 0
    assert checked > 20  # closure swaps were compared, not only zeros


def test_a_swap_whose_fingertip_overlaps_another_is_screened_out():
    n = 50
    p, nrm = _pool(n, 3)
    X = _columns(p, nrm)
    members = np.arange(7)[None]
    clash = np.zeros((n, n), bool)
    free = _screen([X], [X.astype(np.float32)], clash, members, 0)
    q = int(np.argmax(free[0]))
    assert free[0, q] > 0
    clash[q, 3] = clash[3, q] = True  # q's fingertip overlaps contact 3's
    d = _screen([X], [X.astype(np.float32)], clash, members, 0)
    assert d[0, q] == 0
    assert np.array_equal(np.delete(d[0], q), np.delete(free[0], q))


def _kicked(d, lo=0, hi=40, seed=0, n_pool=500):
    k = 7
    rng = np.random.default_rng(seed)
    seeds = np.zeros((hi, k), np.int64)
    out = np.array([rng.choice(n_pool, k, replace=False) for _ in range(10)])
    out_fit = np.linspace(0.1, 0.9, 10)
    finished = np.ones(10, bool)
    calls = []

    def screen(members, j):  # as the climb's screen: the member's own contacts are no swap
        calls.append((members.copy(), j))
        out = d[None].copy()
        out[0, members[0]] = 0.0
        return out

    seeds_all = np.zeros((10 + hi, k), np.int64)
    _kick(seeds_all, np.concatenate([out, seeds]), np.concatenate([out_fit, np.zeros(hi)]),
          np.concatenate([finished, np.zeros(hi, bool)]), 10 + lo, 10 + hi, n_pool, rng, screen)
    return seeds_all[10 + lo:], out, calls


def test_a_kick_takes_one_contact_from_the_best_screened_swaps_and_one_at_random():
    n_pool = 500
    d = np.zeros(n_pool, np.float32)
    good = np.arange(100, 300)
    d[good] = np.linspace(0.2, 0.9, len(good))
    kicked, out, calls = _kicked(d, n_pool=n_pool)
    elite = out[[9, 8, 7]]  # the three best optima
    random_ones = []
    for row, (member, j) in zip(kicked, calls, strict=True):
        assert len(set(row.tolist())) == 7
        source = [e for e in elite if np.array_equal(e, member[0])]
        assert source, "kicks start from the three best optima"
        changed = np.flatnonzero(row != source[0])
        assert len(changed) == 2 and j in changed
        # the best swaps of what the screen gave for this member (its own contacts are none)
        screened = d.copy()
        screened[member[0]] = 0.0
        top = set(np.argsort(-screened, kind="stable")[:_KICK_TOP].tolist())
        assert row[j] in top
        random_ones += [int(row[c]) for c in changed if c != j]
    # the other one is not always from the screen's best
    assert any(q not in range(100, 300) for q in random_ones)


def test_a_kick_without_a_screened_swap_replaces_both_at_random():
    kicked, out, calls = _kicked(np.zeros(500, np.float32))
    for row, (member, j) in zip(kicked, calls, strict=True):
        assert len(set(row.tolist())) == 7
        changed = np.flatnonzero(row != member[0])
        assert len(changed) == 2 and j in changed  # the contact the screen was asked about
