"""Soft-finger contacts (MuJoCo condim 4, linearised), mu_min, epsilon and the gravity squeeze.

The reference LP here is written independently of synth (its own tangent frames, generators and
``scipy.optimize.linprog`` call) from the same model: generators on the unit sphere of
``(f_t / mu, tau / gamma)`` at latitudes 0 and +-45 degrees (``edges`` longitudes each) and the
two poles.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.optimize import linprog

from synth import InputError
from synth.scores import frictional_form_closure
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.gravity import gravity_hold_batch, least_squeeze_batch
from synth.scores.mu_min import MU_MIN_TOL, mu_min, mu_min_batch
from synth.scores.quality import epsilon_quality

ROOT = Path(__file__).resolve().parents[1]


def _frame(n):
    """Tangents written out independently: u = n x e (e the axis least along n... as synth:
    e_x unless |n_x| >= 0.9, then e_y), v = n x u."""
    e = np.array([0.0, 1.0, 0.0]) if abs(n[0]) >= 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(n, e)
    u = u / np.linalg.norm(u)
    return u, np.cross(n, u)


def _reference_generators(P, N, mu, gamma, edges):
    cols = []
    for p, n in zip(P, N, strict=True):
        n = n / np.linalg.norm(n)
        u, v = _frame(n)
        dirs = []
        for lat in (0.0, np.pi / 4, -np.pi / 4):
            for j in range(edges):
                a = 2 * np.pi * j / edges
                dirs.append((np.cos(lat) * np.cos(a), np.cos(lat) * np.sin(a), np.sin(lat)))
        dirs += [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]
        for du, dv, dt in dirs:
            f = n + mu * (du * u + dv * v)
            cols.append(np.concatenate([f, np.cross(p - P.mean(axis=0), f) + gamma * dt * n]))
    return np.array(cols).T, len(cols) // len(P)


def _reference_d_star(P, N, mu, gamma, edges=8):
    G, M = _reference_generators(P, N, mu, gamma, edges)
    k = len(P)
    S = np.kron(np.eye(k), np.ones(M))
    cost = np.r_[np.zeros(k * M), -1.0]
    res = linprog(cost, A_ub=np.block([[-S, np.ones((k, 1))], [S, np.zeros((k, 1))]]),
                  b_ub=np.r_[np.zeros(k), np.ones(k)], A_eq=np.c_[G, np.zeros(6)],
                  b_eq=np.zeros(6), bounds=(0, None), method="highs")
    return res.x[-1], np.linalg.matrix_rank(G, tol=1e-9 * np.abs(G).max())


def _pinch(dz, dy=0.0):
    """Soft contacts on the faces x = +-1 of a box, the line between them tilted by (dy, dz)/2."""
    P = np.array([[1.0, dy / 2, dz / 2], [-1.0, -dy / 2, -dz / 2]])
    N = np.array([[-1.0, 0, 0], [1.0, 0, 0]])
    return P, N


def test_soft_d_star_matches_an_independent_lp():
    rng = np.random.default_rng(11)
    seen = set()
    P_all, N_all = [], []
    for _ in range(30):
        k = int(rng.integers(2, 4))
        P = rng.normal(size=(k, 3))
        N = -P / np.linalg.norm(P, axis=1, keepdims=True) + 0.3 * rng.normal(size=(k, 3))
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        mu, gamma = rng.uniform(0.2, 0.9), rng.uniform(0.01, 0.3)
        r = frictional_form_closure(P, N, mu, torsion=gamma)
        d_ref, rank_ref = _reference_d_star(P, N, mu, gamma)
        assert r.d_star == pytest.approx(d_ref if d_ref > 1e-9 else 0.0, abs=1e-7)
        assert r.rank == rank_ref
        seen.add(r.closure)
        if k == 2:
            P_all.append(P)
            N_all.append(N)
            b = frictional_form_closure_batch(P[None], N[None], mu, torsion=gamma, compiled=False)
            assert b.d_star[0] == pytest.approx(r.d_star, abs=1e-7)
            assert bool(b.closure[0]) == r.is_closure
    assert seen == {"frictional form", "force"}


def test_soft_forces_lie_in_the_elliptic_cone_and_balance():
    rng = np.random.default_rng(5)
    P = rng.normal(size=(3, 3))
    N = -P / np.linalg.norm(P, axis=1, keepdims=True)
    mu, gamma = 0.6, 0.2
    r = frictional_form_closure(P, N, mu, torsion=gamma)
    assert r.closure == "frictional form"
    G, M = _reference_generators(P, N, mu, gamma, 8)
    lam = r.lam.reshape(-1)
    assert np.abs(G @ lam).max() < 1e-7  # an internal force
    for i, (p, n) in enumerate(zip(P, N, strict=True)):
        u, v = _frame(n)
        cols = G[:, i * M : (i + 1) * M]
        w = cols @ r.lam[i] - np.r_[np.zeros(3), np.cross(p - P.mean(0), cols[:3] @ r.lam[i])]
        f, tau = w[:3], w[3:] @ n
        fn = f @ n
        assert fn >= r.d_star - 1e-9
        assert (f @ u) ** 2 / mu**2 + (f @ v) ** 2 / mu**2 + tau**2 / gamma**2 <= fn**2 + 1e-9


@pytest.mark.parametrize("edge_angle", [0.0, np.pi / 8])
def test_two_soft_contacts_close_exactly_inside_both_cones(edge_angle):
    mu = 0.4
    reach = mu * np.cos(edge_angle)  # the pyramid's radius in that tangential direction
    # (exactly on the boundary, a measure-zero case, the paper's LP bounds only the normal
    # intensities and still finds its internal force there; see synth.scores.friction)
    for frac, closes in [(0.5, True), (0.999, True), (1.001, False), (2.0, False)]:
        t = 2 * frac * reach  # tan(angle of the line from the normal) = t / 2
        # tangential direction at angle edge_angle from u = (0, 0, 1) towards v = (0, -1, 0)
        P, N = _pinch(t * np.cos(edge_angle), -t * np.sin(edge_angle))
        for gamma, want in [(0.05, closes), (0.0, False)]:
            r = frictional_form_closure(P, N, mu, torsion=gamma)
            assert r.is_closure == want, (frac, gamma, r.d_star, r.rank)
            b = frictional_form_closure_batch(P[None], N[None], mu, torsion=gamma, compiled=False)
            assert bool(b.closure[0]) == want
    P, N = _pinch(0.0)
    assert frictional_form_closure(P, N, mu, torsion=0.0).rank == 5  # spin about the line


def test_mu_min_of_a_pinch_by_hand():
    gamma = 0.05
    P1, N1 = _pinch(0.3)  # line 0.15 off the normal, along a cone edge
    P2, N2 = _pinch(0.3 * np.cos(np.pi / 8), -0.3 * np.sin(np.pi / 8))  # between two edges
    P3, N3 = _pinch(0.0)
    res = mu_min_batch(np.stack([P1, P2, P3]), np.stack([N1, N2, N3]), gamma)
    assert res.cone == "soft-8x3+2"
    assert res.mu_min[0] == pytest.approx(0.15, abs=2 * MU_MIN_TOL)
    assert res.mu_min[0] >= 0.15
    assert res.mu_min[1] == pytest.approx(0.15 / np.cos(np.pi / 8), abs=2 * MU_MIN_TOL)
    # exactly antipodal: 0 in exact arithmetic; the rank test (RANK_RTOL = 1e-6) cannot see
    # tangential columns much smaller than that, so the bisection ends within two steps of 0
    assert res.mu_min[2] <= 2 * MU_MIN_TOL
    assert mu_min(P1, N1, 0.0) == np.inf  # point contacts never close
    # three point contacts on a circle, normals tilted 25 degrees out of its plane: the
    # bisection agrees with the LP on either side of its value
    th = np.radians([0, 120, 240])
    P = np.stack([np.cos(th), np.sin(th), 0 * th], axis=1)
    N = -P * np.cos(0.44) + [0, 0, np.sin(0.44)]
    m = mu_min(P, N)
    assert 0.1 < m < 10
    assert frictional_form_closure(P, N, m).is_closure
    assert not frictional_form_closure(P, N, m - 2 * MU_MIN_TOL).is_closure


def test_epsilon_needs_torsion_for_a_pinch():
    P, N = _pinch(0.1)
    assert epsilon_quality(P, N, [0, 0, 0], 2.0, mu=0.5) == 0.0
    e = epsilon_quality(P, N, [0, 0, 0], 2.0, mu=0.5, torsion=0.05)
    assert e > 0
    # scaled torsion resists more: the ball grows with gamma until forces limit it
    assert epsilon_quality(P, N, [0, 0, 0], 2.0, mu=0.5, torsion=0.2) > e


def test_gravity_squeeze_of_a_box_pinched_at_its_centre_of_mass():
    mu, gamma = 0.5, 0.01
    P, N = _pinch(0.0)
    dirs = [[0, 0, -1], [0, 1, 0], [1, 0, 0], [0, 1 / np.sqrt(2), 1 / np.sqrt(2)]]
    f = least_squeeze_batch(P[None], N[None], mu, gamma, [0, 0, 0], 2.0, dirs, compiled=False)[0]
    # along the pads: friction on both pads, equal (no moment about the centre): m g / (2 mu)
    assert f[0] == pytest.approx(1 / (2 * mu), rel=1e-9)
    assert f[1] == pytest.approx(1 / (2 * mu), rel=1e-9)
    assert f[2] == pytest.approx(1.0, rel=1e-9)  # along the jaw: one pad carries it all
    assert f[3] == pytest.approx(1 / (2 * mu), rel=1e-9)  # 45 degrees is a cone edge too
    # in the plane of x and a tangential direction t: F = m g (sin(p) / (2 mu') + cos(p)), at
    # worst sqrt(1 + 1 / (2 mu')^2), mu' = mu cos(pi / 8) between the pyramid's edges
    worst = np.sqrt(1 + 1 / (2 * mu * np.cos(np.pi / 8)) ** 2)
    h = gravity_hold_batch(P[None], N[None], mu, gamma, [0, 0, 0], 2.0, compiled=False)
    assert h.sampled[0] <= worst + 1e-9 <= h.squeeze_per_weight[0]
    assert h.squeeze_per_weight[0] <= h.sampled[0] / 0.982  # the icosphere's plane distances
    one = gravity_hold_batch(P[None], N[None], mu, gamma, [0, 0, 0], 2.0, gravity=[0, 0, -2])
    assert one.squeeze_per_weight[0] == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("level", [1, 2])
def test_gravity_skips_only_directions_that_cannot_be_the_worst(level):
    # gravity_hold_batch evaluates the icosahedron, then only the finer directions whose
    # bound from sublinearity could reach the worst value or the bound: the result must be
    # exactly that of evaluating every direction (pinches of every quality, some never held)
    rng = np.random.default_rng(7)
    P = rng.normal(size=(120, 2, 3)) * 0.02
    P[:, 1] = -P[:, 0] + rng.normal(size=(120, 3)) * 0.003
    N = P[:, ::-1] - P + rng.normal(size=(120, 2, 3)) * 0.01
    N /= np.linalg.norm(N, axis=2, keepdims=True)
    ico = trimesh.creation.icosphere(subdivisions=level)
    V = ico.vertices / np.linalg.norm(ico.vertices, axis=1, keepdims=True)
    T = V[ico.faces]
    h = np.abs(np.einsum("ij,ij->i", np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), T[:, 0]))
    h /= np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1)
    f = least_squeeze_batch(P, N, 0.5, 0.005, [0, 0, 0], 0.05, V, compiled=False)
    hold = gravity_hold_batch(P, N, 0.5, 0.005, [0, 0, 0], 0.05, compiled=False, level=level)
    assert 0 < np.isinf(f).any(axis=1).sum() < len(P)
    assert np.array_equal(hold.sampled, f.max(axis=1))
    assert np.array_equal(hold.worst_direction, V[f.argmax(axis=1)])
    assert np.allclose(hold.squeeze_per_weight, (f[:, ico.faces].max(axis=2) / h).max(axis=1),
                       rtol=1e-12, atol=0)


def test_gravity_off_the_centre_of_mass_needs_torsion():
    # pinched 0.3 above the centre of mass along y: gravity along -z twists about x, the
    # jaw axis, which only torsion resists: |tau| <= gamma f_n at each pad, so
    # 2 gamma F >= m g 0.3 besides the friction bound m g / (2 mu).
    mu = 0.8
    P, N = _pinch(0.0)
    P = P + [0.0, 0.3, 0.0]
    for gamma in (0.05, 0.2):
        f = least_squeeze_batch(P[None], N[None], mu, gamma, [0, 0, 0], 2.0, [[0, 0, -1]],
                                compiled=False)[0, 0]
        # the soft cone couples shear and torsion: with shear share a and torsion share b,
        # a^2 + b^2 <= 1 on the ellipsoid; the inscribed generators reach the segment between
        # (cos 45, sin 45) and its neighbours, so the bound lies between the decoupled one
        # and the one from the straight segment between the equator and the pole
        need_t = 0.3 / (2 * gamma)
        need_f = 1 / (2 * mu)
        assert f >= np.hypot(need_t, need_f) - 1e-9  # never better than the true ellipsoid
        assert f <= (need_t + need_f) + 1e-9  # at least as good as the straight segment
    assert least_squeeze_batch(P[None], N[None], mu, 0.0, [0, 0, 0], 2.0, [[0, 0, -1]])[0, 0] \
        == np.inf


def test_inputs_are_checked():
    P, N = _pinch(0.0)
    with pytest.raises(InputError, match="torsion"):
        frictional_form_closure(P, N, 0.5, torsion=-1.0)
    with pytest.raises(InputError, match="torsion"):
        frictional_form_closure(P[:, :2], N[:, :2], 0.5, torsion=0.1)
    with pytest.raises(InputError, match="gravity"):
        gravity_hold_batch(P[None], N[None], 0.5, 0.1, [0, 0, 0], 1.0, gravity=[0, 0, 0])


def _imports(module: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(module.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
    return names


def test_single_and_batch_scorers_do_not_import_each_other():
    scores = ROOT / "synth" / "scores"
    assert "synth.scores.friction_batch" not in _imports(scores / "friction.py")
    assert "synth.scores.friction" not in _imports(scores / "friction_batch.py")


def test_synth_score_with_torsion_closes_pinches(tmp_path, capsys):
    import json

    from synth.cli import main

    P1, N1 = _pinch(0.1)
    P2, N2 = _pinch(1.5)  # line far outside the cones
    f = tmp_path / "pinch.npz"
    np.savez(f, points=np.stack([P1, P2]), normals=np.stack([N1, N2]))
    assert main(["score", str(f), "--mu", "0.5", "--torsion", "0.05", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [c["closure"] for c in doc["candidates"]] == ["frictional form", "force"]
    assert main(["score", str(f), "--mu", "0.5", "--json"]) == 2  # 2 point contacts: refused
    assert main(["score", str(f), "--torsion", "-1"]) == 2


@pytest.mark.parametrize("P, N, centre, length", [
    # two planner grasps (robosuite can, metaworld mug) where qhull's unmerged facets came out
    # flipped (scipy 1.17's qhull 2020.2, facets 2-6% of the points' size outside): the
    # epsilon must be the merged hull's all the same
    ([[0.02458992733609662, -0.003325942971415377, 0.0002691341805332662],
      [-0.024558221390358438, 0.0031445294902277265, 0.0002691341805332662]],
     [[-0.9914448428824383, 0.13052633267589062, 0.0],
      [0.9914448428824383, -0.13052633267589062, 0.0]],
     [7.379741687417057e-05, -0.00026904592917602105, 0.0010625026839853188],
     0.10677078100606367),
    ([[0.002632633192591576, -0.02672965065446421, 0.00040755284626302346],
      [-0.0026326203529903297, 0.02672965437974797, 0.00040755284626302346]],
     [[-0.09801673544629212, 0.9951847665496351, 0.0],
      [0.09801673544629212, -0.9951847665496351, 0.0]],
     [-8.450796633435371e-10, -2.3259902912754467e-09, -0.004916917902070026],
     0.1006833640868532),
])
def test_epsilon_is_the_least_distance_to_the_merged_hulls_facets(P, N, centre, length):
    from scipy.spatial import ConvexHull

    from synth.scores.cones import cone_wrenches_batch

    P, N = np.array(P), np.array(N)
    G = cone_wrenches_batch(P[None], N[None], 0.5, np.array(centre), 8, 0.005)[0]
    G = G / np.linalg.norm(G[:3], axis=0)
    G[3:] /= length
    hull = ConvexHull(G.T)  # qhull's default merging
    eq = hull.equations
    assert (G.T @ eq[:, :-1].T + eq[:, -1]).max() <= 1e-12  # every facet supports the points
    e = epsilon_quality(P, N, centre, length, mu=0.5, edges=8, torsion=0.005)
    assert e == pytest.approx(float((-eq[:, -1]).min()), rel=1e-12)
