"""Frictional form closure with linearised cones."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull, QhullError

from synth import InputError, form_closure, friction_cone_wrenches, frictional_form_closure
from synth import wrench_matrix
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
