"""Finger checks on cases with known answers: a cube, an L bracket, an I-beam, a table."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

import synth.fingers as fingers_pkg
import synth.fingers.collide as collide_mod
import synth.fingers.geometry as geometry_mod
import synth.fingers.model as model_mod
from synth.errors import InputError
from synth.fingers import (
    Fingers,
    check_fingers,
    default_fingers,
    finger_placement,
)
from synth.fingers.collide import (
    APPROACH_BLOCKED,
    BODY_HITS_PART,
    MISFIT,
    OK,
    OVERLAP,
    PLANE,
    TIP_PENETRATES,
    FingerChecker,
    checker_for,
)

UP = (0.0, 0.0, -1.0)  # inward normal of a face whose outward normal is +z


CORPUS = Path(__file__).resolve().parent.parent / "meshes" / "corpus"

def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    lo_a, hi_a = np.array(lo), np.array(hi)
    return trimesh.creation.box(
        extents=hi_a - lo_a, transform=trimesh.transformations.translation_matrix((lo_a + hi_a) / 2)
    )


def _union(*boxes: trimesh.Trimesh) -> trimesh.Trimesh:
    mesh = trimesh.boolean.union(list(boxes), engine="manifold")
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    return mesh


@pytest.fixture(scope="module")
def cube() -> trimesh.Trimesh:
    return trimesh.creation.box((2.0, 2.0, 2.0))


@pytest.fixture(scope="module")
def bracket() -> trimesh.Trimesh:
    """L bracket: floor [0,4]x[0,2]x[0,1] and upright [0,1]x[0,2]x[0,4]; inside edge x=1, z=1."""
    return _union(_box((0, 0, 0), (4, 2, 1)), _box((0, 0, 0), (1, 2, 4)))


@pytest.fixture(scope="module")
def ibeam() -> trimesh.Trimesh:
    """I-beam: base z in [-0.5, 0], stem |x| <= 0.5 up to z = 2, top bar z in [2, 2.5]."""
    return _union(
        _box((-2, -1, -0.5), (2, 1, 0)), _box((-0.5, -1, -0.1), (0.5, 1, 2.1)),
        _box((-2, -1, 2), (2, 1, 2.5)),
    )


def _one(part, point, normal, fingers, finger_ids=None):
    ids = None if finger_ids is None else np.asarray(finger_ids)
    return check_fingers(part, np.array([point], float)[None] if np.ndim(point) == 1 else
                         np.array(point, float)[None],
                         np.array([normal], float)[None] if np.ndim(normal) == 1 else
                         np.array(normal, float)[None], fingers, ids)


def _depth(reason: str) -> float:
    match = re.search(r"penetrates the part by ([0-9.e+-]+)", reason)
    assert match, reason
    return float(match.group(1))


# -- cube -----------------------------------------------------------------------------------


def test_tip_on_cube_face_is_accepted_with_its_placement(cube):
    f = Fingers(tip_radius=0.1, body_length=1.0, body_radius=0.05)
    res = _one(cube, (0.3, 0.2, 1.0), UP, f)
    assert res.mask.tolist() == [True] and res.reasons == ("",)
    pl = res.placement(0)
    np.testing.assert_allclose(pl.tip_centers, [[0.3, 0.2, 1.1]], atol=1e-12)
    np.testing.assert_allclose(pl.approach, [[0.0, 0.0, 1.0]], atol=1e-12)
    assert pl.contact_finger.tolist() == [0]
    d = pl.to_dict()
    assert set(d) == {"tip_centers", "tip_radius", "approach", "body_length", "body_radius",
                      "frames"}
    # the finger's frame: origin at the tip centre, +z along the approach (towards the part)
    F = np.array(d["frames"])
    assert F.shape == (1, 4, 4) and np.allclose(F[0, :3, 3], pl.tip_centers[0])
    assert np.allclose(F[0, :3, 2], -pl.approach[0]) and np.linalg.det(F[0, :3, :3]) > 0
    assert np.allclose(F[0, :3, :3].T @ F[0, :3, :3], np.eye(3), atol=1e-12)
    assert json.loads(json.dumps(d)) == d and d["body_length"] == 1.0


@pytest.mark.parametrize("shift", [0.1, 0.5, 2e-3])
def test_tip_shifted_into_cube_face_is_rejected_with_its_depth(cube, shift):
    r = 0.1
    f = Fingers(tip_radius=r)  # penetration_tol = 1e-4
    res = _one(cube, (0.3, 0.2, 1.0 - shift * r), UP, f)
    assert res.mask.tolist() == [False]
    assert res.status[0, 0] == TIP_PENETRATES
    assert "finger 0 tip penetrates the part" in res.reasons[0]
    assert _depth(res.reasons[0]) == pytest.approx(shift * r, rel=1e-2)


def test_penetration_within_tolerance_is_accepted(cube):
    f = Fingers(tip_radius=0.1, penetration_tol=1e-3)
    assert _one(cube, (0.3, 0.2, 1.0 - 0.5e-3), UP, f).mask[0]
    assert not _one(cube, (0.3, 0.2, 1.0 - 1.5e-3), UP, f).mask[0]


def test_tips_closer_than_two_radii_overlap(cube):
    r = 0.1
    f = Fingers(tip_radius=r)
    pts = [(0.0, 0.0, 1.0), (1.9 * r, 0.0, 1.0)]
    res = _one(cube, pts, [UP, UP], f)
    assert not res.mask[0] and res.status[0].tolist() == [OVERLAP, OVERLAP]
    assert res.reasons[0].startswith("fingers 0 and 1 overlap")
    res = _one(cube, [(0.0, 0.0, 1.0), (2.1 * r, 0.0, 1.0)], [UP, UP], f)
    assert res.mask[0] and res.status[0].tolist() == [OK, OK]


def test_batch_mixes_reasons_per_grasp(cube):
    r = 0.1
    f = Fingers(tip_radius=r)
    points = np.array([
        [(0.0, 0.0, 1.0), (0.5, 0.0, 1.0)],
        [(0.0, 0.0, 1.0), (0.5, 0.0, 1.0 - 0.5 * r)],
        [(0.0, 0.0, 1.0), (0.05, 0.0, 1.0)],
    ])
    normals = np.broadcast_to(np.array(UP), points.shape)
    res = check_fingers(cube, points, normals, f)
    assert res.mask.tolist() == [True, False, False]
    assert res.reasons[1].startswith("finger 1 tip penetrates")
    assert "overlap" in res.reasons[2]
    with pytest.raises(InputError, match="rejected"):
        res.placement(1)


# -- L bracket ------------------------------------------------------------------------------


def test_tip_too_big_for_inside_corner_is_rejected(bracket):
    point = (1.3, 1.0, 1.0)  # on the floor, 0.3 from the upright
    res = _one(bracket, point, UP, Fingers(tip_radius=0.5))
    assert not res.mask[0] and res.status[0, 0] == TIP_PENETRATES
    assert _depth(res.reasons[0]) == pytest.approx(0.2, rel=1e-3)
    assert _one(bracket, point, UP, Fingers(tip_radius=0.2)).mask[0]


def test_shared_tip_in_inside_corner_touches_both_faces(bracket):
    r = 0.25
    pts = [(1.0, 1.0, 1.0 + r), (1.0 + r, 1.0, 1.0)]
    nrm = [(-1.0, 0.0, 0.0), UP]
    res = _one(bracket, pts, nrm, Fingers(tip_radius=r), finger_ids=[0, 0])
    assert res.mask[0], res.reasons
    pl = res.placement(0)
    np.testing.assert_allclose(pl.tip_centers, [[1 + r, 1.0, 1 + r]], atol=1e-12)
    assert pl.contact_finger.tolist() == [0, 0] and pl.n_fingers == 1
    np.testing.assert_allclose(pl.approach[0], np.array([1.0, 0.0, 1.0]) / math.sqrt(2))
    # The same two contacts as two separate fingers: the two tips overlap.
    assert "overlap" in _one(bracket, pts, nrm, Fingers(tip_radius=r)).reasons[0]
    # A contact the shared tip cannot reach.
    far = [(1.0, 1.0, 1.0 + 2 * r), (1.0 + r, 1.0, 1.0)]
    res = _one(bracket, far, nrm, Fingers(tip_radius=r), finger_ids=[0, 0])
    assert res.status[0, 0] == MISFIT and "cannot touch contacts [0, 1]" in res.reasons[0]


def test_crossing_bodies_overlap(bracket):
    pts = [(1.5, 1.0, 1.0), (1.0, 1.0, 1.5)]
    nrm = [UP, (-1.0, 0.0, 0.0)]
    res = _one(bracket, pts, nrm, Fingers(tip_radius=0.2, body_length=2.0, body_radius=0.15))
    assert not res.mask[0] and res.reasons[0] == "fingers 0 and 1 overlap (body against finger)"
    short = Fingers(tip_radius=0.2, body_length=0.0, body_radius=0.15)
    assert _one(bracket, pts, nrm, short).mask[0]


# -- I-beam: a face in the shadow of an overhang ----------------------------------------------


def test_face_under_overhang_needs_a_tilted_approach(ibeam):
    point, r = (1.5, 0.0, 0.0), 0.2
    res = _one(ibeam, point, UP, Fingers(tip_radius=r, body_length=0.5, body_radius=0.15))
    assert not res.mask[0] and res.status[0, 0] == APPROACH_BLOCKED
    assert res.reasons[0] == "finger 0 approach blocked by the part"
    # A body long enough to reach the bar is reported as such.
    res = _one(ibeam, point, UP, Fingers(tip_radius=r, body_length=3.0, body_radius=0.15))
    assert res.status[0, 0] == BODY_HITS_PART and res.reasons[0] == "finger 0 body hits the part"
    # A narrow cone does not get out from under the bar; a wide one does.
    narrow = Fingers(tip_radius=r, body_length=0.5, body_radius=0.15,
                     approach_cone=math.radians(20))
    assert not _one(ibeam, point, UP, narrow).mask[0]
    wide = Fingers(tip_radius=r, body_length=0.5, body_radius=0.15,
                   approach_cone=math.radians(60))
    res = _one(ibeam, point, UP, wide)
    assert res.mask[0], res.reasons
    a = res.placement(0).approach[0]
    assert np.linalg.norm(a) == pytest.approx(1.0)
    # The inner ring (tilt 30 deg) already clears the bar's edge towards +x.
    assert math.degrees(math.acos(a[2])) == pytest.approx(30.0) and a[0] > 0.4
    # Independent check of the chosen path: sample the swept tip against the mesh.
    c = res.placement(0).tip_centers[0]
    path = c + np.linspace(0.0, 10.0, 400)[:, None] * a
    sd = trimesh.proximity.signed_distance(ibeam, path)  # positive inside
    assert np.all(-sd >= r - 1e-3 * r - 1e-9)


# -- support plane --------------------------------------------------------------------------


def test_support_plane_under_the_part(cube):
    table = ((0.0, 0.0, -1.0), (0.0, 0.0, 1.0))
    f = Fingers(tip_radius=0.1, body_length=0.5, body_radius=0.05, support_plane=table)
    side = (-1.0, 0.0, 0.0)
    assert _one(cube, (1.0, 0.0, 0.0), side, f).mask[0]
    res = _one(cube, (1.0, 0.0, -0.95), side, f)
    assert res.status[0, 0] == PLANE and res.reasons[0] == "finger 0 tip crosses the support plane"
    res = _one(cube, (0.0, 0.0, -1.0), (0.0, 0.0, 1.0), f)  # the bottom face rests on the table
    assert res.status[0, 0] == PLANE
    # Without the table both are fine.
    free = Fingers(tip_radius=0.1, body_length=0.5, body_radius=0.05)
    assert _one(cube, (1.0, 0.0, -0.95), side, free).mask[0]
    assert _one(cube, (0.0, 0.0, -1.0), (0.0, 0.0, 1.0), free).mask[0]


def test_support_plane_blocks_an_approach_from_below(cube):
    # A tilted table: the side face's outward normal points into it far away.
    table = ((0.0, 0.0, -1.2), (-0.2, 0.0, 1.0))
    f = Fingers(tip_radius=0.1, support_plane=table)
    res = _one(cube, (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), f)
    assert res.reasons[0] == "finger 0 approach crosses the support plane"
    tilted = Fingers(tip_radius=0.1, support_plane=table, approach_cone=math.radians(40))
    res = _one(cube, (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), tilted)
    assert res.mask[0] and res.placement(0).approach[0] @ np.array([-0.2, 0, 1]) > 0


# -- API, caching and errors ----------------------------------------------------------------


def test_duck_typed_part_and_cached_checker(cube):
    part = SimpleNamespace(mesh=cube)
    assert checker_for(part) is checker_for(cube)
    pl = finger_placement(part, [(0.0, 0.0, 1.0)], [UP], Fingers(tip_radius=0.1))
    assert pl.tip_centers.shape == (1, 3)
    with pytest.raises(InputError, match="cannot|rejected"):
        finger_placement(cube, [(0.0, 0.0, 0.9)], [UP], Fingers(tip_radius=0.5))


def test_default_fingers_scale_with_the_part():
    box = trimesh.creation.box((3.0, 4.0, 12.0))
    f = default_fingers(box, approach_cone=0.3)
    assert f.tip_radius == pytest.approx(0.025 * 13.0)
    assert f.body_radius == pytest.approx(0.75 * f.tip_radius)
    assert f.body_length == pytest.approx(10 * f.tip_radius)
    assert f.penetration_tol == pytest.approx(1e-3 * f.tip_radius) and f.approach_cone == 0.3
    assert json.dumps(f.to_dict())


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"tip_radius": 0.0}, "tip_radius"),
        ({"tip_radius": float("nan")}, "tip_radius"),
        ({"tip_radius": 1.0, "body_radius": 1.5}, "body_radius"),
        ({"tip_radius": 1.0, "approach_cone": math.pi / 2}, "approach_cone"),
        ({"tip_radius": 1.0, "penetration_tol": 1.0}, "penetration_tol"),
        ({"tip_radius": 1.0, "body_length": -1.0}, "body_length"),
        ({"tip_radius": 1.0, "support_plane": ((0, 0, 0), (0, 0, 0))}, "support_plane"),
        ({"tip_radius": 1.0, "support_plane": "table"}, "support_plane"),
    ],
)
def test_bad_finger_models_raise(kwargs, match):
    with pytest.raises(InputError, match=match):
        Fingers(**kwargs)


def test_bad_inputs_raise(cube):
    f = Fingers(tip_radius=0.1)
    p = np.zeros((2, 3, 3))
    n = np.broadcast_to(np.array(UP), p.shape)
    with pytest.raises(InputError, match="part"):
        check_fingers(object(), p, n, f)
    with pytest.raises(InputError, match="normals"):
        check_fingers(cube, p, n[:, :2], f)
    with pytest.raises(InputError, match="normals"):
        check_fingers(cube, p, np.zeros_like(p), f)
    with pytest.raises(InputError, match="points"):
        check_fingers(cube, np.zeros((2, 3, 2)), n, f)
    with pytest.raises(InputError, match="NaN"):
        check_fingers(cube, np.full_like(p, np.nan), n, f)
    with pytest.raises(InputError, match="finger_ids"):
        check_fingers(cube, p, n, f, finger_ids=[0, 1, 3])
    with pytest.raises(InputError, match="finger_ids"):
        check_fingers(cube, p, n, f, finger_ids=np.zeros((3, 3), int))
    with pytest.raises(InputError, match="finger_ids"):
        check_fingers(cube, p, n, f, finger_ids=[0.0, 1.0, 2.0])
    with pytest.raises(InputError, match="fingers"):
        check_fingers(cube, p, n, {"tip_radius": 0.1})


def test_finger_ids_with_gaps_renumber_fingers(cube):
    f = Fingers(tip_radius=0.1)
    pts = [(-0.5, 0.0, 1.0), (0.5, 0.0, 1.0), (0.0, 0.5, 1.0)]
    res = _one(cube, pts, [UP] * 3, f, finger_ids=[2, 0, 2])
    # contacts 0 and 2 on one flat face cannot share a tip
    assert res.status[0, 2] == MISFIT and res.reasons[0].startswith("finger 1 cannot touch")
    res = check_fingers(cube, np.array([pts]), np.array([[UP] * 3]), f, np.array([[2, 0, 1]]))
    pl = res.placement(0)
    assert pl.contact_finger.tolist() == [2, 0, 1]
    np.testing.assert_allclose(pl.tip_centers[2], (-0.5, 0.0, 1.1))


@pytest.mark.parametrize("module", [fingers_pkg, collide_mod, geometry_mod, model_mod])
def test_all_names_exist(module):
    for name in module.__all__:
        assert hasattr(module, name), name


def test_checker_rejects_non_mesh():
    with pytest.raises(InputError, match="Trimesh"):
        FingerChecker(SimpleNamespace(mesh="bracket.stl"))


def test_tip_wider_than_a_channel_cannot_reach_its_floor():
    # U channel: two walls 1.0 apart on a base; floor at z = 1, walls at x = 1 and x = 2.
    channel = _union(
        _box((0, 0, 0), (3, 2, 1)), _box((0, 0, 0), (1, 2, 3)), _box((2, 0, 0), (3, 2, 3))
    )
    floor = (1.5, 1.0, 1.0)
    res = _one(channel, floor, UP, Fingers(tip_radius=0.6))
    assert res.status[0, 0] == TIP_PENETRATES
    assert _depth(res.reasons[0]) == pytest.approx(0.1, rel=1e-3)
    assert _one(channel, floor, UP, Fingers(tip_radius=0.45)).mask[0]
    # A tip exactly as wide as the channel touches both walls at once.
    walls = [(1.0, 1.0, 2.0), (2.0, 1.0, 2.0)]
    res = _one(channel, walls, [(-1.0, 0, 0), (1.0, 0, 0)], Fingers(tip_radius=0.5), [0, 0])
    assert res.mask[0], res.reasons
    np.testing.assert_allclose(res.placement(0).tip_centers, [[1.5, 1.0, 2.0]], atol=1e-12)
    # opposite normals cancel: the finger leaves along the channel, upwards
    np.testing.assert_allclose(res.placement(0).approach, [[0.0, 0.0, 1.0]], atol=1e-12)


def test_flipped_normal_puts_the_tip_inside_and_is_rejected(cube):
    # Outward instead of inward normal: the centre lands 0.5 inside the cube, no surface
    # within r of it; the approach from outside must cross the top face.
    res = _one(cube, (0.0, 0.0, 1.0), (0.0, 0.0, 1.0), Fingers(tip_radius=0.5, body_length=0.0))
    assert not res.mask[0] and res.status[0, 0] == APPROACH_BLOCKED


def test_results_do_not_depend_on_the_batch(bracket):
    rng = np.random.default_rng(4)
    pts, faces = trimesh.sample.sample_surface(bracket, 60, seed=3)
    points = pts.reshape(20, 3, 3) + rng.normal(scale=0.02, size=(20, 3, 3))
    normals = -bracket.face_normals[faces].reshape(20, 3, 3)
    f = Fingers(tip_radius=0.2, approach_cone=0.4)
    res = check_fingers(bracket, points, normals, f)
    assert 0 < res.n_accepted < 20
    for i in range(20):
        one = check_fingers(bracket, points[i : i + 1], normals[i : i + 1], f)
        assert one.mask[0] == res.mask[i] and one.reasons[0] == res.reasons[i]
        np.testing.assert_array_equal(one.approach[0], res.approach[i])


def _roof() -> trimesh.Trimesh:
    """Return a block whose top is two facets meeting at a ridge along y, tilted 12 degrees."""
    h = math.tan(math.radians(12.0))
    pts = [(x, y, z) for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 0.0)]
    return trimesh.convex.convex_hull(np.array(pts + [(0.0, -1.0, h), (0.0, 1.0, h)]))


def test_one_fingertip_model_a_tip_sinks_at_most_the_penetration_tolerance() -> None:
    """A contact on the ridge, its normal tilted 8.9 degrees from the facet it lies on and 21
    from the facet across the ridge: the tip enters the ridge by r (1 - cos 8 deg) (distance
    from the tip centre to the ridge line, derived by hand and measured with trimesh), and is
    rejected with that depth and the allowance in the message. The same normal in the middle
    of a facet sinks r (1 - cos a) and is rejected too (no allowance for tessellation); the
    part's own normals there and on the ridge seat tips that sink nothing (trimesh)."""
    from synth.fingers import tip_sinks
    from synth.part import Part

    mesh = _roof()
    part = Part(mesh)
    n_a = np.array([-math.sin(math.radians(12.0)), 0.0, math.cos(math.radians(12.0))])
    n_b = n_a * [-1.0, 1.0, 1.0]
    # outward normal: n_a turned 4 degrees towards n_b, then 8 degrees along the ridge
    swing = np.cross([0.0, 1.0, 0.0], n_a)
    n = math.cos(math.radians(4.0)) * n_a + math.sin(math.radians(4.0)) * swing
    n = math.cos(math.radians(8.0)) * n + math.sin(math.radians(8.0)) * np.array([0.0, 1.0, 0.0])
    assert n @ n_b < math.cos(math.radians(15.0)) < n @ n_a
    r = 0.2
    ridge = np.array([-1e-9, 0.0, math.tan(math.radians(12.0))])  # on facet a, at the ridge
    sunk = r - trimesh.proximity.signed_distance(mesh, [ridge + r * n])[0] * -1
    assert sunk == pytest.approx(r * (1 - math.cos(math.radians(8.0))), rel=1e-6)
    fingers = Fingers(tip_radius=r, body_length=0.0)
    assert sunk > fingers.penetration_tol
    res = check_fingers(part, ridge[None], -n[None], fingers)
    assert not res.mask[0] and res.status[0, 0] == TIP_PENETRATES, res.reasons[0]
    assert f"{fingers.penetration_tol:.3g}" in res.reasons[0], res.reasons[0]
    assert _depth(res.reasons[0]) == pytest.approx(sunk, rel=5e-3)  # printed to 3 digits
    inside = np.array([-0.5, 0.0, 0.5 * math.tan(math.radians(12.0))])  # facet a only
    res = check_fingers(part, inside[None], -n[None], fingers)
    assert not res.mask[0] and res.status[0, 0] == TIP_PENETRATES, res.reasons[0]
    for p in (ridge, inside):
        c = part.resolve(p[None])
        res = check_fingers(part, c.points[None], c.normals[None], fingers)
        assert res.mask[0], res.reasons[0]
        tip = res.tip_centers[0, 0]
        clear = -trimesh.proximity.signed_distance(mesh, [tip])[0]
        assert abs(clear - r) <= 1e-8  # the ridge point lies 1e-9 off the ridge
        assert tip_sinks(part, tip[None], r)[0] <= 1e-8


