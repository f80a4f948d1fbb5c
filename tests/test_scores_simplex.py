"""The batched bounded simplex: crash start, vectorised solves, agreement with HiGHS."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from synth.scores.simplex import OPTIMAL, UNBOUNDED, _solve_square, solve_batch


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
def test_matches_highs(M, n, crash):
    rng = np.random.default_rng(M * 100 + n)
    A, c, hi = _random_lps(rng, 60, M, n)
    sol = solve_batch(A, np.zeros((60, M)), c, hi, np.arange(n + 1, n + 1 + M), crash=crash)
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


def test_solve_square_matches_numpy_and_flags_singular():
    rng = np.random.default_rng(2)
    Mat = rng.normal(size=(40, 6, 6))
    rhs = rng.normal(size=(40, 6))
    Mat[7] = 0.0
    Mat[9, :, 2] = Mat[9, :, 4]  # two equal columns: singular
    x, ok = _solve_square(Mat, rhs)
    assert not ok[7] and not ok[9] and ok.sum() == 38
    good = np.nonzero(ok)[0]
    ref = np.linalg.solve(Mat[good], rhs[good][..., None])[..., 0]
    assert np.allclose(x[good], ref, rtol=1e-10, atol=1e-10)
