"""``synth plan`` and ``synth rank`` end to end through the command line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

MESHES = Path(__file__).resolve().parent.parent / "meshes"


def synth(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "synth", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd)


def test_plan_writes_json_png_glb(tmp_path, capsys):
    proc = synth("plan", MESHES / "bracket.stl", "--evals", "10000", "--top", "3", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "form" in proc.stdout and "d*" in proc.stdout
    doc = json.loads((tmp_path / "bracket.grasps.json").read_text())
    assert len(doc["grasps"]) == 3 and doc["params"]["evals"] == 10000
    png = (tmp_path / "bracket.grasps.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    scene = trimesh.load(tmp_path / "bracket.grasps.glb")
    assert "part" in scene.geometry and "tip_0" in scene.geometry
    # units unknown (no --units): every geometry says so alike, none is read as metres
    assert {g.units for g in scene.geometry.values()} == {"none"}
    assert scene.metadata["synth"]["units"] is None
    _fingers_drawn_as_planned(scene, doc["grasps"][0]["fingers"], MESHES / "bracket.stl")
    _outputs_are_not_parts(tmp_path, doc["run_id"], capsys)


def _outputs_are_not_parts(folder, run_id, capsys):
    """synth's own outputs are not parts: db build on the folder plans the mesh beside them
    but not the scene (a part with its fingers), and plan refuses the scene by name."""
    import shutil

    from synth.cli import main
    from synth.database import build_database
    from tests.db_support import PLANNER

    shutil.copy(MESHES / "bracket.stl", folder / "bracket.stl")
    report = build_database([folder], folder / "g.sqlite", {"evals": 1000}, workers=0,
                            planner=PLANNER, quiet=True)
    assert (report.found, report.done) == (1, 1)
    assert [Path(p).name for p in report.scenes] == ["bracket.grasps.glb"]
    assert "not planned: 1 scenes synth plan wrote" in report.summary()
    assert main(["plan", str(folder / "bracket.grasps.glb"), "--no-files"]) == 2
    line = capsys.readouterr().err.strip()
    assert f"a scene synth plan wrote (run {run_id})" in line and "not a part" in line


def _fingers_drawn_as_planned(scene, fingers, mesh_path):
    """Every finger body of the GLB is the capsule the JSON describes (axis from the tip
    centre along the approach for the body length), and it lies outside every body of the
    part: no triangle of it meets a triangle of the mesh file (FCL, exact triangle tests)
    and none of its points is inside (a body wholly inside meets no triangle)."""
    import fcl

    def bvh(mesh):
        model = fcl.BVHModel()
        model.beginModel(len(mesh.vertices), len(mesh.faces))
        model.addSubModel(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int32))
        model.endModel()
        return fcl.CollisionObject(model, fcl.Transform())

    part = trimesh.load(mesh_path)
    bodies = part.split(only_watertight=False)
    tips, approach = np.array(fingers["tip_centers"]), np.array(fingers["approach"])
    L, rb = fingers["body_length"], fingers["body_radius"]
    atol = 1e-6 * np.linalg.norm(np.ptp(part.vertices, axis=0))  # the GLB stores float32
    for i, (c, a) in enumerate(zip(tips, approach, strict=True)):
        body = scene.geometry[f"finger_{i}"]
        v = body.vertices - c
        along = v @ a
        off_axis = np.linalg.norm(v - np.clip(along, 0, L)[:, None] * a, axis=1)
        assert np.allclose(off_axis, rb, rtol=0, atol=atol), f"finger {i}: not the JSON's capsule"
        assert np.allclose([along.min(), along.max()], [-rb, L + rb], rtol=0, atol=atol), i
        for b in bodies:
            hit = fcl.collide(bvh(body), bvh(b), fcl.CollisionRequest(), fcl.CollisionResult())
            assert not hit, f"finger {i}'s body crosses the part's surface"
            assert not b.contains(body.vertices[:1]).any(), f"finger {i}'s body is inside"


def test_plan_json_to_stdout_and_sphere_exit_status(tmp_path):
    proc = synth("plan", MESHES / "sphere.stl", "--evals", "2000", "--json", "--no-files",
                 cwd=tmp_path)
    assert proc.returncode == 1  # nothing found
    doc = json.loads(proc.stdout)
    assert doc["grasps"] == [] and "rotate" in doc["message"]
    assert list(tmp_path.iterdir()) == []


def _one_line_error(proc, code=2):
    assert proc.returncode == code, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("synth: error: ")
    return lines[0]


def test_plan_bad_input(tmp_path):
    assert "no such file" in _one_line_error(synth("plan", tmp_path / "missing.stl"))
    junk = tmp_path / "junk.stl"
    junk.write_bytes(np.random.default_rng(0).bytes(900))
    assert "junk.stl" in _one_line_error(synth("plan", junk, "--no-files"))
    msg = _one_line_error(synth("plan", MESHES / "cube.stl", "--contacts", "4", "--no-files"))
    assert "from 7 to 64 without friction" in msg and "--mu > 0" in msg


def test_rank_end_to_end(tmp_path):
    plan = synth("plan", MESHES / "cube.stl", "--evals", "2000", "--top", "2",
                 "--no-files", "--quiet")
    assert plan.returncode == 0
    proc = synth("plan", MESHES / "cube.stl", "--evals", "2000", "--top", "2", "--quiet",
                 "--out", tmp_path / "g.json", "--png", tmp_path / "g.png",
                 "--glb", tmp_path / "g.glb")
    doc = json.loads((tmp_path / "g.json").read_text())
    cands = [{"name": f"g{i}", "points": g["points"]} for i, g in enumerate(doc["grasps"])]
    cands.append({"name": "far", "points": [[9, 9, 9]] + doc["grasps"][0]["points"][1:]})
    f = tmp_path / "c.json"
    f.write_text(json.dumps(cands))
    out = tmp_path / "ranked.json"
    proc = synth("rank", MESHES / "cube.stl", f, "--out", out)
    assert proc.returncode == 0, proc.stderr
    ranked = json.loads(out.read_text())["candidates"]
    assert [c["status"] for c in ranked] == ["ok", "ok", "misses the part"]
    assert "candidate 2 (far): point 0 is" in ranked[2]["reason"]
    assert " mesh units from the surface" in ranked[2]["reason"]  # the file says no unit
    assert ranked[0]["d_star"] == doc["grasps"][0]["d_star"] or abs(
        ranked[0]["d_star"] - doc["grasps"][0]["d_star"]) < 1e-7
    bad = tmp_path / "bad.json"
    bad.write_text('[{"name": "x"}]')
    assert "missing field 'points'" in _one_line_error(synth("rank", MESHES / "cube.stl", bad))


def test_internal_error_is_one_line_with_its_own_exit_status(monkeypatch, capsys):
    """A failure inside synth is never reported as bad input and never as a traceback."""
    import synth.plan.search as search
    from synth.cli import EXIT_INTERNAL, main
    from synth.errors import InputError, InternalError

    def broken(*args, **kwargs):
        raise InputError("points: 1 of 600 lie farther than 1e-08 from the surface")

    monkeypatch.setattr(search, "sample_contacts", broken)
    with pytest.raises(InternalError, match="planner failed"):
        search.plan_part(synth_part(), search.PlanParams(evals=500))
    code = main(["plan", str(MESHES / "cube.stl"), "--no-files", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == EXIT_INTERNAL == 3 and len(err) == 1
    assert err[0].startswith("synth: internal error: ") and "bug in synth" in err[0]
    monkeypatch.setattr(search, "sample_contacts", lambda *a, **k: 1 / 0)
    assert main(["plan", str(MESHES / "cube.stl"), "--no-files", "--quiet"]) == 3
    assert "ZeroDivisionError" in capsys.readouterr().err
    monkeypatch.setenv("SYNTH_TRACEBACK", "1")
    assert main(["plan", str(MESHES / "cube.stl"), "--no-files", "--quiet"]) == 3
    assert "Traceback" in capsys.readouterr().err


def synth_part():
    from synth import load_part

    return load_part(MESHES / "cube.stl")


def test_plan_json_reports_bodies_and_repairs(tmp_path):
    out = tmp_path / "g.json"
    proc = synth("plan", MESHES / "bracket.stl", "--evals", "2000", "--no-files")
    assert proc.returncode == 0
    proc = synth("plan", MESHES / "bracket.stl", "--evals", "2000", "--out", out, "--png",
                 tmp_path / "g.png", "--glb", tmp_path / "g.glb", "--quiet")
    mesh = json.loads(out.read_text())["mesh"]
    assert mesh["repairs"] == [] and mesh["dropped"] == [] and len(mesh["bodies"]) == 1
    assert mesh["bodies"][0]["closed"] and mesh["precision"] > 0
    assert len(mesh["center_mass"]) == 3 and mesh["volume"] > 0


def test_plan_and_rank_report_tolerance(tmp_path):
    out = tmp_path / "g.json"
    proc = synth("plan", MESHES / "cube.stl", "--units", "dm", "--evals", "3000", "--top", "3",
                 "--regions", "--quiet", "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert "tolerance" in proc.stdout.splitlines()[0]
    doc = json.loads(out.read_text())
    tol = [g["tolerance"] for g in doc["grasps"]]
    assert all(t is not None and t >= 0 for t in tol)
    # the GLB's region patches are the JSON's polygons, lifted off the surface by 0.1% of L
    scene = trimesh.load(tmp_path / "g.glb")
    best = doc["grasps"][0]
    lift = 1e-3 * doc["mesh"]["length"]
    patches = 0
    for i, (poly, n) in enumerate(zip(best["contact_regions"]["polygons"], best["normals"],
                                      strict=True)):
        if len(poly) < 3:
            continue
        patches += 1
        want = np.array(poly) - lift * np.array(n)
        got = scene.geometry[f"region_{i}"].vertices
        assert np.allclose(np.sort(got, axis=0), np.sort(want, axis=0), atol=1e-6)
    assert patches > 0
    cands = [{"name": f"g{i}", "points": g["points"]} for i, g in enumerate(doc["grasps"])]
    f = tmp_path / "c.json"
    f.write_text(json.dumps(cands))
    ranked_file = tmp_path / "ranked.json"
    proc = synth("rank", MESHES / "cube.stl", f, "--units", "dm", "--rank-by", "tolerance",
                 "--out", ranked_file, "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "tolerance" in proc.stdout.splitlines()[0]
    ranked = json.loads(ranked_file.read_text())["candidates"]
    got = [c["tolerance"] for c in ranked]
    assert got == sorted(got, reverse=True)
    assert sorted(got) == pytest.approx(sorted(tol))  # the same grasps, the same tolerances
    floor = 1.5 * max(got)
    proc = synth("rank", MESHES / "cube.stl", f, "--units", "dm", "--min-tolerance", floor,
                 "--out", ranked_file)
    assert proc.returncode == 0, proc.stderr
    assert f"{len(got)} candidates: 0 ok, {len(got)} tolerance," in proc.stderr
    ranked = json.loads(ranked_file.read_text())["candidates"]
    assert [c["status"] for c in ranked] == ["tolerance"] * len(got)
    assert all("below --min-tolerance" in c["reason"] for c in ranked)
    plain = synth("plan", MESHES / "cube.stl", "--evals", "3000", "--top", "1", "--quiet",
                  "--no-files")
    assert "tolerance" not in plain.stdout


def test_rank_reads_a_plan_whose_fingertips_touch_several_faces(tmp_path):
    """A --fingers plan puts one fingertip in a groove or an inside corner, touching two or
    three faces: rank groups those contacts into that one finger (their tips coincide), so
    it finds the plan's grasps collision free with the plan's d*, where it saw two fingers
    in one place before."""
    out = tmp_path / "f.json"
    plan = synth("plan", MESHES / "bracket.stl", "--units", "dm", "--fingers", "auto",
                 "--evals", "3000", "--top", "4", "--out", out, "--quiet")
    assert plan.returncode == 0, plan.stderr
    doc = json.loads(out.read_text())
    shared = [g for g in doc["grasps"]
              if len(set(g["fingers"]["contact_finger"])) < len(g["points"])]
    assert shared  # the plan did put a tip on more than one face
    proc = synth("rank", MESHES / "bracket.stl", out, "--units", "dm", "--json")
    assert proc.returncode == 0, proc.stderr
    ranked = json.loads(proc.stdout)["candidates"]
    assert {c["status"] for c in ranked} == {"ok"}, [c.get("reason") for c in ranked]
    assert sorted(round(c["d_star"], 9) for c in ranked) == \
        sorted(round(g["d_star"], 9) for g in doc["grasps"])



def test_the_table_gives_the_squeeze_in_newtons_with_a_mass_and_the_margin_with_a_grip(capsys):
    """--mass adds the least squeeze in newtons (N/weight times the part's weight, its mass
    times g), --grip too the margin (the grip over that squeeze); without a mass neither."""
    from synth.cli import main

    def table(*extra):
        assert main(["plan", str(MESHES / "cube.stl"), "--units", "dm", "--no-files",
                     "--quiet", "--top", "3", "--evals", "3000", *extra]) == 0
        head, *lines = capsys.readouterr().out.strip().splitlines()
        names = head.replace("squeeze N", "squeeze_N").split()
        return names, [dict(zip(names, line.split()[:len(names) - 2], strict=False))
                       for line in lines if line.split()[1][0].isdigit()]  # not the summary

    names, _ = table()
    assert "squeeze_N" not in names and "margin" not in names
    names, rows = table("--mass", "0.2")
    assert names[5:7] == ["N/weight", "squeeze_N"] and "margin" not in names
    for row in rows:
        # to the cells' rounding: 0.005 N for two decimals, 0.0005 weights times 1.96 N
        assert float(row["squeeze_N"]) == pytest.approx(
            float(row["N/weight"]) * 0.2 * 9.81, abs=0.005 + 0.0005 * 0.2 * 9.81)
    names, rows = table("--mass", "0.2", "--grip", "5")
    assert names[5:8] == ["N/weight", "squeeze_N", "margin"]
    for row in rows:
        assert float(row["margin"]) == pytest.approx(5 / float(row["squeeze_N"]), rel=1e-2)



def test_a_gripper_table_shows_the_margin_and_squeeze_with_a_mass_only(capsys):
    """A gripper plan without the part's mass has no margin nor squeeze in newtons: no
    columns of dashes, nor 'margin -' in the picture's titles; with a mass, both columns."""
    from synth.cli.gripper import format_gripper_table
    from synth.part import load_part
    from synth.plan.gripper import GripperParams, plan_gripper

    part = load_part(MESHES / "cube.stl", units="cm")
    light = plan_gripper(part, GripperParams(samples=60, top=2))
    weighed = plan_gripper(part, GripperParams(samples=60, top=2, mass=0.02))
    head = format_gripper_table(light.grasps, 10.0).splitlines()[0].split()
    assert "margin" not in head and "squeeze" not in head and "N/weight" in head
    head, *rows = format_gripper_table(weighed.grasps, 10.0).splitlines()
    assert head.split()[3:6] == ["margin", "squeeze", "N"]
    assert [float(r.split()[2]) for r in rows] == [round(g.margin, 2) for g in weighed.grasps]