def test_rank_seats_jittered_candidates_on_the_facets_of_a_curved_part() -> None:
    """Grasps of a tessellated curved part (the corpus lemon), their points jittered by 0.3% of
    its size as another tool's would be: ``synth rank`` snaps them to the facets and seats the
    tips along the facets' normals, so no tip sinks beyond the penetration tolerance (before,
    tips followed interpolated normals and were refused as penetrating by about 1e-5 m). The
    depths are measured again with trimesh's signed distance."""
    from synth import PlanParams, load_part, plan_part
    from synth.cli.rank_contacts import rank_candidates
    from synth.fingers import default_fingers
    from synth.grasps.candidates import Candidate

    path = Path(__file__).resolve().parent.parent / "meshes" / "corpus" / "robosuite_lemon.stl"
    part = load_part(path, units="m")
    # candidates, however hard they would be to hold (the lemon is nearly a body of revolution)
    plan = plan_part(part, PlanParams(evals=3000, top=3, surface="smooth", max_squeeze=None))
    assert plan.grasps, plan.message
    rng = np.random.default_rng(0)
    cands = [Candidate(f"g{i}", g.points + rng.normal(size=g.points.shape) * 3e-3 * part.length,
                       np.full(g.points.shape, np.nan), None)
             for i, g in enumerate(plan.grasps)]
    fingers = default_fingers(part)
    rows = rank_candidates(part, cands, 0.0, fingers, 0.01 * part.length)
    mesh = trimesh.load(path)
    for r in rows:
        assert r.fingers is not None, r.reason
        assert r.fingers["tip_sink"] <= fingers.penetration_tol
        tips = np.asarray(r.fingers["tip_centers"])
        clear = -trimesh.proximity.signed_distance(mesh, tips)
        assert clear.min() >= fingers.tip_radius - fingers.penetration_tol


