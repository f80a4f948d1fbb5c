"""Contact regions and placement tolerances (synth.robust), checked independently."""

from __future__ import annotations

import numpy as np
import pytest

import synth
from synth.robust import certify, certify_regions, contact_regions, expand
from synth.robust.regions import REGION_VERTICES, _contacts, _shape
from tests.robust_check import (
    cofactors,
    d_star_lp,
    d_star_solve,
    d_star_svd,
    sample_polygon,
    tangent_discs,
    worst_vertex_choice,
    wrenches,
)


# --- the paper's Example 1 rectangle, derived by hand --------------------------------------
def _example1(alpha: float, s1: float = 0.0, s2: float = 0.0, s3: float = 0.0) -> np.ndarray:
    """W_n of Example 1 (l = 1, moments about the upper right corner) with contacts 1 and 2
    slid by s1, s2 along the bottom edge and contact 3 by s3 up the left edge; contact 4 sits
    at the corner."""
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[0, 0, 1, -c], [1, 1, 0, -s], [-1 + s1, s2, 7 / 4 - s3, 0]], float)


def test_example1_tolerance_matches_hand_derivation():
    # Null vector with c4 = 1: c3 = cos a, c2 = -(sin a m1 + cos a m3) / (m2 - m1), so
    # closure needs sin a (1 - s1) - cos a (7/4 - s3) > 0 (and c1 > 0, m2 > m1). With every
    # contact free to slide by r, the worst is s1 = r, s3 = -r:
    #     r* = (sin a - 7/4 cos a) / (sin a + cos a)    (0.23015 at a = 1.2)
    # (c1 > 0 needs r < 7/4 cos a / (cos a + sin a) = 0.49 and m2 > m1 needs r < 1/2.)
    a = 1.2
    exact = (np.sin(a) - 1.75 * np.cos(a)) / (np.sin(a) + np.cos(a))
    assert exact == pytest.approx(0.23015, abs=1e-5)
    D = np.zeros((4, 2, 3))
    D[0, 0, 2] = D[1, 0, 2] = 1.0  # moment x of a push along +y
    D[2, 0, 2] = -1.0  # moment -y of a push along +x
    e = expand(_example1(a), D)
    seg = lambda r: np.array([[-r, 0.0], [r, 0.0]])  # noqa: E731
    fixed = np.zeros((1, 2))
    inside = certify(e, [seg(exact * 0.999)] * 3 + [fixed])
    assert inside.closure is True
    outside = certify(e, [seg(exact * 1.001)] * 3 + [fixed])
    assert outside.closure is False
    x = outside.counterexample  # a real choice where closure is lost
    assert d_star_lp(_example1(a, x[0, 0], x[1, 0], x[2, 0])) == 0.0
    # d* over the regions at half the tolerance: the certified bound is below the exact
    # minimum, which is at a vertex choice (8 of them), and above zero
    r = exact / 2
    cert = certify(e, [seg(r)] * 3 + [fixed])
    exact_min = min(d_star_lp(_example1(a, s1, s2, s3))
                    for s1 in (-r, r) for s2 in (-r, r) for s3 in (-r, r))
    assert 0 < cert.d_star_min <= exact_min + 1e-9


