"""``synth plan``, ``rank`` and ``score`` on hostile input: every failure one line with the
right exit status, limits stated in --help, outputs kept together and named by their run."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from synth.cli import EXIT_FAILED, EXIT_INPUT, main
from synth.part import load_part
from synth.plan import params as lim
from tests.cli_support import BIG, CUBE_FC, earlier_output

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture()
def box(tmp_path):
    path = tmp_path / "box.stl"
    trimesh.creation.box().export(path)
    return path


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _refused(capsys, *argv, code=EXIT_INPUT):
    """Run; the command must fail with ``code`` and exactly one line, no traceback."""
    got, _, err = _run(capsys, *argv)
    assert got == code, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("synth: error: "), err
    return lines[0]


def _files(folder):
    return {p.relative_to(folder): p.read_bytes() for p in Path(folder).rglob("*") if p.is_file()}


# -- item 1 and 2: numeric options -------------------------------------------------------------

PLAN_REFUSED = [
    (["--seed", "-1"], "--seed: expected an integer from 0 to 2**63 - 1"),
    (["--seed", BIG], "--seed"),
    (["--evals", "1000000000000"], "--evals: expected an integer from 100 to 10,000,000"),
    (["--evals", "99"], "--evals"),
    (["--contacts", "1000"], "--contacts: expected an integer from 7 to 64 without friction"),
    (["--contacts", "2", "--mu", "0.5"], "--contacts: expected an integer from 3 to 64 with "
                                         "friction (--mu > 0), got 2"),
    (["--mu", "1e308"], "--mu: expected a number in [0, 100]"),
    (["--mu", "nan"], "--mu"),
    (["--mu", "-0.5"], "--mu"),
    (["--min-d-star", "nan"], "--min-d-star: expected a number in [0, 1]"),
    (["--min-d-star", "2"], "--min-d-star: expected a number in [0, 1]"),
    (["--top", "0"], "--top: expected an integer from 1 to 1,000"),
    (["--top", BIG], "--top"),
    (["--time", "0"], "--time"),
    (["--time", "inf"], "--time"),
    (["--table", "1e300"], "--table"),
    (["--finger-radius", "-1"], "--finger-radius"),
    (["--body-length", "inf"], "--body-length"),
    (["--body-radius", "0"], "--body-radius"),
    (["--body-radius", "1", "--units", "m"], "(--body-radius): expected at most the tip "
                                             "radius (tip_radius, --finger-radius) 0.0433013, "
                                             "got 1"),
    (["--approach-cone", "90"], "--approach-cone"),
    (["--sharp-angle", "0"], "--sharp-angle"),
    (["--fingers", "13"], "--fingers: expected an integer from 2 to 12"),
    (["--fingers", "two"], "--fingers"),
    (["--seed", "abc"], "argument --seed: invalid int value: 'abc'"),
    (["--evals", "1e4"], "argument --evals: invalid int value"),
    (["--no-such-option"], "unrecognized arguments"),
]


@pytest.mark.parametrize("extra, message", PLAN_REFUSED)
def test_plan_refuses_bad_options_before_any_work(box, tmp_path, capsys, extra, message):
    out = tmp_path / "o.json"
    line = _refused(capsys, "plan", box, "--out", out, *extra)
    assert message in line
    assert len(line) < 250
    assert not out.exists() and not (tmp_path / "o.png").exists()


@pytest.mark.parametrize("argv, message", [
    (["score", "{c}", "--edges", "100000", "--mu", "0.5"],
     "--edges: expected an integer from 3 to 64"),
    (["score", "{c}", "--edges", "2"], "--edges"),
    (["score", "{c}", "--top", "-3"], "--top: expected an integer from 0 to 1,000"),
    (["score", "{c}", "--mu", "inf"], "--mu"),
    (["score", "{c}", "--mu", "1e308"], "--mu: expected a number in [0, 100]"),
    (["score", "{c}", "--out", "{tmp}/scores.txt"],
     "--out: expected a file name ending in .json"),
    (["score", "{c}", "--json", "{tmp}/scores.json"],
     "--json takes no file name: it prints the JSON, as every command's --json does; "
     "write it to a file with --out"),
    (["rank", "{box}", "{c}", "--max-distance", "-1"],
     "--max-distance: expected a number in [0, 1e+15]"),
    (["rank", "{box}", "{c}", "--max-distance", "nan"], "--max-distance"),
    (["rank", "{box}", "{c}", "--mu", "1e308"], "--mu"),
    (["rank", "{box}", "{c}", "--finger-radius", "0"], "--finger-radius"),
    (["rank", "{box}", "{c}", "--out", "{tmp}/ranked.csv"],
     "--out: expected a file name ending in .json"),
    # a grip without the part's weight gives no margin: refused, not ignored
    (["rank", "{box}", "{c}", "--grip", "10"], "--grip: a margin is the grip over the least "
     "squeeze in newtons, which needs the part's weight: add --mass KG or --density KG/M3"),
    (["plan", "{box}", "--grip", "10", "--no-files"], "--grip: a margin is the grip"),
    # an option that excludes another is refused even when the other is typed at its default
    (["plan", "{box}", "--fingers", "3", "--contacts", "7", "--no-files"],
     "give --fingers or --contacts, not both"),
    (["plan", "{box}", "--gripper", "franka", "--units", "cm", "--contacts", "7", "--no-files"],
     "--contacts applies to point-finger grasps, not to --gripper"),
    (["plan", "{box}", "--gripper", "franka", "--units", "cm", "--evals", "50000",
      "--no-files"], "--evals applies to point-finger grasps, not to --gripper"),
])
def test_rank_and_score_refuse_bad_options(box, tmp_path, capsys, argv, message):
    c = tmp_path / "c.json"
    c.write_text(json.dumps([CUBE_FC]))
    argv = [a.format(c=c, box=box, tmp=tmp_path) for a in argv]
    assert message in _refused(capsys, *argv)


def test_zero_top_means_all_rows(tmp_path, capsys):
    c = tmp_path / "c.json"
    c.write_text(json.dumps([CUBE_FC] * 25))
    code, out, _ = _run(capsys, "score", c, "--top", "0")
    assert code == 0 and len(out.strip().splitlines()) == 26


@pytest.mark.parametrize("command, limits", [
    ("plan", ["7 to 64", "[0, 100]", "100 to 10,000,000", "in [0, 1]", "0 to 2**63 - 1",
              "1 to 1,000", "(0, 180)", "[0, 90)", ".json", ".png", ".glb", "run id"]),
    ("rank", ["[0, 100]", "[0, 1e+15]", ".json"]),
    ("score", ["3 to 64", "[0, 100]", "1 to 1,000, or 0 for all", ".json"]),
])
def test_help_states_every_limit(capsys, command, limits):
    with pytest.raises(SystemExit) as stop:
        main([command, "--help"])
    assert stop.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for limit in limits:
        assert limit in text, limit


def test_limits_are_module_constants():
    assert (lim.MAX_CONTACTS, lim.MIN_EDGES, lim.MAX_EDGES) == (64, 3, 64)
    assert (lim.MIN_EVALS, lim.MAX_EVALS, lim.MAX_MU, lim.MAX_TOP) == (100, 10_000_000, 100, 1000)
    assert lim.MAX_SEED == 2**63 - 1 and lim.MAX_LENGTH == 1e15
    lim.PlanParams(contacts=lim.MAX_CONTACTS, mu=lim.MAX_MU, evals=lim.MAX_EVALS,
                   edges=lim.MAX_EDGES, seed=lim.MAX_SEED, top=lim.MAX_TOP, min_d_star=1.0)


# -- item 1: candidate files -------------------------------------------------------------------

def _npz(path, **arrays):
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    return path


P3 = np.array([CUBE_FC["points"]] * 3, float)
N3 = np.array([CUBE_FC["normals"]] * 3, float)


def _bad_candidate_files(tmp_path):
    """(file, words the one error line must hold) for every kind of broken candidate file."""
    t = tmp_path
    (t / "mu400.json").write_text(
        json.dumps([dict(CUBE_FC, mu=0)]).replace('"mu": 0', f'"mu": {BIG}'))
    (t / "pt400.json").write_text(
        json.dumps([CUBE_FC]).replace("0.5, 0.1, 0.1", f"{BIG}, 0.1, 0.1", 1))
    (t / "int5000.json").write_text('[{"points": [[' + "9" * 5000 + ', 0, 0]]}]')
    (t / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    (t / "huge.json").write_text(json.dumps([dict(CUBE_FC, points=(np.array(
        CUBE_FC["points"]) * 1e200).tolist())]))
    (t / "random.json").write_bytes(np.random.default_rng(1).bytes(600))
    (t / "random.npz").write_bytes(np.random.default_rng(2).bytes(600))
    np.save(t / "array.npy", P3)
    (t / "array.npy").rename(t / "array.npz")
    return [
        (t / "mu400.json", ["candidate 0", "'mu'", "from 0 to 100"]),
        (t / "pt400.json", ["candidate 0", "too large"]),
        (t / "int5000.json", ["int5000.json", "not a readable JSON file"]),
        (t / "deep.json", ["deep.json", "not a readable JSON file", "RecursionError"]),
        (t / "huge.json", ["candidate 0", "magnitude 5e+199", "1e+15"]),
        (t / "random.json", ["random.json", "not a readable JSON file"]),
        (t / "random.npz", ["random.npz", "not a readable NPZ file"]),
        (t / "array.npz", ["array.npz", "one bare array"]),
        (_npz(t / "names.npz", points=P3, normals=N3, names=np.array(["a"])),
         ["names.npz", "'names' must have shape (3,)"]),
        (_npz(t / "mu.npz", points=P3, normals=N3, mu=np.array([0.1, 0.2])),
         ["mu.npz", "'mu' must be one number or shape (3,)"]),
        (_npz(t / "mu_big.npz", points=P3[:1], normals=N3[:1], mu=np.array(1e308)),
         ["candidate 0", "from 0 to 100"]),
        (_npz(t / "strings.npz", points=P3, normals=np.array([["x"] * 7] * 3)),
         ["strings.npz", "'normals' must be numbers"]),
    ]


def test_bad_candidate_files_one_line_each(box, tmp_path, capsys):
    for path, words in _bad_candidate_files(tmp_path):
        before = _files(tmp_path)
        for argv in (["score", path, "--out", tmp_path / "s.json"],
                     ["rank", box, path, "--out", tmp_path / "r.json", "--quiet"]):
            line = _refused(capsys, *argv)
            for w in words:
                assert w in line, (argv, line)
            assert len(line) < 450
        assert _files(tmp_path) == before


def test_rank_with_no_usable_candidate_writes_nothing(box, tmp_path, capsys):
    far = tmp_path / "far.json"
    far.write_text(json.dumps([{"name": "far", "points": [[9, 9, 9]] * 7}] * 2))
    out = tmp_path / "r.json"
    before = earlier_output(out)
    line = _refused(capsys, "rank", box, far, "--out", out, "--quiet")
    assert "no candidate could be used" in line and "(and 1 more unusable)" in line
    assert out.read_bytes() == before


# -- item 1: mesh files ------------------------------------------------------------------------

@pytest.mark.parametrize("ext", ["stl", "obj", "ply", "off", "glb", "gltf", "3mf"])
def test_random_bytes_as_mesh(tmp_path, capsys, ext):
    for seed in range(3):
        mesh = tmp_path / f"junk{seed}.{ext}"
        mesh.write_bytes(np.random.default_rng(seed).bytes(300 + 200 * seed))
        assert mesh.name in _refused(capsys, "plan", mesh, "--no-files", "--quiet")


def test_huge_coordinates_are_refused_naming_the_file(tmp_path, capsys):
    mesh = trimesh.creation.box()
    mesh.vertices *= 1e200
    path = tmp_path / "huge.obj"
    mesh.export(path)
    line = _refused(capsys, "plan", path, "--no-files", "--evals", "200")
    assert "huge.obj" in line and "magnitude" in line and "1e+15" in line
    big = trimesh.creation.box()
    big.vertices *= 1e14  # large, but within the limit
    assert load_part(big).length == pytest.approx(np.sqrt(3) * 1e14)


def test_face_naming_a_missing_vertex_is_refused(tmp_path, capsys):
    data = bytearray(trimesh.creation.box().export(file_type="ply"))
    first_face = data.index(b"end_header\n") + len(b"end_header\n") + 8 * 12
    data[first_face + 2] = 1  # the face's first vertex index becomes 256 + index
    path = tmp_path / "corrupt.ply"
    path.write_bytes(bytes(data))
    line = _refused(capsys, "plan", path, "--no-files", "--quiet")
    assert "corrupt.ply" in line and "refers to vertex" in line and "8 vertices" in line


# -- item 3: output files ----------------------------------------------------------------------

def test_png_suffix_is_refused_before_anything_is_written(box, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    before = _files(tmp_path)
    line = _refused(capsys, "plan", box, "--png", "x.xyz", "--evals", "200")
    assert "--png: expected a file name ending in .png, got 'x.xyz'" in line
    assert _files(tmp_path) == before


def test_missing_output_folder_fails_before_planning(box, tmp_path, capsys, monkeypatch):
    import synth.plan

    monkeypatch.setattr(synth.plan, "plan_part", lambda *a, **k: pytest.fail("planned"))
    line = _refused(capsys, "plan", box, "--out", tmp_path / "nowhere" / "x.json",
                    code=EXIT_FAILED)
    assert "no such folder" in line


def _png_run_id(path):
    return Image.open(path).text["synth.run_id"]


def _glb_extras(path):
    data = Path(path).read_bytes()
    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n])["scenes"][0]["extras"]


def test_outputs_follow_out_and_share_the_run_id(box, tmp_path, capsys, monkeypatch):
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    (tmp_path / "sub").mkdir()
    out = tmp_path / "sub" / "x.json"
    code, stdout, err = _run(capsys, "plan", box, "--out", out, "--evals", "200", "--top", "2",
                             "--units", "mm", "--seed", "3")
    assert code == 0, err
    assert list(cwd.iterdir()) == []
    assert sorted(p.name for p in out.parent.iterdir()) == ["x.glb", "x.json", "x.png"]
    doc = json.loads(out.read_text())
    run_id = doc["run_id"]
    assert len(run_id) == 25 and run_id in stdout
    assert doc["params"]["seed"] == 3 and doc["params"]["evals"] == 200
    assert _png_run_id(out.with_suffix(".png")) == run_id
    scene = trimesh.load(out.with_suffix(".glb"))
    assert scene.metadata["synth"]["run_id"] == run_id
    assert scene.metadata["synth"]["params"] == doc["params"]
    assert _glb_extras(out.with_suffix(".glb"))["synth"]["grasp_rank"] == 1
    # a second run is another run
    assert main(["plan", str(box), "--out", str(out), "--evals", "200", "--quiet"]) == 0
    again = json.loads(out.read_text())["run_id"]
    assert again != run_id and _png_run_id(out.with_suffix(".png")) == again


def test_files_of_a_failed_run_are_left_as_they_were(box, tmp_path, capsys):
    import synth.plan

    paths = [tmp_path / n for n in ("g.json", "g.png", "g.glb")]
    before = [earlier_output(p) for p in paths]

    def disk_full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(synth.plan, "export_glb", disk_full)
        line = _refused(capsys, "plan", box, "--out", paths[0], "--evals", "200", "--units",
                        "mm", code=EXIT_FAILED)
    assert "No space left on device" in line and line.startswith(f"synth: error: {paths[2]}:")
    assert [p.read_bytes() for p in paths] == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["box.stl", "g.glb", "g.json", "g.png"]


def test_a_disk_full_while_writing_the_glb_names_the_glb(box, tmp_path, capsys):
    """The error of the real write (not a stand-in for the exporter) names the target, not a
    hidden temporary file, and nothing is replaced."""
    paths = [tmp_path / n for n in ("g.json", "g.png", "g.glb")]
    before = [earlier_output(p) for p in paths]
    real = Path.write_bytes

    def full_for_glb(self, data):
        if self.suffix == ".glb":
            raise OSError(28, "No space left on device")
        return real(self, data)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Path, "write_bytes", full_for_glb)
        line = _refused(capsys, "plan", box, "--out", paths[0], "--evals", "200", "--units",
                        "mm", code=EXIT_FAILED)
    assert line.startswith(f"synth: error: {paths[2]}: could not be written"), line
    assert ".part" not in line
    assert [p.read_bytes() for p in paths] == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["box.stl", "g.glb", "g.json", "g.png"]


# -- one vocabulary (issue 22) ---------------------------------------------------------------

def _options(*path):
    """Option strings and actions of the subcommand ``path`` (``("db", "build")``)."""
    import argparse

    from synth.cli import build_parser

    parser = build_parser()
    for word in path:
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = sub.choices[word]
    return {s: a for a in parser._actions for s in a.option_strings}


def test_one_vocabulary_across_commands():
    from synth.plan.params import RANK_BY

    for path in (("plan",), ("rank",), ("db", "top"), ("db", "build")):
        opts = _options(*path)
        assert set(RANK_BY) <= set(opts["--rank-by"].choices), path
        assert "--top" in opts, path
    assert "--top" in _options("score") and "-k" in _options("db", "top")  # -k: old spelling
    for path in (("plan",), ("rank",), ("score",), ("db", "build")):
        assert {"--mu", "--edges"} <= set(_options(*path)), path
    for path in (("plan",), ("rank",), ("score",), ("db", "info"), ("db", "top")):
        assert _options(*path)["--json"].nargs in (0, "?"), path  # prints, never a path
    assert "--out" in _options("score")


def test_db_build_takes_every_planning_option_of_plan(box, tmp_path, capsys):
    """A database holds what plan gives for the same part: every option of plan that is
    not about its output files (simulating the grasps found, ``--sim``, too) is an option of
    db build, and reaches the planner."""
    output = {"--out", "--png", "--glb", "--no-files", "--json", "--quiet", "-h", "--help"}
    missing = set(_options("plan")) - output - set(_options("db", "build"))
    assert not missing, missing
    db = tmp_path / "g.sqlite"
    code, _, err = _run(capsys, "db", "build", box, "--out", db, "--workers", "0", "--quiet",
                        "--evals", "100", "--top", "1", "--units", "dm", "--table", "-5",
                        "--sharp-angle", "40", "--edges", "6", "--body", "largest",
                        "--body-length", "0.3", "--approach-cone", "10", "--min-d-star", "0.01")
    assert code == 0, err
    from synth.database import GraspDatabase

    with GraspDatabase(db) as d:
        mesh = d.mesh("box")
        params = d.info().params
    assert mesh.units == "decimeters" and mesh.status == "done"
    assert (params["units"], params["support_z"], params["sharp_angle"], params["edges"],
            params["body_length"], params["approach_cone"]) == ("dm", -5.0, 40.0, 6, 0.3, 10.0)
    code, _, err = _run(capsys, "db", "build", box, "--out", db, "--seed", "-1")
    assert code == 2 and "--seed: expected an integer from 0 to 2**63 - 1" in err
    assert "(see 'synth db build --help')" in err


# -- partial failures and exit statuses (issue 22) ---------------------------------------------

def test_rank_reports_a_malformed_candidate_and_ranks_the_rest(box, tmp_path, capsys):
    """As synth score does: the NaN candidate gets its own error line and status 2, the
    others are ranked and written; a candidate never scored shows no score (not 0, not
    'force')."""
    nan = dict(CUBE_FC, name="nan", points=[["NaN", 0.1, 0.1]] + CUBE_FC["points"][1:])
    far = dict(CUBE_FC, name="far", points=[[5.0, 0.1, 0.1]] + CUBE_FC["points"][1:])
    c = tmp_path / "c.json"
    c.write_text(json.dumps([far, nan, CUBE_FC]).replace('"NaN"', "NaN"))
    out = tmp_path / "r.json"
    code, stdout, err = _run(capsys, "rank", box, c, "--units", "mm", "--out", out)
    assert code == 2
    errors = [line for line in err.splitlines() if line.startswith("synth: error: ")]
    assert len(errors) == 1 and "candidate 1 (nan)" in errors[0] and "finite" in errors[0]
    rows = json.loads(out.read_text())["candidates"]
    assert [(r["name"], r["status"], r["index"]) for r in rows] == [
        ("good", "ok", 2), ("far", "misses the part", 0), ("nan", "malformed", 1)]
    assert rows[0]["d_star"] == pytest.approx(0.5) and rows[0]["closure"] == "form"
    for r in rows[1:]:
        assert r["d_star"] is None and r["closure"] is None and r["conditioning"] is None
    *table, wrote = stdout.splitlines()
    assert wrote == f"wrote {out}"
    assert "0.50000" in table[1]
    for line in table[2:]:
        assert "0.00000" not in line and "force" not in line
        assert line.split()[2:5] == ["-", "-", "-"]


def _plan_file(path, mesh, units="decimeters"):
    """A plan file (``synth.grasps``) of CUBE_FC, made on ``mesh`` in ``units``."""
    import hashlib

    path.write_text(json.dumps({
        "format": "synth.grasps", "version": 1,
        "mesh": {"path": mesh.name, "sha256": hashlib.sha256(mesh.read_bytes()).hexdigest(),
                 "units": units, "load": {"units": units, "body": "largest"}},
        "params": {"mu": 0.0}, "grasps": [dict(CUBE_FC, rank=1)]}))
    return path


def test_rank_takes_the_unit_a_plan_records(box, tmp_path, capsys):
    """A plan records its unit (mesh.units): synth rank took none and warned "length unit
    unknown" though the file says decimetres; now it takes the plan's and says so."""
    plan = _plan_file(tmp_path / "box.grasps.json", box)
    out = tmp_path / "r.json"
    code, _, err = _run(capsys, "rank", box, plan, "--out", out)
    assert code == 0, err
    assert f"units: decimeters, the unit {plan} records" in err.splitlines()
    assert "length unit unknown" not in err
    assert json.loads(out.read_text())["mesh"]["units"] == "decimeters"
    code, _, err = _run(capsys, "rank", box, plan, "--units", "dm", "--quiet")  # the same unit
    assert code == 0 and err == "", err
    for same in ("decimeter", "Decimeters", "decimetres"):  # in other words: the same length
        code, _, err = _run(capsys, "rank", box, plan, "--units", same, "--quiet")
        assert code == 0 and err == "", (same, err)
    # --density needs the part's unit: the plan's does (an STL file says none)
    code, _, err = _run(capsys, "rank", box, plan, "--density", "1000", "--quiet")
    assert code == 0 and err == "", err