@pytest.mark.parametrize("mode", ["certified", "traced", "traced without exits",
                                  "traced in 2 steps"])
@pytest.mark.parametrize("shape", ["ibeam", "blob"])
def test_exact_distance_sweeps_change_no_verdict(shape, mode, ibeam, monkeypatch):
    """The near part of an approach sweep is certified with exact distances and only the rest
    goes to FCL; on a large mesh every sweep is traced with them (the first direction, the
    others when it is blocked, then the body) and FCL is left the grazing cases. Every
    verdict, reason and approach must equal FCL's on the whole sweep (a checker that
    certifies nothing), on a part with overhangs and blocked approaches and on a finely
    tessellated one, tips on and off the surface; with the traces' exits through the
    bounding planes and without them; and with traces cut at 2 steps, which leaves some
    sweeps to FCL trees of the faces near each (never the whole part's)."""
    if shape == "ibeam":
        mesh = ibeam.subdivide().subdivide()
    else:
        mesh = trimesh.creation.icosphere(5)
        mesh.vertices *= 1.0 + 0.2 * np.sin(3.0 * mesh.vertices)
    rng = np.random.default_rng(7)
    pts, faces = trimesh.sample.sample_surface(mesh, 700, seed=3)
    normals = -np.asarray(mesh.face_normals)[faces]
    pts = pts + rng.normal(scale=0.01, size=pts.shape) * rng.random((len(pts), 1))
    P, N = pts.reshape(-1, 1, 3), normals.reshape(-1, 1, 3)  # one finger a grasp: all checked
    fingers = Fingers(tip_radius=0.08, body_radius=0.05, body_length=0.6, approach_cone=0.4)
    fcl_only = _full_fcl(mesh).check(P, N, fingers)
    decided = []
    traced = mode != "certified"
    if traced:  # as on a mesh of _TRACE_FACES or more
        monkeypatch.setattr(collide_mod, "_TRACE_FACES", 0)
        if mode == "traced without exits":  # and with the distance bound from the start
            monkeypatch.setattr(collide_mod, "_bounding_planes", lambda v: np.zeros((0, 4)))
            monkeypatch.setattr(collide_mod, "_BOUND_AFTER", 0)
        if mode == "traced in 2 steps":
            monkeypatch.setattr(collide_mod, "_TRACE_STEPS", 2)
            monkeypatch.setattr(collide_mod, "_LOCAL_TREES", 10**9)
        trace = FingerChecker._trace
        monkeypatch.setattr(FingerChecker, "_trace", lambda self, *a: decided.append(
            trace(self, *a)) or decided[-1])
        step = FingerChecker._trace_distance
        bounded = []  # the points whose step the distance bound gave, not an exact distance

        def spy(self, pts, radius):
            out = step(self, pts, radius)
            bounded.append(out < self._distance(pts) - 1e-12)
            return out
        monkeypatch.setattr(FingerChecker, "_trace_distance", spy)
    else:
        certify = FingerChecker._certify
        monkeypatch.setattr(FingerChecker, "_certify", lambda self, *a: decided.append(
            certify(self, *a)[0]) or (decided[-1],) + certify(self, *a)[1:])
    checker = FingerChecker(mesh)
    certified = checker.check(P, N, fingers)
    verdicts = np.concatenate([v.ravel() for v in decided])
    if mode == "traced in 2 steps":  # FCL decided most, on trees of the faces near each
        assert (verdicts == 0).sum() > 200 and checker._local_trees > 200  # 237-261, 210-632
        assert checker._fcl is None
    elif traced:  # the traces decided sweeps both ways, and took the bound's steps far out
        assert (verdicts == 1).any() and (verdicts == -1).any()
        assert len(decided) >= 2 + (shape == "ibeam")  # other directions; the I-beam's bodies
        # every trace decided: no FCL tree at all, of the whole part or of a few faces
        assert (verdicts != 0).all()
        assert checker._fcl is None and checker._local_trees == 0
        # (the I-beam's faces are too large for the bound to take a step; the blob's are
        # not, but the planes end its traces before the bound would take one)
        points = np.concatenate(bounded)
        if mode == "traced without exits":
            assert points.mean() > 0.1 or shape == "ibeam"
            assert len(points) > {"ibeam": 15_000, "blob": 7_000}[shape]  # 15,797 and 7,544
        else:  # the planes end the sweeps near the part: fewer steps, with the same verdicts
            assert len(points) < {"ibeam": 13_500, "blob": 5_500}[shape]  # 12,847 and 5,114
    else:  # every certificate decided some sweeps: the hull's planes (the I-beam's hull has
        # 6; the blob's, thousands, which are not used), a sunk tip, the balls
        kinds = {collide_mod._SINKS, collide_mod._NEAR}
        assert (len(checker._planes) > 0) == (shape == "ibeam")
        if shape == "ibeam":
            kinds.add(collide_mod._CLEAR)
        assert kinds <= set(verdicts.tolist())
    assert np.array_equal(certified.mask, fcl_only.mask)
    assert certified.reasons == fcl_only.reasons
    # each reported depth is the tip's radius less its centre's distance from the surface
    # (trimesh's closest points, a separate code), to the 3 digits printed
    sunk = np.flatnonzero(certified.status[:, 0] == TIP_PENETRATES)
    assert len(sunk) > 5
    centers = certified.tip_centers[sunk, 0]
    _, dist, _ = trimesh.proximity.closest_point(mesh, centers)
    for row, d in zip(sunk, dist, strict=True):
        assert _depth(certified.reasons[row]) == pytest.approx(0.08 - d, rel=5e-3)
    assert np.array_equal(certified.status, fcl_only.status)
    assert np.array_equal(certified.approach, fcl_only.approach, equal_nan=True)
    assert 0 < certified.mask.sum() < len(P)
    assert (certified.status == APPROACH_BLOCKED).any() or shape == "blob"


