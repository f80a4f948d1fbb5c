"""Gripper grasps (``synth plan --gripper``), checked by tests/gripper_check.py, which shares
no code with synth, over corpus parts and the sample cube."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.cli import main
from synth.part import load_part
from synth.plan.gripper import DISTINCT_RTOL, GripperParams, plan_gripper
from tests.gripper_check import check_grasp, gripper_shapes

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "meshes" / "corpus"
DATA = ROOT / "synth" / "fingers" / "grippers"
UNITS = {r["file"]: r["units"] for r in json.loads((CORPUS / "corpus.json").read_text())}


@pytest.mark.parametrize("name, gripper", [
    ("robosuite_bread.stl", "franka"),
    ("pybullet_lego_vhacd.obj", "franka"),
    ("robosuite_models_yumi_link7_coarse.stl", "robotiq_2f85"),
    ("metaworld_coffee_mug.stl", "robotiq_2f140"),
])
def test_corpus_grasps_pass_the_independent_check(name, gripper):
    path = CORPUS / name
    part = load_part(path, units=UNITS[name])
    plan = plan_gripper(part, GripperParams(gripper=gripper, samples=60, top=4, mass=0.2))
    assert plan.grasps, plan.message
    doc = plan.to_json()
    scale = float(trimesh.units.unit_conversion("meters", UNITS[name]))
    clear = 1e-3 * part.length
    for g in doc["grasps"]:
        assert check_grasp(g, path, DATA / f"{gripper}.json", scale, doc["model"]["mu"],
                           clear) == []
        m = g["measures"]
        assert m["least_squeeze"] == pytest.approx(m["squeeze_per_weight"] * 0.2 * 9.80665)
        assert m["margin"] == pytest.approx(doc["gripper"]["grip_force"] / m["least_squeeze"])
    margins = [g["measures"]["squeeze_per_weight"] for g in doc["grasps"]]
    assert margins == sorted(margins)  # ranked by the least squeeze
    pts = [np.array([c["point"] for c in g["contacts"]]) for g in doc["grasps"]]
    for i in range(len(pts)):
        for j in range(i):
            d = np.linalg.norm(pts[i][:, None] - pts[j][None], axis=2)
            hausdorff = max(d.min(1).max(), d.min(0).max())
            assert hausdorff >= DISTINCT_RTOL * part.length


FITS = [r["file"] for r in json.loads((CORPUS / "corpus.json").read_text())
        if r["units"] and r["extent"] < 0.6 * {"meters": 1, "millimeters": 1000,
                                               "decimeters": 10}[r["units"]]
        and r["file"] != "pybullet_cloth_z_up.obj"]


@pytest.mark.parametrize("name", FITS)
def test_every_corpus_part_that_fits_passes_the_independent_check(name):
    path = CORPUS / name
    part = load_part(path, units=UNITS[name])
    plan = plan_gripper(part, GripperParams(samples=40, top=2))
    if not plan.grasps:  # said why, in words: too large for the opening, or nothing closes
        assert plan.message.startswith("no grasp: ") and "_" not in plan.message
        return
    doc = plan.to_json()
    scale = float(trimesh.units.unit_conversion("meters", UNITS[name]))
    for g in doc["grasps"]:
        assert check_grasp(g, path, DATA / "franka.json", scale, doc["model"]["mu"],
                           1e-3 * part.length) == []


def test_cli_files_glb_matches_the_json(tmp_path, capsys):
    out = tmp_path / "cube.json"
    assert main(["plan", str(ROOT / "meshes" / "cube.stl"), "--units", "cm", "--gripper",
                 "franka", "--mass", "0.02", "--samples", "40", "--top", "3", "--out",
                 str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "margin" in text and "Franka Hand" in text
    doc = json.loads(out.read_text())
    assert doc["format"] == "synth.gripper_grasps" and doc["gripper"]["name"] == "franka"
    assert "approach +z" in doc["gripper"]["frame"]
    g = doc["grasps"][0]
    T = np.array(g["pose"])
    scene = trimesh.load(out.with_suffix(".glb"))
    geoms = scene.dump(concatenate=False) if hasattr(scene, "dump") else []
    named = {m.metadata.get("name", ""): m for m in geoms}
    # the part and the posed gripper alike are in the part's units (centimetres here)
    assert {g.units for g in scene.geometry.values()} == {"centimeters"}
    assert scene.units == "centimeters" and scene.metadata["synth"]["units"] == "centimeters"
    want = gripper_shapes(DATA / "franka.json", g["width"], 100.0)  # metres to cm
    assert len([k for k in named if k.startswith("gripper_")]) == len(want)
    for k, (V, _) in enumerate(want):
        got = np.asarray(named[f"gripper_{k}"].vertices)
        posed = V @ T[:3, :3].T + T[:3, 3]
        assert got.shape == posed.shape
        assert np.abs(got - posed).max() < 1e-5  # GLB stores float32
    # the TCP is the pose applied to the description's tool centre point
    tcp = np.array(json.loads((DATA / "franka.json").read_text())["tcp"]) * 100.0
    assert np.allclose(g["tcp"], T[:3, :3] @ tcp + T[:3, 3])
    assert out.with_suffix(".png").stat().st_size > 10_000


def test_a_part_too_large_is_told_its_narrowest_width_and_the_opening():
    """The nut in metres (1 m across flats, a hole of 0.5 m: its wall is 0.25 m thick where
    thinnest): no two facing points fit the Franka's 80 mm, and the message names the
    narrowest width found and the opening in words, never the planner's counters."""
    part = load_part(ROOT / "meshes" / "nut.stl", units="m")
    plan = plan_gripper(part, GripperParams(samples=200))
    assert not plan.grasps
    assert "too large for the Franka Hand (Franka Emika Panda)'s 80 mm opening" in plan.message
    # along a closing axis within the friction cone (26.6 degrees at mu 0.5) of the wall's
    # normal, the wall is at least 0.25 cos(26.6 deg) across, and no more than 0.25 m at its
    # thinnest place (a flat facing a vertex of the 48-gon hole) was sampled nearby
    assert 0.25 * np.cos(np.arctan(0.5)) <= plan.narrowest <= 0.2506
    assert f"narrowest width found is {plan.narrowest * 1000:.0f} mm" in plan.message
    for word in ("too_wide", "edge_touch", "distinct_contacts", "collision_free", "pairs"):
        assert word not in plan.message