def test_rank_loads_the_part_as_the_plan_records_it_was_loaded(box, tmp_path, capsys):
    """A plan's mesh.load (body, sharp angle, decimation) is how its part was loaded: rank
    loads it so where the command line does not say otherwise, says so, and records it."""
    plan = _plan_file(tmp_path / "box.grasps.json", box)
    doc = json.loads(plan.read_text())
    doc["mesh"]["load"].update(body="all", sharp_angle=40.0)
    plan.write_text(json.dumps(doc))
    out = tmp_path / "r.json"
    code, _, err = _run(capsys, "rank", box, plan, "--out", out)
    assert code == 0, err
    assert f"load: --body all, --sharp-angle 40.0, as {plan} records its part was loaded" in err
    load = json.loads(out.read_text())["mesh"]["load"]
    assert load["body"] == "all" and load["sharp_angle"] == pytest.approx(40.0)
    # an option given on the command line wins, even at its default value
    code, _, err = _run(capsys, "rank", box, plan, "--sharp-angle", "30", "--out", out)
    assert code == 0 and f"load: --body all, as {plan} records" in err, err
    assert json.loads(out.read_text())["mesh"]["load"]["sharp_angle"] == pytest.approx(30.0)


def test_rank_refuses_units_other_than_the_plans(box, tmp_path, capsys):
    plan = _plan_file(tmp_path / "box.grasps.json", box)
    line = _refused(capsys, "rank", box, plan, "--units", "mm")
    assert line == (f"synth: error: --units mm: {plan} records its coordinates in decimeters, "
                    "and a plan's coordinates are in its recorded unit: leave --units out, or "
                    "give --units decimeters")


