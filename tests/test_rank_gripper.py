"""Ranking gripper poses from elsewhere (``synth rank --gripper``): statuses, the half-turn,
and the planner's own grasps read back with the planner's contacts and measures."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from synth.cli import main
from synth.fingers.gripper import half_turn, load_gripper
from synth.part import load_part
from synth.plan.gripper import GripperParams, plan_gripper
from synth.plan.gripper_rank import rank_gripper_poses

TCP = load_gripper("franka").tcp
BOX = (0.04, 0.09, 0.06)  # metres: 40 mm across x fits the Franka Hand, 90 mm across y not


@pytest.fixture(scope="module")
def part():
    return load_part(trimesh.creation.box(extents=BOX), units="m")


def _from_above(centre, closing=(1.0, 0.0, 0.0)):
    """A pose approaching along -z of the part, closing along ``closing``, TCP at ``centre``."""
    x = np.asarray(closing, float)
    z = np.array([0.0, 0.0, -1.0])
    R = np.column_stack([x, np.cross(z, x), z])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(centre, float) - R @ TCP
    return T


def _rank(part, poses, malformed=None, **kw):
    return rank_gripper_poses(part, np.asarray(poses), 1.0, GripperParams(**kw), malformed)


def test_each_candidate_gets_one_status(part):
    pinch = _from_above([0.0, 0.0, 0.0])
    deep = _from_above([0.0, 0.0, -0.03])  # the palm in the part's top
    wide = _from_above([0.0, 0.0, 0.0], closing=(0.0, 1.0, 0.0))  # 90 mm across the pads
    away = _from_above([0.5, 0.0, 0.0])
    nan = np.full((4, 4), np.nan)
    r = _rank(part, [away, wide, deep, nan, pinch], {3: "candidate 3: field 'x' bad"})
    by = {row.index: row for row in r.rows}
    assert [row.index for row in r.rows] == [4, 0, 1, 2, 3]  # the ranked first
    assert by[4].status == "ok" and by[4].grasp.closure == "frictional form"
    up = TCP[2] - load_gripper("franka").pad_center[1]  # the pad's centre, 0.05 mm above the TCP
    assert np.allclose(by[4].grasp.points, [[0.02, 0, up], [-0.02, 0, up]], atol=1e-12)
    assert by[4].grasp.width == pytest.approx(0.04, abs=1e-12)
    assert by[2].status == "collision" and "hits the part" in by[2].reason
    assert by[1].status == "no contact" and "wider than the opening" in by[1].reason
    assert by[0].status == "misses the part"
    assert by[3].status == "malformed" and by[3].reason.endswith("field 'x' bad")
    assert r.counts == {"ok": 1, "collision": 1, "no contact": 1, "misses the part": 1,
                        "malformed": 1}


def test_a_pose_and_its_half_turn_are_the_same_jaw_grasp(part):
    T = _from_above([0.003, 0.01, 0.005])
    T[:3, :3] = T[:3, :3] @ trimesh.transformations.rotation_matrix(0.3, [1, 0, 0])[:3, :3]
    r = _rank(part, [T, T @ half_turn()], mass=0.2)
    a, b = sorted(r.rows, key=lambda row: row.index)
    assert a.status == b.status == "ok" and b.same_as == 0 and a.same_as is None
    assert np.array_equal(a.grasp.points, b.grasp.points[::-1])
    assert np.array_equal(a.grasp.pose @ half_turn(), b.grasp.pose)
    assert a.grasp.to_json()["measures"] == b.grasp.to_json()["measures"]


def test_the_planners_grasps_read_back_with_its_contacts_and_measures():
    part = load_part(trimesh.creation.box(extents=(0.05, 0.03, 0.07)), units="m")
    plan = plan_gripper(part, GripperParams(samples=40, top=3, mass=0.2))
    assert len(plan.grasps) == 3
    poses = np.array([g.pose for g in plan.grasps])
    r = _rank(part, poses[::-1], mass=0.2)  # in reverse: ranked back into the plan's order
    assert [row.index for row in r.rows] == [2, 1, 0]
    for g, row in zip(plan.grasps, r.rows, strict=True):
        h = row.grasp
        assert np.abs(h.points - g.points).max() <= 1e-9 * part.length
        assert np.abs(h.pose - g.pose).max() <= 1e-9 * part.length
        for key in ("squeeze_per_weight", "squeeze_sampled", "mu_min", "epsilon", "d_star",
                    "margin", "width"):
            assert getattr(h, key) == pytest.approx(getattr(g, key), rel=1e-9, abs=1e-12), key


def test_the_command_ranks_a_graspgen_file_and_reports_a_malformed_pose(tmp_path, capsys):
    mesh = tmp_path / "box.stl"
    trimesh.creation.box(extents=BOX).export(mesh)
    good = _from_above([0.0, 0.0, 0.0])
    bad = good.copy()
    bad[:3, :3] *= 2.0
    in_mm = good.copy()
    in_mm[:3, 3] *= 1000.0
    np.savez(tmp_path / "p.npz", poses=[in_mm], widths=[45.0], units="mm")  # to a part in m
    assert main(["rank", str(mesh), str(tmp_path / "p.npz"), "--gripper", "franka", "--units",
                 "m", "--json", "--quiet"]) == 0
    row = json.loads(capsys.readouterr().out)["candidates"][0]
    assert row["status"] == "ok" and row["given_width"] == pytest.approx(0.045)
    assert row["width"] == 2 * float(np.float32(0.02))  # the binary STL's float32 faces
    doc = {"object": {"file": "box.stl", "scale": 0.001},  # the mesh in mm, read as metres
           "grasps": {"transforms": [good.tolist(), bad.tolist()],
                      "object_in_gripper": [True, True]}}
    (tmp_path / "g.json").write_text(json.dumps(doc))
    # the STL's numbers are metres; the file says one mesh unit is 1 mm: refused with --units m
    code = main(["rank", str(mesh), str(tmp_path / "g.json"), "--gripper", "franka",
                 "--units", "m"])
    err = capsys.readouterr().err
    assert code == 2 and "object scale" in err and "another size" in err
    doc["object"]["scale"] = 1.0
    (tmp_path / "g.json").write_text(json.dumps(doc))
    code = main(["rank", str(mesh), str(tmp_path / "g.json"), "--gripper", "franka",
                 "--out", str(tmp_path / "r.json")])
    out, err = capsys.readouterr()
    assert code == 2
    lines = [x for x in err.splitlines() if x.startswith("synth: error:")]
    assert len(lines) == 1 and "candidate 1" in lines[0] and "grasps.transforms[1]" in lines[0]
    assert "g.json" in lines[0]
    assert "poses: 2 poses from graspgen file" in err and "object scale 1" in err
    # the mesh's unit, which the STL does not say, is the pose file's: no warning that it is not
    assert "length unit unknown" not in err
    assert f"wrote {tmp_path / 'r.json'}" in out
    res = json.loads((tmp_path / "r.json").read_text())
    assert [c["status"] for c in res["candidates"]] == ["ok", "malformed"]
    assert res["candidates"][0]["label"] == 1.0 and res["poses"]["format"] == "graspgen"
    assert out.splitlines()[1].split()[-1] == "ok"


def test_a_pad_resting_on_its_rim_says_so_in_the_json():
    # a box whose +x face is turned 10 degrees about z: the +x pad rests on its rim with the
    # face's normal, the -x pad flat on its face
    a = np.radians(10.0)
    V = [[-0.02, y, z] for y in (-0.03, 0.03) for z in (-0.03, 0.03)]
    V += [[0.02 - np.tan(a) * y, y, z] for y in (-0.03, 0.03) for z in (-0.03, 0.03)]
    part = load_part(trimesh.convex.convex_hull(np.array(V)), units="m")
    T = np.eye(4)
    T[:3, 3] = -TCP
    row = _rank(part, [T]).rows[0]
    assert row.status == "ok"
    contacts = row.grasp.to_json()["contacts"]
    assert [c["touch"] for c in contacts] == ["rim", "pad"]
    assert np.allclose(contacts[0]["normal"], [-np.cos(a), -np.sin(a), 0.0], atol=1e-9)
    assert np.allclose(contacts[1]["normal"], [1.0, 0.0, 0.0], atol=1e-12)


def test_an_acronym_file_gives_its_object_mass_unless_mass_is_given(tmp_path, capsys):
    """ACRONYM stores the object's mass (``object/mass``): ranking its poses weighs the part
    with it, as ACRONYM's own simulation did; ``--mass`` overrides it, and a NaN (synth's
    export of a build without a mass) is no mass."""
    h5py = pytest.importorskip("h5py")
    from pathlib import Path

    mesh = Path(__file__).resolve().parents[1] / "meshes" / "corpus" / "robosuite_bread.stl"
    part = load_part(mesh, units="m")
    plan = plan_gripper(part, GripperParams(top=3, samples=100))
    poses = np.array([g.pose for g in plan.grasps])
    g = 9.80665
    for stored, given, want in ((0.25, None, 0.25), (0.25, "0.5", 0.5), (np.nan, None, None)):
        h5 = tmp_path / "obj.h5"
        with h5py.File(h5, "w") as f:
            f["grasps/transforms"] = poses
            f["object/scale"] = 1.0
            f["object/mass"] = stored
        out = tmp_path / "r.json"
        args = ["rank", str(mesh), str(h5), "--gripper", "franka", "--units", "m", "--out",
                str(out), "--quiet"] + (["--mass", given] if given else [])
        assert main(args) == 0
        capsys.readouterr()
        doc = json.loads(out.read_text())
        assert doc["model"]["mass"] == want
        for c in doc["candidates"]:
            m = c["measures"]
            if want is None:
                assert m["least_squeeze"] is None
            else:
                assert m["least_squeeze"] == pytest.approx(m["squeeze_per_weight"] * want * g)


def test_pose_files_of_text_or_of_another_place_are_refused_by_name(tmp_path, capsys):
    """Text where numbers belong (ACRONYM datasets, GraspGen labels, NPZ poses) stopped the
    command with an internal error; poses that all miss the part (another frame or unit) were
    ranked, written and exited 0."""
    h5py = pytest.importorskip("h5py")
    mesh = tmp_path / "box.stl"
    trimesh.creation.box(extents=BOX).export(mesh)
    good = _from_above([0.0, 0.0, 0.0])

    def rank(path, *extra):
        code = main(["rank", str(mesh), str(path), "--gripper", "franka", "--units", "m",
                     "--quiet", *extra])
        return code, capsys.readouterr().err

    cases = []
    for key, value in (("grasps/transforms", np.array([b"a"])), ("object/scale", b"abc"),
                       ("grasps/widths", np.array([b"w"]))):
        h5 = tmp_path / f"{key.replace('/', '_')}.h5"
        with h5py.File(h5, "w") as f:
            f["grasps/transforms"] = [good]
            f["object/scale"] = 1.0
            if key in f:
                del f[key]
            f[key] = value
        cases.append((h5, f"dataset '{key}' holds"))
    h5 = tmp_path / "group.h5"
    with h5py.File(h5, "w") as f:
        f["grasps/transforms"] = [good]
        f.create_group("object/scale")
    cases.append((h5, "'object/scale' is a group"))
    h5 = tmp_path / "two.h5"
    with h5py.File(h5, "w") as f:
        f["grasps/transforms"] = [good]
        f["object/scale"] = [1.0, 2.0]
    cases.append((h5, "'object/scale' holds 2 numbers, expected one"))
    doc = {"object": {"file": "box.stl", "scale": 1.0},
           "grasps": {"transforms": [good.tolist()], "object_in_gripper": ["abc"]}}
    (tmp_path / "g.json").write_text(json.dumps(doc))
    cases.append((tmp_path / "g.json", "field 'grasps.object_in_gripper' is ['abc']"))
    np.savez(tmp_path / "s.npz", poses=np.array(["a", "b"]))
    cases.append((tmp_path / "s.npz", "array 'poses' holds <U1 values, expected numbers"))
    for path, message in cases:
        code, err = rank(path)
        assert code == 2 and message in err and "internal error" not in err, (path, err)
    far = good.copy()
    far[:3, 3] += 10.0  # ten metres away: every pose misses the part
    np.savez(tmp_path / "far.npz", poses=[far, far])
    out = tmp_path / "r.json"
    code, err = rank(tmp_path / "far.npz", "--out", str(out))
    assert code == 2 and "no candidate could be used" in err and "misses the part" in err
    assert "(and 1 more unusable)" in err and "frame and unit" in err
    assert not out.exists()


def test_a_point_finger_plan_ranked_with_a_gripper_says_what_it_is(tmp_path, capsys):
    """synth rank MESH PLAN.json --gripper franka, the plan of point fingers: the line says it
    is a point-finger plan to rank without --gripper (it listed the file's JSON keys)."""
    from pathlib import Path

    mesh = Path(__file__).parents[1] / "meshes" / "cube.stl"
    plan = tmp_path / "cube.grasps.json"
    assert main(["plan", str(mesh), "--units", "dm", "--evals", "500", "--top", "1",
                 "--out", str(plan), "--png", str(tmp_path / "p.png"), "--glb",
                 str(tmp_path / "p.glb"), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["rank", str(mesh), str(plan), "--gripper", "franka", "--units", "dm"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"synth: error: {plan}: a point-finger plan (contact sets; JSON written by "
                   "synth plan --out), not gripper poses; rank it without --gripper (synth "
                   f"rank MESH {plan})"), err


def test_the_gripper_an_acronym_file_names_is_told(tmp_path, capsys):
    """ACRONYM names its gripper (``gripper/type``; ``panda`` in its own files): given without
    --gripper, the line says which --gripper to give; with another built-in gripper, a warning
    says the poses were made for the one the file names (every pose may then collide)."""
    h5py = pytest.importorskip("h5py")
    from pathlib import Path

    from synth.fingers.builtin import builtin_named

    assert [builtin_named(n) for n in ("panda", "Franka", "robotiq-2f-85", "robotiq_2f140",
                                       "shadow", None, 3)] == [
        "franka", "franka", "robotiq_2f85", "robotiq_2f140", None, None, None]
    mesh = Path(__file__).resolve().parents[1] / "meshes" / "corpus" / "robosuite_bread.stl"
    h5 = tmp_path / "obj.h5"
    with h5py.File(h5, "w") as f:
        f["grasps/transforms"] = np.stack([_from_above((0.0, 0.0, 0.05))] * 2)
        f["object/scale"] = 1.0
        f["gripper/type"] = "panda"
    assert main(["rank", str(mesh), str(h5), "--units", "m"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"synth: error: {h5}: gripper poses (ACRONYM .h5) of the franka gripper (its "
                   f"gripper/type is 'panda'), not contact sets: rank them with synth rank MESH "
                   f"{h5} --gripper franka"), err
    warning = (f"warning: {h5} holds poses of the franka gripper (its gripper/type is 'panda'), "
               "ranked here as the robotiq_2f85's")
    main(["rank", str(mesh), str(h5), "--units", "m", "--gripper", "robotiq_2f85"])
    assert warning in capsys.readouterr().err.splitlines()
    main(["rank", str(mesh), str(h5), "--units", "m", "--gripper", "franka"])
    assert "warning" not in capsys.readouterr().err
