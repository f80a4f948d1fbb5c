"""Frictional form closure with linearised cones."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull, QhullError

from synth import (
    InputError,
    form_closure,
    friction_cone_wrenches,
    frictional_form_closure,
    wrench_matrix,
)
from synth.scores.friction import frictional_squeezable
from tests.scoring_cases import blob_contacts


def test_mu_zero_agrees_with_frictionless():
    rng = np.random.default_rng(4)
    seen = set()
    for n, dim in [(7, 3), (10, 3), (5, 2)] * 15:
        P, N = blob_contacts(rng, n, dim, 0.5)
        a = frictional_form_closure(P, N, 0.0)
        b = form_closure(wrench_matrix(P, N))
        assert a.d_star == pytest.approx(b.d_star, abs=1e-7)
        assert a.closure == b.closure
        seen.add(a.closure)
    assert seen == {"form", "force"}


def test_three_fingers_on_a_sphere_need_friction():
    th = np.radians([0, 120, 240])
    P = np.stack([np.cos(th), np.sin(th), 0 * th], axis=1)
    assert frictional_form_closure(P, -P, 0.0).closure == "force"
    r = frictional_form_closure(P, -P, 0.3)
    assert r.closure == "frictional form" and r.d_star > 0.9 and r.rank == 6


def test_two_fingers_cannot_stop_the_spin_about_their_line():
    P = np.array([[1, 0, 0], [-1, 0, 0.0]])
    r = frictional_form_closure(P, -P, 1.0)
    assert r.closure == "force" and r.rank == 5
    assert r.escape_words.startswith("free to rotate about ±x")


def _hull_contains_origin(G):
    try:
        hull = ConvexHull(G.T)
    except QhullError:
        return False
    return bool(np.all(hull.equations[:, -1] < -1e-9))


def test_closure_agrees_with_qhull_of_cone_edges():
    rng = np.random.default_rng(8)
    kinds = set()
    for _ in range(40):
        P, N = blob_contacts(rng, 3, 3, 0.9)
        mu = rng.uniform(0.1, 0.8)
        G = friction_cone_wrenches(P, N, mu, edges=6)
        r = frictional_form_closure(P, N, mu, edges=6)
        assert r.is_closure == _hull_contains_origin(G.reshape(6, -1))
        kinds.add(r.is_closure)
    assert kinds == {True, False}


def test_per_contact_mu_and_planar():
    P = np.array([[1, 0.0], [-1, 0.2], [0, 1.0]])
    N = np.array([[-1, 0.0], [1, 0.0], [0, -1.0]])
    r = frictional_form_closure(P, N, [0.5, 0.5, 0.0])
    assert r.edges == 2 and r.m == 3
    assert r.mu.tolist() == [0.5, 0.5, 0.0]
    with pytest.raises(InputError, match="mu"):
        frictional_form_closure(P, N, [0.5, 0.5])
    with pytest.raises(InputError, match="mu"):
        frictional_form_closure(P, N, -0.1)
    with pytest.raises(InputError, match="edges"):
        frictional_form_closure(np.eye(3), -np.eye(3), 0.5, edges=2)


# --- Trinkle's frictional measure (Section II.B): Example 2 and an independent LP ---------

BETA = np.radians(15.0)


def _example2(l3: float) -> tuple[np.ndarray, np.ndarray]:
    """Example 2 built from contacts: two frictionless contacts at heights l1 = 0 and l2 = 1 on
    the vertical edge (normal +x), and contact 3 on the slanted edge at (l3 tan b, l3) with
    inward normal (-cos b, sin b). Its wrench matrix (moments about the origin) is eq. (20)."""
    P = np.array([[0.0, 0.0], [0.0, 1.0], [l3 * np.tan(BETA), l3]])
    N = np.array([[1.0, 0.0], [1.0, 0.0], [-np.cos(BETA), np.sin(BETA)]])
    return P, N


def _example2_exact(l3: float) -> float:
    """By hand: c3t = tan(b) c3n (vertical balance), c2 = l3 c3n / cos b (moments),
    c1 = (1 - l3) c3n / cos b (horizontal balance); the box caps the largest at 1."""
    if not 0 < l3 < 1:
        return 0.0
    c = np.array([(1 - l3) / np.cos(BETA), l3 / np.cos(BETA), 1.0])
    return float(c.min() / c.max())


@pytest.mark.parametrize("l3", [0.001, 0.1, 0.2, 0.3, 0.4, 0.5, 0.65, 0.7, 0.85, 0.9, 0.999])
def test_table2_rebuilt_from_contacts(l3: float) -> None:
    P, N = _example2(l3)
    W = wrench_matrix(P, N, center=[0.0, 0.0])
    W20 = np.array([[1, 1, -np.cos(BETA)], [0, 0, np.sin(BETA)], [0, -1, l3 / np.cos(BETA)]])
    assert np.allclose(W, W20)  # the normal columns of eq. (20)
    r = frictional_form_closure(P, N, [0.0, 0.0, 0.3])
    assert r.d_star == pytest.approx(_example2_exact(l3), abs=1e-9)
    assert r.closure == "frictional form"
    printed = {0.001: 0.001, 0.1: 0.104, 0.3: 0.311, 0.5: 0.518, 0.7: 0.311, 0.9: 0.104,
               0.999: 0.001}
    if l3 in printed:  # the paper prints three decimals
        assert round(r.d_star, 3) == printed[l3]
    # the optimal normal intensities are the paper's (its c1 and c2 columns are swapped
    # relative to its own eq. (20): c1 carries 1 - l3 here)
    c = np.array([(1 - l3), l3, np.cos(BETA)]) / max(1 - l3, l3, np.cos(BETA))
    assert np.allclose(r.c_normal, c, atol=1e-7)
    sq = frictional_squeezable(P, N, [0.0, 0.0, 0.3])
    assert sq.closure == "frictional form" and sq.squeezable.all()
    assert sq.friction_columns.tolist() == [False, False, True]


@pytest.mark.parametrize("l3", [-0.001, 1.001])
def test_table2_outside_the_edge_is_force_closure(l3: float) -> None:
    P, N = _example2(l3)
    r = frictional_form_closure(P, N, [0.0, 0.0, 0.3])
    assert r.d_star == 0.0 and r.closure == "force"


@pytest.mark.parametrize("l3", [0.1, 0.5, 0.9])
def test_table2_with_too_little_friction_is_no_closure(l3: float) -> None:
    """mu = 0.25 < tan 15 deg: contact 3's force cannot be horizontal."""
    P, N = _example2(l3)
    r = frictional_form_closure(P, N, [0.0, 0.0, 0.25])
    assert r.d_star == 0.0 and r.closure == "force"
    sq = frictional_squeezable(P, N, [0.0, 0.0, 0.25])
    assert sq.closure == "force" and not sq.squeezable.any()