def test_rank_says_a_plan_of_another_mesh_was_planned_there(box, tmp_path, capsys,
                                                            monkeypatch):
    """A plan of box.stl ranked on a larger box: every point misses the surface, and the line
    said only "point 0 is 0.9327 from the surface"; now it says the file was planned on
    another mesh, and names it (found from the plan's folder)."""
    (tmp_path / "plans").mkdir()
    plan = _plan_file(tmp_path / "plans" / "box.grasps.json", box)
    doc = json.loads(plan.read_text())
    doc["mesh"]["path"] = "../box.stl"
    plan.write_text(json.dumps(doc))
    big = tmp_path / "big.stl"
    trimesh.creation.box(extents=(3, 3, 3)).export(big)
    monkeypatch.chdir(tmp_path)
    line = _refused(capsys, "rank", "big.stl", "plans/box.grasps.json", "--quiet")
    digest = doc["mesh"]["sha256"]
    assert line == (f"synth: error: plans/box.grasps.json: planned on another mesh (box.stl, "
                    f"sha256 {digest[:12]}...), not big.stl: rank it on that mesh; no candidate "
                    "could be used: candidate 0 (good): point 0 is 1 dm from the surface (more "
                    "than 0.05196 allowed)"), line
    # the same plan on its own mesh: no word of another
    code, _, err = _run(capsys, "rank", "box.stl", "plans/box.grasps.json")
    assert code == 0 and "another mesh" not in err, err
    # a recorded path no file can have (a NUL in it) is left out, not an internal error
    doc["mesh"]["path"] = "a\u0000b.stl"
    plan.write_text(json.dumps(doc))
    line = _refused(capsys, "rank", "big.stl", "plans/box.grasps.json", "--quiet")
    assert line.startswith(f"synth: error: plans/box.grasps.json: planned on another mesh "
                           f"(sha256 {digest[:12]}...), not big.stl"), line