def _full_fcl(mesh):
    """A checker on FCL's whole sweeps: it certifies and traces nothing."""
    return FingerChecker(mesh, certify=False)


def test_traced_seated_tips_with_no_tolerance_touch_without_penetrating(monkeypatch):
    """With penetration_tol 0 a seated tip's centre is its radius from the surface to
    round-off: the trace must leave that to FCL (review: about half of such tips were said
    to penetrate)."""
    mesh = trimesh.creation.icosphere(4)
    pts, fi = trimesh.sample.sample_surface(mesh, 300, seed=1)
    P, N = pts[:, None], -np.asarray(mesh.face_normals)[fi][:, None]
    fingers = Fingers(tip_radius=0.05, penetration_tol=0.0)
    ref = _full_fcl(mesh).check(P, N, fingers)
    monkeypatch.setattr(collide_mod, "_TRACE_FACES", 0)
    traced = FingerChecker(mesh).check(P, N, fingers)
    assert ref.mask.all()
    assert np.array_equal(traced.status, ref.status)


def test_traced_sweep_ends_where_the_capsule_ends(monkeypatch):
    """A tip far below the part whose sweep ends just short of it: the capsule is clear, and
    the trace must not sample the axis past its end (review: 4 of 300 were blocked)."""
    mesh = trimesh.creation.icosphere(4)
    fingers = Fingers(tip_radius=0.1)
    r = fingers.tip_radius
    rho = r - float(fingers.penetration_tol)
    zbot = float(mesh.vertices[:, 2].min())
    ref_checker = _full_fcl(mesh)
    D = ref_checker.sweep_length(fingers)
    eps = np.linspace(1e-4, 0.09, 300)
    cz = zbot - rho - eps - D  # the sweep's far end is eps below the part's lowest point
    P = np.stack([np.zeros_like(cz), np.zeros_like(cz), cz - r], axis=1)[:, None]
    N = np.broadcast_to([0.0, 0.0, -1.0], P.shape)
    ref = ref_checker.check(P, N, fingers)
    monkeypatch.setattr(collide_mod, "_TRACE_FACES", 0)
    traced = FingerChecker(mesh).check(P, N, fingers)
    assert ref.mask.all()
    assert np.array_equal(traced.status, ref.status)