def _facet_lp(P: np.ndarray, N: np.ndarray, mu: float, edges: int) -> float:
    """The same statement in other variables: normal intensities c (box [0, 1], >= d) and
    free tangential intensities (t_u, t_v) per contact, each cone the inscribed regular
    polygon written by its facets cos(th) t_u + sin(th) t_v <= mu cos(pi / E) c."""
    from scipy.optimize import linprog

    n = len(P)
    helper = np.where(np.abs(N[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    u = np.cross(N, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(N, u)
    r = P - P.mean(axis=0)
    cols = [np.concatenate([d, np.cross(r, d)], axis=1).T for d in (N, u, v)]  # 3 x (6, n)
    W = np.hstack(cols)  # [W_n W_t W_o]
    th = (2 * np.arange(edges) + 1) * np.pi / edges
    A_ub, b_ub = [], []
    for i in range(n):
        for t in th:
            row = np.zeros(3 * n + 1)
            row[i] = -mu * np.cos(np.pi / edges)
            row[n + i], row[2 * n + i] = np.cos(t), np.sin(t)
            A_ub.append(row)
            b_ub.append(0.0)
        row = np.zeros(3 * n + 1)
        row[i], row[-1] = -1.0, 1.0  # d <= c_i
        A_ub.append(row)
        b_ub.append(0.0)
    cost = np.zeros(3 * n + 1)
    cost[-1] = -1.0
    res = linprog(cost, A_ub=np.array(A_ub), b_ub=b_ub, A_eq=np.hstack([W, np.zeros((6, 1))]),
                  b_eq=np.zeros(6), bounds=[(0, 1)] * n + [(None, None)] * (2 * n) + [(0, 1)],
                  method="highs")
    return float(res.x[-1])


def test_agrees_with_an_independent_lp_of_the_same_statement() -> None:
    rng = np.random.default_rng(21)
    seen = set()
    for k, mu, edges in [(3, 0.5, 8), (4, 0.3, 6), (5, 0.8, 4), (7, 0.2, 8)] * 10:
        P, N = blob_contacts(rng, k, 3, 0.9)
        a = frictional_form_closure(P, N, mu, edges=edges)
        b = _facet_lp(P, N / np.linalg.norm(N, axis=1, keepdims=True), mu, edges)
        assert a.d_star == pytest.approx(max(b, 0.0) if b > 1e-9 else 0.0, abs=1e-7)
        seen.add(a.d_star > 0)
    assert seen == {True, False}


def test_frictional_squeezable_matches_one_lp_per_contact() -> None:
    """The paper's route: one LP per contact pushing its normal intensity up."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(5)
    kinds = set()
    for trial in range(48):
        k = int(rng.integers(3, 6))
        P, N = blob_contacts(rng, k, 3, 0.9)
        if trial % 3 == 0:  # a pinch along x, the others pressing from +y where nothing opposes
            P[:2], N[:2] = [[1, 0, 0], [-1, 0, 0]], [[-1, 0, 0], [1, 0, 0]]
            P[2:, 1], N[2:] = np.abs(P[2:, 1]) + 0.5, [0.1, -1.0, 0.2]
        mu = float(rng.uniform(0.05, 0.6))
        G = friction_cone_wrenches(P, N, mu, edges=6).reshape(6, -1)
        sums = np.kron(np.eye(k), np.ones((1, 6)))
        per = []
        for i in range(k):
            res = linprog(-sums[i], A_ub=sums, b_ub=np.ones(k), A_eq=G, b_eq=np.zeros(6),
                          bounds=[(0, None)] * (6 * k), method="highs")
            per.append(-res.fun > 1e-7)
        sq = frictional_squeezable(P, N, mu, edges=6)
        assert sq.squeezable.tolist() == per
        kinds.add(sq.closure)
        full = frictional_form_closure(P, N, mu, edges=6)
        assert (sq.closure in ("frictional form", "form")) == full.is_closure
    assert {"frictional form", "strong force", "force"} <= kinds


def test_cone_edges_are_held_to_their_range():
    """A billion cone edges filled 24 GB before the kernel stopped the process: the API takes
    the command line's 3 to 64."""
    from synth.errors import InputError
    from synth.scores import frictional_form_closure

    P = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0]])
    with pytest.raises(InputError, match="edges must be an integer from 3 to 64"):
        frictional_form_closure(P, -P, 0.5, edges=10**9)
    assert frictional_form_closure(P, -P, 0.5, edges=64).closure == "frictional form"