def test_every_malformed_candidate_of_rank_has_its_own_line(tmp_path, capsys):
    """A NaN (the reader's) and a set of six contacts (the ranking's) are both malformed:
    each gets its own error line, in file order, and the exit status is 2 (the six-contact
    set was in the table only, with exit status 0 when it was the only one)."""
    from synth.cli import main

    seven = [[0.5, 0.1, 0.1], [-0.5, 0.1, 0.1], [0.1, 0.5, 0.1], [0.1, -0.5, 0.1],
             [0.1, 0.1, 0.5], [0.1, 0.1, -0.5], [0.5, -0.2, -0.2]]
    f = tmp_path / "c.json"
    f.write_text(json.dumps([{"name": "six", "points": seven[:6]},
                             {"name": "good", "points": seven}]))
    assert main(["rank", str(MESHES / "cube.stl"), str(f), "--units", "dm", "--quiet"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"synth: error: {f}: candidate 0 (six): 6 contacts are too few: closure takes at "
        "least 7 without friction, 3 with it (--mu)"]
    broken = json.dumps({"name": "nan", "points": seven[:6] + [[0.5, -0.2, "NaN"]]})
    f.write_text(f.read_text()[:-1] + ", " + broken.replace('"NaN"', "NaN") + "]")
    assert main(["rank", str(MESHES / "cube.stl"), str(f), "--units", "dm", "--quiet"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(": ")[3] for line in lines] == ["candidate 0 (six)", "candidate 2 (nan)"]