@pytest.mark.parametrize(("scale", "offset"), [(1.0, 0.0), (1e-3, 0.0), (1e3, 0.0),
                                               (1.0, 1e4)])
def test_hull_planes_certify_compound_parts_at_any_scale(scale, offset):
    """On a convex decomposition (bodies side by side, gaps between them, an outside hull
    that covers several), tips seated on the faces and jittered off them: the checker whose
    sweeps the hull's planes, sunk tips and balls decide gives FCL's verdicts, reasons and
    approaches on whole sweeps, tiny, huge and far from the origin."""
    mesh = trimesh.load(CORPUS / "pybullet_duck_vhacd.obj", force="mesh")
    mesh.apply_scale(scale / mesh.scale)
    mesh.apply_translation([offset, -offset, offset])
    assert mesh.body_count == 5
    rng = np.random.default_rng(11)
    pts, faces = trimesh.sample.sample_surface(mesh, 600, seed=4)
    normals = -np.asarray(mesh.face_normals)[faces]
    jitter = rng.normal(scale=0.01 * scale, size=pts.shape) * (rng.random((len(pts), 1)) < 0.5)
    P, N = (pts + jitter)[:, None], normals[:, None]
    fingers = Fingers(tip_radius=0.02 * scale, body_radius=0.012 * scale,
                      body_length=0.15 * scale, approach_cone=0.4,
                      penetration_tol=2e-5 * scale)
    checker = FingerChecker(mesh)
    verdicts = checker._certify(*_first_sweeps(checker, P, N, fingers))[0]
    assert {collide_mod._CLEAR, collide_mod._SINKS, collide_mod._NEAR} <= set(
        verdicts.ravel().tolist())
    got, ref = checker.check(P, N, fingers), _full_fcl(mesh).check(P, N, fingers)
    assert 0 < got.mask.sum() < len(P)
    assert got.reasons == ref.reasons
    assert np.array_equal(got.status, ref.status)
    assert np.array_equal(got.approach, ref.approach, equal_nan=True)