def test_units_are_required_and_a_large_part_is_told_so(tmp_path, capsys, monkeypatch):
    cube = str(ROOT / "meshes" / "cube.stl")
    assert main(["plan", cube, "--gripper", "franka", "--no-files"]) == 2
    err = capsys.readouterr().err
    assert "--units" in err and "STL files do not say it" in err
    # refused before the mesh is read (a large scan would load for seconds first)
    import synth.cli.plan

    def unread(args):  # type: ignore[no-untyped-def]
        raise AssertionError("the mesh was read")

    with monkeypatch.context() as m:
        m.setattr(synth.cli.plan, "load_part_from_args", unread)
        assert main(["plan", cube, "--gripper", "franka", "--no-files"]) == 2
    assert "--units" in capsys.readouterr().err
    # a format that says its unit is read first (a GLB is in metres: too large for the hand)
    glb = tmp_path / "cube.glb"
    trimesh.load(cube).export(glb)
    assert main(["plan", str(glb), "--gripper", "franka", "--no-files", "--samples", "20"]) == 1
    assert "too large for the Franka Hand" in capsys.readouterr().out
    assert main(["plan", cube, "--units", "m", "--gripper", "franka", "--no-files",
                 "--samples", "20"]) == 1
    assert "too large for the Franka Hand" in capsys.readouterr().out
    assert main(["plan", cube, "--units", "dm", "--gripper", "franka", "--no-files",
                 "--samples", "20"]) == 1
    assert "narrowest width found is 100 mm" in capsys.readouterr().out
    # the pads' torsion means nothing to point fingers (their --mass and --density do)
    assert main(["plan", cube, "--units", "cm", "--torsion", "0.1", "--no-files"]) == 2
    assert "--torsion applies to gripper grasps" in capsys.readouterr().err
    bad = tmp_path / "g.json"
    bad.write_text('{"format": "synth.gripper", "version": 1, "name": "x", "max_opening": 0}')
    assert main(["plan", cube, "--units", "cm", "--gripper", str(bad), "--no-files"]) == 2
    assert "max_opening" in capsys.readouterr().err


def test_table_and_rank_orders():
    part = load_part(ROOT / "meshes" / "cube.stl", units="cm")
    table = float(part.mesh.bounds[0, 2])
    plan = plan_gripper(part, GripperParams(samples=40, top=4, table=table, rank_by="epsilon"))
    assert plan.grasps
    for g in plan.grasps:
        for V, _ in plan.gripper.meshes_at(g.width):
            assert (V @ g.pose[:3, :3].T + g.pose[:3, 3])[:, 2].min() >= table - 1e-9
    eps = [g.epsilon for g in plan.grasps]
    assert eps == sorted(eps, reverse=True)
    by_mu = plan_gripper(part, GripperParams(samples=40, top=4, rank_by="mu_min"))
    mus = [g.mu_min for g in by_mu.grasps]
    assert mus == sorted(mus)