def test_expansion_is_exact():
    rng = np.random.default_rng(3)
    P = rng.normal(size=(7, 3))
    N = rng.normal(size=(7, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    axes = np.zeros((7, 2, 3))
    for i, n in enumerate(N):
        u = np.cross(n, [1.0, 0.0, 0.0])
        u /= np.linalg.norm(u)
        axes[i] = [u, np.cross(n, u)]
    W = wrenches(P, N, np.zeros(3), 1.0)
    D = np.zeros((7, 2, 6))
    D[:, :, 3:] = np.cross(axes, N[:, None, :])
    e = expand(W, D)
    x = rng.normal(size=(5, 7, 2))
    moved = P + np.einsum("zia,iad->zid", x, axes)
    direct = cofactors(wrenches(moved, N, np.zeros(3), 1.0))
    sign = np.sign(cofactors(W).sum())
    np.testing.assert_allclose(e(x), sign * direct, rtol=1e-9, atol=1e-12)


def test_certify_regions_takes_regions_of_slightly_tilted_normals():
    """Real faces tilt by up to the coplanarity angle from their region's normal; the regions
    contact_regions makes on them must re-check from their own data."""
    part = synth.load_part("meshes/cube.stl", units="dm")
    g = synth.plan_part(part, synth.PlanParams(top=1, seed=0)).grasps[0]
    rng = np.random.default_rng(6)
    for tilt in (1e-7, 5e-5):  # radians, below the coplanarity angle (1e-4)
        side = np.cross(g.normals, rng.normal(size=g.normals.shape))
        side /= np.linalg.norm(side, axis=1, keepdims=True)
        N = np.cos(tilt) * g.normals + np.sin(tilt) * side
        reg = contact_regions(part, g.points, N)
        assert reg.certified and reg.kinds == ("plane",) * 7
        closure, d_min = certify_regions(g.points, N, reg.polygons, part.center_mass,
                                         part.length)
        assert closure is True and d_min > 0
    with pytest.raises(synth.InputError, match="does not contain its contact"):
        certify_regions(g.points, g.normals, [p + 0.5 * (p[0] - q) if len(p) > 2 else p
                                              for p, q in zip(reg.polygons, g.points, strict=True)],
                        part.center_mass, part.length)


def test_the_checks_fast_scorer_agrees_with_its_svd():
    rng = np.random.default_rng(5)
    W = rng.normal(size=(20_000, 6, 7))
    W[:10, :, 5] = W[:10, :, 0]  # singular 6 x 6 blocks go to the SVD
    a, b = d_star_svd(W), d_star_solve(W)
    assert ((a > 0) == (b > 0)).all() and (a > 0).sum() > 100
    np.testing.assert_allclose(a[a > 0], b[a > 0], atol=1e-9)
    assert np.array_equal(a[:10] > 0, b[:10] > 0)
    for w, d in zip(W[:200], b[:200], strict=True):  # and linprog
        assert abs(max(d, 0.0) - d_star_lp(w)) < 1e-6


def test_rank_deficient_grasps_are_never_certified():
    """All normals in one plane: W has rank 5 and every cofactor is 0, so rounding noise
    (about 1e-17) must not pass for one sign (it did when the test was relative to the
    cofactors themselves)."""
    rng = np.random.default_rng(0)
    for _ in range(500):
        P = rng.normal(size=(7, 3))
        ang = rng.uniform(0, 2 * np.pi, 7)
        N = np.stack([np.cos(ang), np.sin(ang), np.zeros(7)], axis=1)
        Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        W = wrenches(P @ Q.T, N @ Q.T, np.zeros(3), 1.0)
        assert certify(expand(W, np.zeros((7, 2, 6))), [np.zeros((1, 2))] * 7).closure is False


# --- planned grasps on sample and corpus meshes ---------------------------------------------
_PARTS = [("meshes/bracket.stl", "dm"), ("meshes/cube.stl", None),
          ("meshes/corpus/pybullet_stone.obj", None),
          ("meshes/corpus/metaworld_soccer_goal_collision.obj", None)]


@pytest.fixture(scope="module")
def planned():
    out = []
    for path, units in _PARTS:
        part = synth.load_part(path, units=units)
        plan = synth.plan_part(part, synth.PlanParams(top=2, seed=0))
        for g in plan.grasps:
            out.append((path, part, g, contact_regions(part, g.points, g.normals)))
    assert out
    return out


def test_dense_sampling_never_breaks_certified_regions(planned):
    rng = np.random.default_rng(0)
    for path, part, g, reg in planned:
        if not reg.certified or reg.limited_by == "none":
            continue
        n = 100_000
        pts = np.stack([sample_polygon(p, n, rng) for p in reg.polygons], axis=1)
        W = wrenches(pts, np.repeat(g.normals[None], n, 0), part.center_mass, part.length)
        d = np.concatenate([d_star_svd(W[s:s + 20000]) for s in range(0, n, 20000)])
        assert d.min() > 0, path
        assert d.min() >= reg.d_star_min - 1e-7, path
        # the regions' own corners too, and certify_regions agrees from the stored data
        closure, d_min = certify_regions(g.points, g.normals, reg.polygons, part.center_mass,
                                         part.length)
        assert closure is True and d_min > 0


def test_tolerance_discs_hold_and_are_tight(planned):
    rng = np.random.default_rng(1)
    for path, part, g, reg in planned:
        if reg.tolerance == 0 or not reg.certified:
            continue
        args = (g.normals, part.center_mass, part.length)
        discs = tangent_discs(g.points, g.normals, reg.kinds, reg.polygons, reg.tolerance)
        value, _ = worst_vertex_choice(g.points, g.normals, discs, *args[1:], rng)
        assert value > 0, path
        if reg.limited_by == "closure":
            wider = tangent_discs(g.points, g.normals, reg.kinds, reg.polygons,
                                  1.1 * reg.tolerance)
            value, pts = worst_vertex_choice(g.points, g.normals, wider, *args[1:], rng)
            assert value <= 0, f"{path}: no counterexample at 1.1 x the tolerance"
            assert d_star_lp(wrenches(pts, g.normals, part.center_mass, part.length)) < 1e-6


def test_regions_grown_by_a_fifth_break(planned):
    rng = np.random.default_rng(2)
    tried = 0
    for path, part, g, reg in planned:
        if reg.limited_by == "none" or not reg.certified:
            continue
        cs = _contacts(part, g.points, g.normals)
        size = max(float(np.linalg.norm(p - q, axis=1).max())
                   for p, q, c in zip(reg.polygons, g.points, cs, strict=True) if c.kind == "plane")
        grown = [_shape(c, 1.2 * size, REGION_VERTICES, False) for c in cs]
        if all(len(s) == len(c.feature) and np.allclose(np.sort(s, axis=0),
               np.sort(c.feature, axis=0))
               for s, c in zip(grown, cs, strict=True) if c.kind == "plane"):
            continue  # every region already fills its piece
        tried += 1
        polys = [g.points[i] + s @ c.axes for i, (s, c) in enumerate(zip(grown, cs, strict=True))]
        value, pts = worst_vertex_choice(g.points, g.normals, polys, part.center_mass,
                                         part.length, rng)
        assert value <= 0, f"{path}: regions grown by 20% still hold"
        assert d_star_lp(wrenches(pts, g.normals, part.center_mass, part.length)) < 1e-6
    assert tried


def test_plan_ranks_and_filters_by_tolerance():
    part = synth.load_part("meshes/bracket.stl", units="dm")
    # a time cap far above the work: the budget and the seed decide, whatever the machine's load
    plan = synth.plan_part(part, synth.PlanParams(top=3, seed=0, rank_by="tolerance", time=600,
                                                  evals=10_000))
    tol = [g.tolerance for g in plan.grasps]
    assert tol == sorted(tol, reverse=True) and len(tol) == 3
    doc = plan.to_json()["grasps"][0]
    assert doc["tolerance"] == pytest.approx(tol[0])
    assert doc["tolerance_ratio"] == pytest.approx(tol[0] / doc["fingers"]["tip_radius"])
    assert len(doc["contact_regions"]["polygons"]) == len(doc["points"])
    floor = float(np.median(tol))
    kept = synth.plan_part(part, synth.PlanParams(top=4, seed=0, min_tolerance=floor, time=600,
                                                  evals=10_000))
    assert kept.grasps and all(g.tolerance >= floor for g in kept.grasps)
    none = synth.plan_part(part, synth.PlanParams(top=2, seed=0, evals=3000,
                                                  min_tolerance=part.length))
    assert not none.grasps and "placement tolerance below --min-tolerance" in none.message
    plain = synth.plan_part(part, synth.PlanParams(top=2, seed=0))
    assert plain.grasps[0].contact_regions is None
    assert plain.to_json()["grasps"][0]["tolerance"] is None


def test_sampled_with_friction_reports_uncertified():
    part = synth.load_part("meshes/cube.stl", units="dm")
    plan = synth.plan_part(part, synth.PlanParams(contacts=3, mu=0.5, top=1, seed=0,
                                                  regions=True))
    r = plan.grasps[0].contact_regions
    assert r is not None and r.certified is False and r.tolerance >= 0


def test_more_than_seven_contacts_certified_by_a_subset():
    part = synth.load_part("meshes/bracket.stl", units="dm")
    plan = synth.plan_part(part, synth.PlanParams(contacts=8, top=2, seed=0))
    rng = np.random.default_rng(4)
    checked = 0
    for g in plan.grasps:
        reg = contact_regions(part, g.points, g.normals)
        assert len(reg.polygons) == 8
        if not reg.certified or reg.limited_by == "none":
            continue
        checked += 1
        n = 1000  # one linprog each: closure with 8 contacts has a 2-D null space
        pts = np.stack([sample_polygon(p, n, rng) for p in reg.polygons], axis=1)
        W = wrenches(pts, np.repeat(g.normals[None], n, 0), part.center_mass, part.length)
        d = np.array([d_star_lp(w) for w in W])
        assert (np.linalg.matrix_rank(W) == 6).all()
        assert d.min() > 0 and d.min() >= reg.d_star_min - 1e-7
        closure, d_min = certify_regions(g.points, g.normals, reg.polygons, part.center_mass,
                                         part.length)
        assert closure is True and d_min <= d.min() + 1e-7
    assert checked


def test_certify_regions_names_a_wrong_argument():
    """None, NaN, a zero normal, a missing region, a flat point given as two numbers, no
    centre, a length of zero: each an InputError naming it (they were numpy's AxisError,
    TypeError or ValueError, or a NaN bound returned)."""
    P = np.array([[1.0, 0, 0]] * 7)
    N = np.array([[-1.0, 0, 0]] * 7)
    regions = [p[None] for p in P]
    cases = [
        ((None, None, None, None, None), "field 'points' must have shape"),
        ((P * np.nan, N, regions, [0, 0, 0], 1.0), "field 'points' row 0 is not finite"),
        ((P, N * 0, regions, [0, 0, 0], 1.0), "field 'normals' row 0 has zero length"),
        ((P[:6], N[:6], regions[:6], [0, 0, 0], 1.0), "at least 7 contacts"),
        ((P, N, None, [0, 0, 0], 1.0), "polygons: expected a list of 7"),
        ((P, N, regions[:6], [0, 0, 0], 1.0), "polygons: expected a list of 7 .* of 6"),
        ((P, N, [[1, 2]] * 7, [0, 0, 0], 1.0), r"polygons\[0\]: expected shape"),
        ((P, N, regions, None, 1.0), "center: expected 3 finite numbers"),
        ((P, N, regions, [0, 0, 0], 0.0), "length: expected a positive finite number"),
        ((P, N, regions, [0, 0, 0], np.inf), "length: expected a positive finite number"),
    ]
    for args, message in cases:
        with pytest.raises(synth.InputError, match=message):
            certify_regions(*args)