def _first_sweeps(checker, P, N, fingers):
    """``_certify``'s arguments for one-finger grasps: tip centres, each finger's first
    approach direction (the cone's axis: no support plane), all live."""
    r, tol = fingers.tip_radius, fingers.penetration_tol
    n = N / np.linalg.norm(N, axis=-1, keepdims=True)
    centers = P - r * n
    return (centers, -n, np.ones(P.shape[:2], bool), r - tol, checker.sweep_length(fingers),
            collide_mod._NEAR_LENGTH * r)


def test_certified_sweeps_in_any_direction_are_those_fcl_finds_clear(bracket):
    """The certificates alone, on tip centres around and inside an L bracket and sweeps in
    every direction (not only the cone's axis, so the planes' slope term decides): a sweep
    certified clear is clear for FCL, and a tip certified sunk is nearer the surface than its
    radius for trimesh's closest points."""
    from synth.fingers.geometry import quaternions_to

    rng = np.random.default_rng(5)
    n = 3000
    centers = rng.uniform(-1.0, 5.0, (n, 3))
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    rho, D, near = 0.2, 8.0, 0.2
    checker = FingerChecker(bracket)
    verdict, tip_d, _ = checker._certify(centers[:, None], dirs[:, None], np.ones((n, 1), bool),
                                         rho, D, near)
    verdict = verdict[:, 0]
    ref = FingerChecker(bracket, certify=False)
    sweep = ref._object("capsule", rho, D)
    rot = quaternions_to(dirs)
    mid = ref._fcl_frame(centers + 0.5 * D * dirs)
    hits = np.array([ref._hits(sweep, rot[i], mid[i]) for i in range(n)])
    clear = verdict == collide_mod._CLEAR
    assert clear.sum() > 100 and hits.sum() > 100
    assert not hits[clear].any()
    # directions that would cross the planes: a sweep down onto the upright's top from above
    # it is never certified (it hits), one up and away from the same centre is
    above = np.array([[0.5, 1.0, 4.0 + 1.5 * rho]])
    down, up = np.array([[0.2, 0.0, -1.0]]), np.array([[0.2, 0.0, 1.0]])
    for d, want in ((down, False), (up, True)):
        d = d / np.linalg.norm(d)
        v = checker._certify(above[:, None], d[:, None], np.ones((1, 1), bool), rho, D, near)[0]
        assert (v[0, 0] == collide_mod._CLEAR) == want
    sunk = verdict == collide_mod._SINKS
    _, dist, _ = trimesh.proximity.closest_point(bracket, centers[sunk])
    assert sunk.sum() > 100
    assert (dist < rho).all()
    assert np.allclose(tip_d[sunk, 0], dist, rtol=1e-9, atol=1e-12)


