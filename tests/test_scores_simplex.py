"""The batched bounded simplex: crash start, both pivot routes, the optimality certificate,
agreement with HiGHS."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from synth.errors import InputError, SolverError
from synth.scores import simplex
from synth.scores.simplex import OPTIMAL, UNBOUNDED, UNVERIFIED, _certify, solve_batch


def _random_lps(rng, B, M, n):
    """max c^T x, [A I] x = 0, 0 <= x <= 1 for the first n, slack/artificials fixed at 0,
    plus one free-above column (like the s column of the d* LP)."""
    A = rng.normal(size=(B, M, n + 1))
    Afull = np.concatenate([A, np.broadcast_to(np.eye(M), (B, M, M))], axis=2)
    hi = np.concatenate([np.ones(n), [np.inf], np.zeros(M)])
    c = np.zeros(n + 1 + M)
    c[n] = 1.0
    c[: n // 2] = 0.1 * rng.normal(size=n // 2)
    return Afull, c, hi


@pytest.mark.parametrize("crash", [False, True])
@pytest.mark.parametrize("M, n", [(3, 6), (6, 12), (6, 20)])
def test_matches_highs(M, n, crash, pivot_route):
    rng = np.random.default_rng(M * 100 + n)
    A, c, hi = _random_lps(rng, 60, M, n)
    sol = solve_batch(A, np.zeros((60, M)), c, hi, np.arange(n + 1, n + 1 + M), crash=crash,
                      compiled=pivot_route == "numba")
    for j in range(60):
        ref = linprog(-c, A_eq=A[j], b_eq=np.zeros(M),
                      bounds=[(0, h if np.isfinite(h) else None) for h in hi], method="highs")
        if ref.status == 3:
            assert sol.status[j] == UNBOUNDED
        else:
            assert sol.status[j] == OPTIMAL
            assert sol.objective[j] == pytest.approx(-ref.fun, abs=1e-9)
            assert np.abs(A[j] @ sol.x[j]).max() < 1e-9


def test_crash_needs_fewer_iterations():
    rng = np.random.default_rng(1)
    A, c, hi = _random_lps(rng, 200, 6, 12)
    args = (A, np.zeros((200, 6)), c, hi, np.arange(13, 19))
    plain, crashed = solve_batch(*args), solve_batch(*args, crash=True)
    assert crashed.iterations.sum() < plain.iterations.sum()
    ok = (plain.status == OPTIMAL) & (crashed.status == OPTIMAL)
    assert np.allclose(plain.objective[ok], crashed.objective[ok], atol=1e-9)


def test_nonzero_rhs_known_optimum(pivot_route):
    # max x0 + x1 s.t. x0 + x1 + s = 1.5, 0 <= x0, x1 <= 1: optimum 1.5 (found by hand), reached
    # by a bound flip and a pivot
    A = np.array([[[1.0, 1.0, 1.0]]])
    sol = solve_batch(A, np.array([[1.5]]), np.array([1.0, 1.0, 0.0]),
                      np.array([1.0, 1.0, np.inf]), np.array([2]),
                      compiled=pivot_route == "numba")
    assert sol.status[0] == OPTIMAL
    assert sol.objective[0] == pytest.approx(1.5)
    assert sorted(sol.x[0, :2]) == pytest.approx([0.5, 1.0])


def _one_lp():
    """max x0 s.t. x0 - x1 + a = 0, x0 + x2 + s = 1 (a fixed at 0, s a slack) as (A, b, c, hi,
    basis0); by hand, the optimum is x0 = x1 = 1, x2 = s = 0."""
    A = np.array([[[1.0, -1.0, 0.0, 1.0, 0.0], [1.0, 0.0, 1.0, 0.0, 1.0]]])
    b = np.array([[0.0, 1.0]])
    c = np.array([1.0, 0.0, 0.0, 0.0, 0.0])
    hi = np.array([np.inf, np.inf, np.inf, 0.0, np.inf])
    return A, b, c, hi, np.array([3, 4])


def test_certificate_accepts_the_optimum_and_rejects_others():
    A, b, c, hi, _ = _one_lp()
    wcols = np.array([0, 1, 2, 4])
    no_upper = np.zeros((1, 4), dtype=bool)
    # optimal basis {x0, x1}: xB = (1, 1); duals y with c_B = y^T B: y = (0, 1)
    x, ok = _certify(A, b, c, hi, wcols, np.array([[0, 1]]), no_upper, np.array([[1.0, 1.0]]),
                     np.array([[0.0, 1.0]]))
    assert ok[0] and x[0] == pytest.approx([1, 1, 0, 0, 0])
    # the start (artificial and slack basic, x = 0) is feasible but not optimal: x0 prices out
    x, ok = _certify(A, b, c, hi, wcols, np.array([[3, 4]]), no_upper, np.array([[0.0, 1.0]]),
                     np.array([[0.0, 0.0]]))
    assert not ok[0]
    # right basis, wrong values (A x != b)
    _, ok = _certify(A, b, c, hi, wcols, np.array([[0, 1]]), no_upper, np.array([[1.0, 0.5]]),
                     np.array([[0.0, 1.0]]))
    assert not ok[0]
    # right point, duals that do not price the basis to zero
    _, ok = _certify(A, b, c, hi, wcols, np.array([[0, 1]]), no_upper, np.array([[1.0, 1.0]]),
                     np.array([[0.0, 0.9]]))
    assert not ok[0]


def test_hand_lp_both_routes(pivot_route):
    A, b, c, hi, basis0 = _one_lp()
    sol = solve_batch(A, b, c, hi, basis0, compiled=pivot_route == "numba")
    assert sol.status[0] == OPTIMAL
    assert sol.x[0] == pytest.approx([1, 1, 0, 0, 0])


def test_bad_compiled_answer_is_caught(monkeypatch):
    """A kernel that returns a wrong point leaves the problem unverified (for HiGHS), never
    reports it optimal."""
    pytest.importorskip("numba")
    real = simplex._compiled_module()

    def wrong(*args):
        basis, upper, xB, y, status, iters = real(*args)
        return basis, upper, xB * 1.01 + 1e-3, y, status, iters

    monkeypatch.setattr(simplex, "_compiled_module", lambda: wrong)
    rng = np.random.default_rng(5)
    A, c, hi = _random_lps(rng, 20, 6, 12)
    sol = solve_batch(A, np.zeros((20, 6)), c, hi, np.arange(13, 19), crash=True, compiled=True)
    assert not (sol.status == OPTIMAL).any()
    assert (sol.status != OPTIMAL).sum() == 20
    assert set(sol.status.tolist()) <= {UNVERIFIED, UNBOUNDED}


def test_route_choice(monkeypatch):
    """auto uses the kernel from COMPILED_MIN_PROBLEMS LPs on (when numba is there), or for any
    batch once it is loaded, else numpy; numpy and numba force a route; anything else is
    refused by name."""
    have = simplex._compiled_module() is not None
    monkeypatch.delenv("SYNTH_SIMPLEX", raising=False)
    monkeypatch.setattr(simplex, "_kernel_loaded", False)
    assert not simplex.compiled_for(simplex.COMPILED_MIN_PROBLEMS - 1)
    assert simplex.compiled_for(simplex.COMPILED_MIN_PROBLEMS) == have
    if have:
        A, b, c, hi, basis0 = _one_lp()
        solve_batch(A, b, c, hi, basis0, compiled=True)
        assert simplex._kernel_loaded and simplex.compiled_for(1)
    monkeypatch.setenv("SYNTH_SIMPLEX", "numpy")
    assert not simplex.compiled_for(10**6)
    monkeypatch.setenv("SYNTH_SIMPLEX", "numba")
    if have:
        assert simplex.compiled_for(1)
    else:
        with pytest.raises(SolverError, match="numba"):
            simplex.compiled_for(1)
    monkeypatch.setenv("SYNTH_SIMPLEX", "fast")
    with pytest.raises(InputError, match="SYNTH_SIMPLEX"):
        simplex.compiled_for(1)


def test_compiled_refused_without_numba(monkeypatch):
    monkeypatch.setattr(simplex, "_compiled_module", lambda: None)
    A, b, c, hi, basis0 = _one_lp()
    with pytest.raises(SolverError, match="numba"):
        solve_batch(A, b, c, hi, basis0, compiled=True)
    assert solve_batch(A, b, c, hi, basis0).status[0] == OPTIMAL  # the numpy loop instead