def test_the_margin_floor_keeps_what_the_hand_can_hold():
    """With the part's mass, a grasp whose least squeeze exceeds the rated force over
    ``min_margin`` is not returned: the floored plan is the unfloored plan's grasps of margin
    at least ``min_margin``; a part too heavy for every grasp is told so with the least
    squeeze; without a mass, or with ``min_margin`` None, nothing is refused."""
    part = load_part(CORPUS / "robosuite_bread.stl", units="m")
    base = dict(samples=120, top=50)
    free = plan_gripper(part, GripperParams(**base, mass=1.0, min_margin=None))
    margins = np.array([g.margin for g in free.grasps])
    assert len(margins) > 5 and margins.min() < 2 <= margins.max()
    floored = plan_gripper(part, GripperParams(**base, mass=1.0, min_margin=2.0))
    assert [g.margin for g in floored.grasps] == [m for m in margins if m >= 2.0]
    F = free.gripper.grip_force
    best = free.grasps[0].least_squeeze
    light = plan_gripper(part, GripperParams(**base, mass=0.99 * F / best))
    assert light.grasps and light.grasps[0].margin >= 1.0
    for rank_by in ("d_star", "mu_min", "epsilon"):  # the verdict does not follow the order
        other = plan_gripper(part, GripperParams(**base, mass=0.99 * F / best, rank_by=rank_by))
        assert other.grasps and min(g.margin for g in other.grasps) >= 1.0
    heavy = plan_gripper(part, GripperParams(**base, mass=1.01 * F / best))
    assert not heavy.grasps
    assert "too heavy for the Franka Hand" in heavy.message
    assert f"needs a squeeze of {1.01 * F:.3g} N" in heavy.message
    assert plan_gripper(part, GripperParams(samples=120, top=3)).grasps  # no mass: no floor


def test_the_independent_check_catches_broken_grasps():
    path = CORPUS / "robosuite_bread.stl"
    part = load_part(path, units="meters")
    doc = plan_gripper(part, GripperParams(samples=40, top=1)).to_json()
    g = doc["grasps"][0]
    desc = DATA / "franka.json"

    def errors(**change):
        return check_grasp(dict(g, **change), path, desc, 1.0, 0.5, 1e-3 * part.length)

    assert errors() == []
    T = np.array(g["pose"])
    sunk = T.copy()
    sunk[:3, 3] += 0.3 * part.length * T[:3, 2]  # pushed further along the approach
    assert any("intersects" in e for e in errors(pose=sunk.tolist()))
    skew = T.copy()
    skew[:3, 0] *= 1.01
    assert "pose is not a rigid transform" in errors(pose=skew.tolist())
    moved = [dict(c) for c in g["contacts"]]
    moved[0]["point"] = (np.array(moved[0]["point"]) + 0.01 * part.length * T[:3, 0]).tolist()
    assert any("off the surface" in e or "not on its pad" in e for e in errors(contacts=moved))
    slid = [dict(c) for c in g["contacts"]]  # slid along its pad: the line tilts
    slid[0]["point"] = (np.array(slid[0]["point"]) + 0.01 * part.length * T[:3, 1]).tolist()
    assert any("friction cone" in e for e in check_grasp(dict(g, contacts=slid), path, desc,
                                                         1.0, 1e-4, 0.0))


@pytest.mark.parametrize("kw", [dict(mass=-1.0), dict(mass=0.0), dict(min_margin=-1.0),
                                dict(mu=1e9), dict(density=-5.0), dict(mass=1.0, density=2.0),
                                dict(table=float("nan")), dict(top=-3), dict(top="3"),
                                dict(samples=10**9), dict(edges=10**5), dict(seed=-1),
                                dict(gravity="down"), dict(gravity=(0.0, 0.0, 0.0))])
def test_gripper_params_out_of_range_are_refused_by_name(kw):
    """The Python API holds GripperParams to the command line's ranges: a negative mass
    planned 'too heavy', a billion samples ran out of memory; now each is an InputError
    naming its field."""
    from synth.errors import InputError

    with pytest.raises(InputError) as e:
        GripperParams(**kw)
    assert str(e.value).split(":")[0] in kw or "not both" in str(e.value)


def test_plan_gripper_names_a_wrong_argument():
    from synth.errors import InputError

    with pytest.raises(InputError, match="part: expected a synth.Part"):
        plan_gripper(None, GripperParams())
    part = load_part(ROOT / "meshes" / "cube.stl", units="cm")
    with pytest.raises(InputError, match="params: expected a synth.GripperParams"):
        plan_gripper(part, {"samples": 40})