def test_hull_planes_only_for_hulls_of_few_planes():
    """A hull of thousands of planes (a fine sphere) gets no plane certificate: the product of
    fingers by planes would cost more than the FCL sweeps it saves (20k faces: a plan 0.58 s
    -> 2.4 s and 889 MB). A coarse one does; both give FCL's verdicts."""
    fine, coarse = trimesh.creation.icosphere(4), trimesh.creation.icosphere(1)
    assert len(FingerChecker(fine)._planes) == 0
    assert len(FingerChecker(coarse)._planes) == len(coarse.faces)
    fingers = Fingers(tip_radius=0.05)
    for mesh in (fine, coarse):
        pts, fi = trimesh.sample.sample_surface(mesh, 200, seed=2)
        P, N = pts[:, None], -np.asarray(mesh.face_normals)[fi][:, None]
        got, ref = FingerChecker(mesh).check(P, N, fingers), _full_fcl(mesh).check(P, N, fingers)
        assert np.array_equal(got.status, ref.status)
        assert np.array_equal(got.approach, ref.approach, equal_nan=True)


def test_bounding_planes_support_the_vertices():
    """Each of the traces' bounding planes has every vertex on its inner side and touches
    one (the maximum along its normal, by brute force, to round-off: far below the traces'
    slack of 1e-9 of the part's size and distance from the origin), off the origin and at
    any size."""
    rng = np.random.default_rng(5)
    for scale, offset in ((1e-3, 0.0), (1.0, 0.0), (1e3, 1e4)):
        v = rng.normal(size=(200_000, 3)) * scale + offset  # more than one chunk of rows
        planes = collide_mod._bounding_planes(v)
        n, h = planes[:, :3], planes[:, 3]
        assert planes.shape == (42, 4)
        assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
        brute = np.array([max(v[:, 0] * u[0] + v[:, 1] * u[1] + v[:, 2] * u[2]) for u in n])
        assert np.abs(h - brute).max() <= 1e-14 * (scale + offset) * 10


