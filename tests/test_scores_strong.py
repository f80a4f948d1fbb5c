"""Strong force closure (Trinkle's Table 3) and the single-LP squeezable set vs brute force."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from synth import InputError, squeezable_contacts, strong_force_closure
from tests.scoring_cases import TABLE3, example3_W


@pytest.mark.parametrize("a", TABLE3)
def test_table3(a):
    r = strong_force_closure(example3_W(a))
    if abs(a) <= 1.0:
        # exact: c_null = (0, (1 + a)/2, (1 - a)/2, 1), y* = 2
        assert r.closure == "strong force"
        assert r.y_star == pytest.approx(2.0, abs=1e-9)
        assert r.c_null == pytest.approx([0, (1 + a) / 2, (1 - a) / 2, 1], abs=1e-9)
        assert r.squeezable.tolist() == [False, 1 + a > 0, 1 - a > 0, True]
    else:
        assert r.closure == "force" and r.y_star == 0.0
        assert not r.squeezable.any()


def _brute_force(W):
    """The paper's suggestion: one LP per contact, maximising that contact's intensity."""
    m, n = W.shape
    out = []
    for i in range(n):
        cost = np.zeros(n)
        cost[i] = -1.0
        res = linprog(cost, A_eq=W, b_eq=np.zeros(m), bounds=[(0, 1)] * n, method="highs")
        out.append(-res.fun > 1e-9)
    return np.array(out)


def test_single_lp_matches_brute_force():
    rng = np.random.default_rng(0)
    sizes = set()
    for trial in range(80):
        m = 6 if trial % 2 else 3
        n = rng.integers(m + 1, m + 8)
        W = rng.normal(size=(m, n))
        # plant a nonnegative null combination on a random subset of the columns
        k = rng.integers(2, n + 1)
        S = rng.choice(n, k, replace=False)
        w = rng.uniform(0.1, 1.0, k)
        W[:, S[-1]] = -(W[:, S[:-1]] @ w[:-1]) / w[-1]
        single = squeezable_contacts(W)
        assert single.tolist() == _brute_force(W).tolist()
        sizes.add(int(single.sum()))
    assert len(sizes) > 3  # the cases cover several support sizes


def test_form_closure_is_reported_as_form():
    P = np.array([[.5, .1, .1], [-.5, -.1, -.1], [.1, .5, .1], [-.1, -.5, -.1],
                  [.2, .2, -.5], [-.2, .2, -.5], [.2, .4, .5]])
    N = -np.sign(P) * (np.abs(P) == 0.5)
    from synth import wrench_matrix

    r = strong_force_closure(wrench_matrix(P, N))
    assert r.closure == "form" and r.squeezable.all() and r.d_star == pytest.approx(0.5)


def test_external_wrench():
    W = example3_W(0.0)
    ok = strong_force_closure(W, g_ext=[0, -1, 0])  # push down: contact 1 pushes back up
    assert ok.balanced and np.allclose(W @ ok.c_row, [0, 1, 0])
    lift = strong_force_closure(W, g_ext=[0, 1, 0])  # pull up: nothing can hold it
    assert not lift.balanced and lift.y_star == 0.0
    with pytest.raises(InputError):
        strong_force_closure(W, g_ext=[1, 2])
