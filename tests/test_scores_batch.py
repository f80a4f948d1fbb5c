"""The batched scorer agrees with the single LP on every kind of grasp."""

from __future__ import annotations

import numpy as np
import pytest

from synth import InputError, form_closure, form_closure_batch, wrench_matrix
from tests.scoring_cases import TABLE1, blob_contacts, cube_contacts, example1_W

#: every test here runs with both simplex routes (see tests/conftest.py)
pytestmark = pytest.mark.usefixtures("pivot_route")


def _compare(Ws):
    res = form_closure_batch(np.stack(Ws))
    for j, W in enumerate(Ws):
        ref = form_closure(W)
        assert res.d_star[j] == pytest.approx(ref.d_star, abs=1e-7)
        assert bool(res.closure[j]) == ref.is_form_closure
        assert res.rank[j] == ref.rank
    return res


@pytest.mark.parametrize("n", [7, 8, 12, 20])
def test_random_cube_grasps(n):
    rng = np.random.default_rng(n)
    res = _compare([wrench_matrix(*cube_contacts(rng, n)) for _ in range(150)])
    assert res.closure.any() or n == 7


@pytest.mark.parametrize("n, dim", [(7, 3), (9, 3), (16, 3), (4, 2), (6, 2)])
def test_random_blob_grasps(n, dim):
    rng = np.random.default_rng(10 * n + dim)
    res = _compare([wrench_matrix(*blob_contacts(rng, n, dim, 0.5)) for _ in range(120)])
    assert res.closure.any() and not res.closure.all()


def test_paper_table1_batched():
    res = _compare([example1_W(a) for a, _, _ in TABLE1])
    assert res.closure.sum() == 8


def test_degenerate_cases():
    P = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0]])
    octa = wrench_matrix(P, -P)  # d* = 1 (W 1 = 0), rank 3
    dup = np.hstack([octa, octa[:, :1]])  # 7 columns, nullity > 1
    zero_col = dup.copy()
    zero_col[:, 3] = 0.0
    rng = np.random.default_rng(5)
    P2, N2 = blob_contacts(rng, 7, 2, 0.3)
    planar = wrench_matrix(np.hstack([P2, 0 * P2[:, :1]]), np.hstack([N2, 0 * N2[:, :1]]))
    cube = wrench_matrix(*cube_contacts(rng, 7))
    res = _compare([dup, zero_col, planar, cube])
    assert res.rank.tolist()[:3] == [3, 3, 3]
    res8 = _compare([np.hstack([octa, octa[:, :2]]), np.hstack([octa, -octa[:, :2]])])
    assert res8.d_star[0] == pytest.approx(1.0)


def test_scaled_and_rotated_batches_agree():
    rng = np.random.default_rng(2)
    P, N = blob_contacts(rng, 10, 3, 0.5)
    Ws = [wrench_matrix(s * P, N) for s in (1e-3, 1.0, 1e3)]
    res = form_closure_batch(np.stack(Ws))
    assert np.ptp(res.d_star) < 1e-9 and len(set(res.rank.tolist())) == 1


def test_empty_and_bad_batches():
    assert len(form_closure_batch(np.zeros((0, 6, 7)))) == 0
    with pytest.raises(InputError, match="shape"):
        form_closure_batch(np.zeros((6, 7)))
    bad = np.ones((3, 6, 7))
    bad[1, 0, 0] = np.nan
    with pytest.raises(InputError, match=r"W\[1\]"):
        form_closure_batch(bad)


def test_factors_given_by_the_caller_give_the_same_answers():
    from synth.scores.gram import gram_factors

    rng = np.random.default_rng(3)
    W = np.stack([wrench_matrix(*cube_contacts(rng, 7)) for _ in range(40)])
    own = form_closure_batch(W, compiled=False)
    shared = form_closure_batch(W, compiled=False, factors=gram_factors(W))
    assert np.array_equal(own.d_star, shared.d_star) and np.array_equal(own.rank, shared.rank)
    with pytest.raises(InputError, match="factors"):
        form_closure_batch(W[:3], factors=gram_factors(W))


@pytest.mark.parametrize("n, dim", [(7, 3), (9, 3), (12, 3), (16, 3), (4, 2), (6, 2)])
def test_the_forces_certify_d_star(n, dim):
    """``forces``: for every grasp with d* > 0, normal forces the part feels as nothing, every
    one between d* and 1 (so d* is at least the reported value: with the single LP's equal
    d*, they are the optimum's forces); zeros for the others."""
    rng = np.random.default_rng(100 * n + dim)
    Ws = np.stack([wrench_matrix(*blob_contacts(rng, n, dim, 0.5)) for _ in range(300)])
    res = form_closure_batch(Ws)
    assert res.forces.shape == (300, n)
    pos = res.d_star > 0
    assert 5 <= pos.sum() < 300
    c = res.forces[pos]
    resid = np.linalg.norm(np.einsum("bmk,bk->bm", Ws[pos], c), axis=1)
    assert (resid <= 1e-9 * np.linalg.norm(Ws[pos], axis=(1, 2))).all()
    assert (c.min(axis=1) >= res.d_star[pos] * (1 - 1e-9)).all()
    assert (c.max(axis=1) <= 1 + 1e-9).all()
    assert not res.forces[~pos].any()


def test_the_forces_at_the_edges_of_the_measure():
    """Forces where d* is below the closure tolerance are zeros like d*, and where every
    contact may press equally (``W 1 = 0``: the LP's squeeze unbounded, d* = 1) all ones."""
    rng = np.random.default_rng(5)
    v = np.r_[np.ones(6), 1e-12]  # the null line of a 6 x 7 matrix: d* = 1e-12
    M = rng.normal(size=(6, 7))
    tiny = M - np.outer(M @ v, v) / (v @ v)
    W8 = rng.normal(size=(6, 8))
    even = W8 - W8.mean(axis=1, keepdims=True)  # W 1 = 0
    res = form_closure_batch(np.stack([tiny]))
    assert res.d_star[0] == 0 and not res.forces.any()
    res = form_closure_batch(np.stack([even]))
    assert res.d_star[0] == pytest.approx(1.0)
    np.testing.assert_allclose(res.forces[0], np.ones(8))
