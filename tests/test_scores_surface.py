"""The surface models: which normals score a grasp (synth/scores/surface.py), against a plain
scipy LP that shares no code with synth."""

from __future__ import annotations

import numpy as np
import pytest

from synth.errors import InputError
from synth.scores.surface import (
    SURFACES,
    check_surface,
    differs,
    readings,
    surface_scores,
    worst_reading,
)
from tests.independent_check import lp_d_star


def _cube_grasp() -> tuple[np.ndarray, np.ndarray]:
    """Seven contacts on the unit cube (two on x, two on y, three on z), form closure with
    d* = 5/16 (scipy's LP below)."""
    P = np.array([[0.5, 0.1, 0.2], [-0.5, -0.1, -0.2], [0.2, 0.5, 0.1], [-0.2, -0.5, -0.1],
                  [0.1, 0.2, 0.5], [0.1, -0.2, 0.5], [-0.2, 0.0, -0.5]])
    N = -np.sign(P) * (np.abs(P) == 0.5)
    return P, N


def _tilt(N: np.ndarray, rng: np.random.Generator, deg: float) -> np.ndarray:
    S = N + rng.normal(size=N.shape) * np.radians(deg)
    return S / np.linalg.norm(S, axis=-1, keepdims=True)


def test_surface_names_and_readings() -> None:
    assert SURFACES[0] == "both" and set(SURFACES) == {"both", "mesh", "smooth"}
    with pytest.raises(InputError, match="surface: expected one of both, mesh, smooth"):
        check_surface("facets")
    N, S = np.zeros((1, 7, 3)), np.ones((1, 7, 3))
    assert readings(N, S, "mesh")[0] is N and readings(N, S, "smooth")[0] is S
    assert [r is x for r, x in zip(readings(N, S, "both"), (N, S), strict=True)] == [True, True]
    assert differs(N, S).tolist() == [True] and differs(N, N + 1e-13).tolist() == [False]


def test_scores_match_an_independent_lp_with_each_reading() -> None:
    """Random 7- to 9-contact grasps on a cube (the cube grasp moved within its faces,
    some contacts twice) whose smooth normals are tilted a few degrees:
    d_mesh and d_smooth are scipy's d* with each set of normals, the model's d* is the smaller
    (both) or the one named, and closure under both needs closure with both."""
    rng = np.random.default_rng(3)
    center = np.zeros(3)
    P0, N0 = _cube_grasp()
    held = []
    for k in (7, 8, 9):
        # the cube grasp moved within its faces, plus contacts on random faces
        P = np.repeat(np.concatenate([P0, P0[: k - 7]])[None], 40, axis=0)
        N = np.repeat(np.concatenate([N0, N0[: k - 7]])[None], 40, axis=0)
        P += (N == 0) * rng.uniform(-0.08, 0.08, size=P.shape)
        S = _tilt(N, rng, 10.0)
        S[::4] = N[::4]  # some grasps read the same either way
        res = {m: surface_scores(P, N, S, m, center, 1.0) for m in SURFACES}
        for b in range(len(P)):
            dm, rank_m = lp_d_star(P[b], N[b])
            ds, rank_s = lp_d_star(P[b], S[b])
            assert res["both"].d_mesh[b] == pytest.approx(dm, abs=1e-7)
            assert res["both"].d_smooth[b] == pytest.approx(ds, abs=1e-7)
            assert res["mesh"].d_star[b] == pytest.approx(dm, abs=1e-7)
            assert res["smooth"].d_star[b] == pytest.approx(ds, abs=1e-7)
            assert res["both"].d_star[b] == pytest.approx(min(dm, ds), abs=1e-7)
            # closure as scipy sees it (d* within the LPs' accuracy of 0 is undecided)
            for got, d, rank in ((res["mesh"].closure[b], dm, rank_m),
                                 (res["smooth"].closure[b], ds, rank_s)):
                assert got == (rank == 6 and d > 1e-7) or abs(d) < 1e-6
            assert res["both"].closure[b] == (res["mesh"].closure[b] and res["smooth"].closure[b])
        held.append(res["both"].closure)
    held_all = np.concatenate(held)
    assert held_all.any() and not held_all.all()


def test_a_grasp_that_holds_only_on_one_reading_is_not_closure_under_both() -> None:
    """The cube grasp; tilting the lone -z contact's smooth normal 10 degrees about -y keeps
    closure with the smooth reading (scipy's LP says so too) at a lower d*, which both then
    reports; turning it to push sideways only (along +x) breaks closure with the smooth
    reading: under both the grasp is then not closure, under mesh it still is."""
    P, N = _cube_grasp()
    d0, rank0 = lp_d_star(P, N)
    assert rank0 == 6 and d0 == pytest.approx(5 / 16, abs=1e-9)
    S = N.copy()
    a = np.radians(-10.0)
    S[6] = [np.sin(a), 0.0, np.cos(a)]
    res = surface_scores(P[None], N[None], S[None], "both", np.zeros(3), 1.0)
    ds, rank_s = lp_d_star(P, S)
    assert rank_s == 6 and 0 < ds < d0
    assert res.d_mesh[0] == pytest.approx(d0, abs=1e-9)
    assert res.d_smooth[0] == pytest.approx(ds, abs=1e-7)
    assert res.d_star[0] == pytest.approx(ds, abs=1e-7) and res.closure[0]
    S[6] = [1.0, 0.0, 0.0]
    res = surface_scores(P[None], N[None], S[None], "both", np.zeros(3), 1.0)
    assert lp_d_star(P, S)[0] == pytest.approx(0.0, abs=1e-9)
    assert not res.closure[0] and res.d_star[0] == pytest.approx(0.0, abs=1e-9)
    mesh = surface_scores(P[None], N[None], S[None], "mesh", np.zeros(3), 1.0)
    assert mesh.closure[0] and mesh.d_star[0] == pytest.approx(d0, abs=1e-9)


def test_worst_reading_takes_the_smaller_measure() -> None:
    P, N = _cube_grasp()
    S = _tilt(N, np.random.default_rng(0), 5.0)

    def measure(n: np.ndarray) -> float:
        return float(np.linalg.svd(np.vstack([n.T, np.cross(P, n).T]), compute_uv=False)[-1])

    assert worst_reading(measure, N, S, "both") == min(measure(N), measure(S))
    assert worst_reading(measure, N, S, "mesh") == measure(N)
    assert worst_reading(measure, N, S, "smooth") == measure(S)


def test_bad_shapes_are_refused() -> None:
    with pytest.raises(InputError, match=r"\(B, k, 3\)"):
        surface_scores(np.zeros((7, 3)), np.zeros((7, 3)), np.zeros((7, 3)), "both",
                       np.zeros(3), 1.0)