def test_a_trace_ends_at_a_bounding_plane_only_moving_away_from_it():
    """A sweep starting beyond a bounding plane but heading into the part crosses it; one
    heading away ends at once (its first point beyond the plane), with no distance query."""
    mesh = trimesh.creation.icosphere(5)
    checker = FingerChecker(mesh)
    n0 = collide_mod._bounding_planes(np.asarray(mesh.vertices))[0, :3]
    starts = np.array([1.5 * n0, 1.5 * n0])
    dirs = np.array([-n0, n0])
    queried = []
    step = checker._trace_distance
    checker._trace_distance = lambda pts, radius: queried.append(len(pts)) or step(pts, radius)
    assert checker._trace(starts, dirs, 0.1, 3.0).tolist() == [-1, 1]
    assert queried[0] == 1  # the sweep heading away was never measured


def test_fcl_trees_of_the_faces_near_an_object_answer_as_the_whole_part(monkeypatch):
    """Capsules and balls grazing a bumpy sphere (their surface within a few percent of
    their radius of it, either side): FCL against a tree of only the faces whose boxes meet
    the object's box answers as FCL against the whole part's tree; with a box that leaves
    out the object's radius, it does not (the test sees the difference)."""
    from synth.fingers.geometry import quaternions_to

    monkeypatch.setattr(collide_mod, "_TRACE_FACES", 0)
    monkeypatch.setattr(collide_mod, "_LOCAL_TREES", 10**9)
    mesh = trimesh.creation.icosphere(4)
    mesh.vertices *= 1.0 + 0.15 * np.sin(4.0 * mesh.vertices[:, [1]])
    checker = FingerChecker(mesh)
    rng = np.random.default_rng(11)
    x, faces = trimesh.sample.sample_surface(mesh, 400, seed=5)
    n = np.asarray(mesh.face_normals)[faces]
    radius, length = 0.08, 0.6
    tangent = np.cross(n, rng.normal(size=(400, 3)))
    d = tangent / np.linalg.norm(tangent, axis=1, keepdims=True) + 0.3 * n
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    gap = radius * rng.uniform(-0.05, 0.05, size=(400, 1))
    tips = x + n * (radius + gap)
    capsule = checker._object("capsule", radius, length)
    ball = checker._object("sphere", radius)
    rot = quaternions_to(d)
    mids = checker._fcl_frame(tips + 0.5 * length * d)
    at = checker._fcl_frame(tips)

    def answers(axis):
        return ([checker._hits(capsule, rot[i], mids[i], axis(i)) for i in range(400)]
                + [checker._hits(ball, None, at[i], axis(i)) for i in range(400)])

    local = answers(lambda i: d[i])
    assert checker._fcl is None and checker._local_trees == 800
    sizes = dict(checker._sizes)
    checker._sizes = {k: (0.0, h) for k, (r, h) in sizes.items()}  # boxes without the radius
    short = answers(lambda i: d[i])
    checker._sizes = sizes
    whole = answers(lambda i: None)
    assert checker._fcl is not None
    assert local == whole
    assert 100 < sum(whole) < 700  # hits and misses of both kinds
    assert short != whole


def test_a_tip_lost_in_the_coordinates_rounding_is_refused() -> None:
    """A fingertip of radius 1e-20 on the unit cube: its centre one radius off the surface is
    the surface point itself in float64, so every finger check failed and the plan blamed its
    budget; refused by name, while 1e-11 still plans."""
    import trimesh

    from synth.errors import InputError
    from synth.fingers import default_fingers

    box = trimesh.creation.box()
    with pytest.raises(InputError, match="finger radius 1e-20: expected at least"):
        default_fingers(box, tip_radius=1e-20)
    assert default_fingers(box, tip_radius=1e-11).tip_radius == 1e-11