def test_a_plan_of_another_mesh_some_of_whose_candidates_land_is_warned(box, tmp_path, capsys):
    plan = _plan_file(tmp_path / "box.grasps.json", box)
    doc = json.loads(plan.read_text())
    doc["grasps"].append(dict(CUBE_FC, name="far", points=[[0.5, 9, 9]] * 7))
    plan.write_text(json.dumps(doc))
    data = box.read_bytes()
    edited = tmp_path / "edited.stl"  # the same cube, another header: another sha256
    edited.write_bytes(b"edited".ljust(80, b" ") + data[80:])
    code, _, err = _run(capsys, "rank", edited, plan)
    assert code == 0, err
    assert f"warning: {plan} was planned on another mesh ({box}, sha256 " in err
    assert f"1 of its 2 candidates miss {edited}" in err
    copy = tmp_path / "copy.stl"  # the same bytes under another name: the same mesh
    copy.write_bytes(data)
    code, _, err = _run(capsys, "rank", copy, plan)
    assert code == 0 and "another mesh" not in err, err


def test_a_closed_pipe_ends_the_output_quietly(tmp_path):
    """``synth score ... | head``: the reader goes away; synth stops with 128 + SIGPIPE, as
    other tools do, and prints no error."""
    import signal
    import subprocess
    import sys

    f = tmp_path / "c.npz"  # 3,000 rows: more than a pipe holds
    np.savez(f, points=np.tile(CUBE_FC["points"], (3000, 1, 1)),
             normals=np.tile(CUBE_FC["normals"], (3000, 1, 1)))
    proc = subprocess.Popen([sys.executable, "-m", "synth", "score", str(f), "--top", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.readline()
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 128 + signal.SIGPIPE, err
    assert err == ""


def test_a_hidden_point_of_a_single_body_is_not_blamed_on_another_body(tmp_path, capsys):
    """A point in a slot narrower than a fingertip's step off the surface, on a part of one
    body: hidden, and the message says where (a crevice), not "another body"."""
    import manifold3d as mf

    cut = mf.Manifold.cube([1, 1, 1], True) - mf.Manifold.cube([0.001, 2, 0.6], True).translate(
        [0, 0, 0.3])
    mesh = cut.to_mesh()
    path = tmp_path / "slot.stl"
    trimesh.Trimesh(np.asarray(mesh.vert_properties)[:, :3],
                    np.asarray(mesh.tri_verts)).export(path)
    c = tmp_path / "c.json"
    points = [[0.0005, 0.1, 0.3]] + CUBE_FC["points"][1:]  # the first on the slot's wall
    c.write_text(json.dumps([{"name": "slot", "points": points}]))
    line = _refused(capsys, "rank", path, c, "--units", "mm")
    assert "point 0 lies on a hidden part of the surface (in a crevice of the part" in line
    assert "another body" not in line


# -- outputs replace only synth's own files ---------------------------------------------------


def test_plan_never_writes_over_its_input_mesh(box, tmp_path, capsys):
    """A GLB part planned with --out part.json would get part.glb, its own name, as the
    scene: refused, the mesh untouched and nothing written."""
    glb = tmp_path / "part.glb"
    trimesh.load(box).export(glb)
    before = _files(tmp_path)
    line = _refused(capsys, "plan", glb, "--out", tmp_path / "part.json", "--evals", "200")
    assert f"--glb: {glb} is also an input of this command" in line
    line = _refused(capsys, "plan", glb, "--glb", glb, "--out", tmp_path / "g.json",
                    "--evals", "200")
    assert f"--glb: {glb} is also an input of this command" in line
    assert _files(tmp_path) == before


def test_plan_does_not_replace_a_file_synth_did_not_write(box, tmp_path, capsys):
    """The PNG named after --out is a user's picture: refused before any work, every file
    as it was; an earlier plan's files of the same names are replaced."""
    mine = tmp_path / "g.png"
    mine.write_bytes(b"\x89PNG\r\n\x1a\n a user's picture")
    before = _files(tmp_path)
    line = _refused(capsys, "plan", box, "--out", tmp_path / "g.json", "--evals", "200")
    assert f"--png: {mine} exists and synth did not write it" in line
    assert _files(tmp_path) == before
    mine.unlink()
    for suffix in (".json", ".png", ".glb"):
        earlier_output(tmp_path / f"g{suffix}")
    code, _, err = _run(capsys, "plan", box, "--out", tmp_path / "g.json", "--evals", "200",
                        "--units", "mm")
    assert code == 0, err
    assert json.loads((tmp_path / "g.json").read_text())["format"] == "synth.grasps"


@pytest.mark.parametrize("command", ["rank", "score"])
def test_rank_and_score_never_write_over_their_candidates(box, tmp_path, capsys, command):
    cands = tmp_path / "c.json"
    cands.write_text(json.dumps([CUBE_FC]))
    before = _files(tmp_path)
    argv = [command, box, cands] if command == "rank" else [command, cands]
    line = _refused(capsys, *argv, "--out", cands)
    assert f"--out: {cands} is also an input of this command" in line
    assert _files(tmp_path) == before


def test_a_density_without_a_unit_is_bad_input_not_a_bug(box, capsys):
    """A density needs the part's volume in m^3, so its unit: without --units the command
    line is incomplete (exit status 2, saying what to give), never an internal error."""
    line = _refused(capsys, "plan", box, "--density", "1000", "--evals", "200", "--no-files")
    assert ("needs its length unit, which STL files do not say: give --units" in line
            and "internal" not in line)


def test_extreme_values_in_range_print_no_numpy_warnings(box, capsys):
    """A friction coefficient of 1e-300 and a gravity direction of length 1e308 are in range:
    they plan without numpy's overflow warnings on stderr, and the direction's length does
    not matter."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # pytest would hide them from stderr
        code, _, err = _run(capsys, "plan", box, "--mu", "1e-300", "--evals", "500",
                            "--no-files", "--quiet")
        assert code in (0, 1) and err == "", err
        outs = []
        for g in ("1e308,1e308,0", "1,1,0"):
            code, out, err = _run(capsys, "plan", box, "--gripper", "franka", "--units", "cm",
                                  "--gravity", g, "--samples", "40", "--no-files", "--quiet")
            assert code == 0 and err == "", err
            outs.append(out)
    assert outs[0] == outs[1]


@pytest.mark.parametrize(("argv", "words"), [
    (["--no-files", "--out", "x.json"], "--out and --no-files"),
    (["--fingers", "3", "--contacts", "9"], "give --fingers or --contacts, not both"),
    (["--sim-shake", "2"], "--sim-shake: the simulated hand's options apply with --sim only"),
    (["--sim-grip", "5", "--sim-hand", "saturated"], "--sim-hand, --sim-grip:"),
    (["--sim-hand", "balanced"], "--sim-hand: the simulated hand's options"),  # the default
    (["other.stl"], "unrecognized arguments: other.stl (see 'synth plan --help')"),
])
def test_options_that_would_be_ignored_are_refused(box, tmp_path, capsys, argv, words):
    """An option the command would drop without a word is refused, in one line naming it
    and pointing to the command's own help."""
    before = _files(tmp_path)
    line = _refused(capsys, "plan", box, "--evals", "200", *argv)
    assert words in line, line
    assert _files(tmp_path) == before


def test_a_scheduler_without_dask_is_refused(box, tmp_path, capsys):
    line = _refused(capsys, "db", "build", box, "--out", tmp_path / "g.sqlite", "--scheduler",
                    "tcp://127.0.0.1:1")
    assert "--scheduler" in line and "--engine dask" in line
    assert not (tmp_path / "g.sqlite").exists()


def test_a_gripper_description_given_as_a_file_is_an_input(box, tmp_path, capsys):
    """A gripper description the user wrote (format synth.gripper) is never an output: not
    when it is named as --out, nor when it merely sits at an output's name."""
    from synth.fingers.builtin import GRIPPER_FOLDER

    mine = tmp_path / "hand.json"
    mine.write_bytes((GRIPPER_FOLDER / "robotiq_2f85.json").read_bytes())  # boxes only
    before = _files(tmp_path)
    line = _refused(capsys, "plan", box, "--units", "cm", "--gripper", mine, "--out", mine)
    assert f"--out: {mine} is also an input of this command" in line
    line = _refused(capsys, "plan", box, "--units", "cm", "--gripper", "franka", "--out", mine)
    assert f"--out: {mine} exists and synth did not write it" in line
    assert _files(tmp_path) == before


def test_a_users_odd_file_at_an_output_name_is_refused_not_a_crash(box, tmp_path, capsys):
    """A GLB whose JSON is not a glTF document, a damaged NPZ: refused as not synth's (exit
    2), never an internal error."""
    odd = tmp_path / "odd.glb"
    doc = b'{"scenes": 5}   '
    odd.write_bytes(b"glTF" + struct.pack("<III", 2, 20 + len(doc), len(doc)) + b"JSON" + doc)
    line = _refused(capsys, "plan", box, "--glb", odd, "--out", tmp_path / "o.json")
    assert "exists and synth did not write it" in line
    code, _, err = _run(capsys, "db", "build", box, "--out", tmp_path / "g.sqlite", "--evals",
                        "200", "--quiet")
    assert code == 0, err
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"PK\x03\x04garbage")
    line = _refused(capsys, "db", "export", tmp_path / "g.sqlite", "--out", bad)
    assert "not an export synth wrote" in line and bad.read_bytes() == b"PK\x03\x04garbage"


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs Linux's /dev/full")
def test_a_full_disk_under_stdout_is_said_as_such(tmp_path):
    """stdout on a full disk: status 1 and a line that says what could not be written (it was
    '[Errno 28] No space left on device' alone)."""
    with open("/dev/full", "w") as full:
        run = subprocess.run([sys.executable, "-m", "synth.cli", "plan", "meshes/cube.stl",
                              "--units", "mm", "--evals", "200", "--no-files"], cwd=ROOT,
                             stdout=full, stderr=subprocess.PIPE, text=True, check=False)
    assert run.returncode == 1
    assert run.stderr.splitlines()[-1] == ("synth: error: cannot write the output: No space "
                                           "left on device")


@pytest.mark.parametrize(("message", "said"), [
    ("--workers (Python: workers=): expected an integer", "--workers: expected an integer"),
    ("planner 'x' (from --planner, Python: planner=) must be", "planner 'x' (from --planner) "
     "must be"),
    ("decimate it on loading (--decimate N, Python: load_part(path, decimate=N); the surface "
     "error is reported) or first", "decimate it on loading (--decimate N; the surface error "
     "is reported) or first"),
    ("give --units (mm, cm, m, in, ...; Python: load_part(path, units=...))",
     "give --units (mm, cm, m, in, ...)"),
    ("--out g.csv (Python: out=): no format; give --format h5 (Python: fmt=); or a folder",
     "--out g.csv: no format; give --format h5; or a folder"),
    ("a message with (parentheses) and no Python words", "a message with (parentheses) and no "
     "Python words"),
])
def test_the_command_line_leaves_out_the_python_keywords(message, said):
    """An API error names the option and the keyword; the command line says the option."""
    from synth.cli import command_words

    assert command_words(message) == said
