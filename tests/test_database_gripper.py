"""``synth db build --gripper``: gripper grasps in the table gripper_grasps (schema 4), and
older files read as they are and migrated on the first write."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from synth import GraspDatabase
from synth.cli import main
from synth.database.build import normalize_params
from synth.errors import InputError
from synth.plan import plan_gripper_file

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def meshes(tmp_path: Path) -> Path:
    folder = tmp_path / "meshes"
    folder.mkdir()
    shutil.copy(ROOT / "meshes" / "cube.stl", folder / "cube.stl")
    return folder


def test_gripper_build_stores_poses(meshes: Path, tmp_path: Path) -> None:
    out = tmp_path / "g.sqlite"
    assert main(["db", "build", str(meshes), "--out", str(out), "--gripper", "franka",
                 "--units", "cm", "--top", "3", "--workers", "0", "--quiet"]) == 0
    doc = plan_gripper_file(str(meshes / "cube.stl"), normalize_params(
        {"gripper": "franka", "units": "cm", "top": 3, "mu": 0.5}))
    with GraspDatabase(out) as db:
        assert db.schema_version == 4
        stored = list(db.gripper_grasps("cube.stl"))
        assert db.info().grasps == len(stored) == len(doc["grasps"]) == 3
        assert list(db.grasps()) == []
        for rec, g in zip(stored, doc["grasps"], strict=True):
            assert rec.gripper == "franka"
            assert np.array_equal(rec.pose, np.array(g["pose"]))
            assert rec.width == g["width"]
            assert rec.squeeze_per_weight == g["measures"]["squeeze_per_weight"]
            assert rec.margin is None  # no mass given


def test_a_v3_file_reads_and_migrates(meshes: Path, tmp_path: Path) -> None:
    out = tmp_path / "p.sqlite"
    args = ["db", "build", str(meshes), "--out", str(out), "--evals", "1000", "--top", "2",
            "--workers", "0", "--quiet"]
    assert main(args) == 0
    conn = sqlite3.connect(out)  # make it a schema-3 file: no gripper_grasps, no grasps.sim
    with conn:
        conn.execute("DROP TABLE gripper_grasps")
        conn.execute("ALTER TABLE grasps DROP COLUMN sim")
        conn.execute("UPDATE meta SET value = '3' WHERE key = 'schema_version'")
        conn.execute("PRAGMA user_version = 3")
    conn.close()
    with GraspDatabase(out) as db:
        assert db.schema_version == 3
        assert list(db.gripper_grasps()) == [] and len(list(db.grasps())) == 2
        assert db.info().grasps == 2
    shutil.copy(ROOT / "meshes" / "bracket.stl", meshes / "bracket.stl")
    assert main(args) == 0  # a build writes to it: migrated in place
    with GraspDatabase(out) as db:
        assert db.schema_version == 4 and list(db.gripper_grasps()) == []
        added = db.mesh("bracket").n_grasps  # the cube's 2 kept, the bracket's added
        assert added >= 1 and len(list(db.grasps())) == 2 + added
    conn = sqlite3.connect(out)  # the full version 4
    for table in ("grasps", "gripper_grasps"):
        assert "sim" in {r[1] for r in conn.execute(f"PRAGMA table_info({table})")}
    conn.close()


def test_gripper_parameters_are_checked() -> None:
    with pytest.raises(InputError, match="unknown gripper planner parameter 'contacts'"):
        normalize_params({"gripper": "franka", "contacts": 7})
    with pytest.raises(InputError, match="neither a built-in gripper"):
        normalize_params({"gripper": "nope"})
    with pytest.raises(InputError, match="'mu' must be a number > 0"):
        normalize_params({"gripper": "franka", "mu": 0})


# -- a gripper database reads back through every tool (issue 32, item 1) ---------------------
READ_OPTS = ["--gripper", "franka", "--units", "cm", "--top", "2", "--samples", "60",
             "--mass", "0.05"]


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict]:
    """A gripper database of the cube and the prism, simulated: (folder, database, the plan
    documents that `synth plan --gripper --sim` gives for each mesh, by stem)."""
    pytest.importorskip("mujoco")
    tmp = tmp_path_factory.mktemp("jaws")
    folder = tmp / "meshes"
    folder.mkdir()
    for name in ("cube.stl", "prism.stl"):
        shutil.copy(ROOT / "meshes" / name, folder / name)
    opts = READ_OPTS + ["--sim", "--sim-shake", "0"]
    out = tmp / "g.sqlite"
    assert main(["db", "build", str(folder), "--out", str(out), "--workers", "0", "--quiet",
                 *opts]) == 0
    docs = {}
    for stem in ("cube", "prism"):
        with contextlib.redirect_stdout(io.StringIO()) as text:
            assert main(["plan", str(folder / f"{stem}.stl"), "--no-files", "--json",
                         *opts]) == 0
        docs[stem] = json.loads(text.getvalue())
    return folder, out, docs


def _untimed(label: dict | None) -> dict | None:
    return None if label is None else {k: v for k, v in label.items() if k != "seconds"}


def test_db_top_shows_the_gripper_grasps_with_measures_and_labels(simulated, capsys) -> None:
    _, db, docs = simulated
    for stem, doc in docs.items():
        assert len(doc["grasps"]) == 2
        assert main(["db", "top", str(db), stem]) == 0
        text = capsys.readouterr().out
        assert f"{stem}.stl [done]: 2 franka gripper grasps" in text
        rows = [line.split() for line in text.splitlines()[2:]]
        for row, g in zip(rows, doc["grasps"], strict=True):
            m = g["measures"]
            assert float(row[1]) == pytest.approx(g["width"] * 10.0, abs=0.05)  # cm -> mm
            assert float(row[2]) == pytest.approx(m["margin"], abs=0.005)
            assert float(row[4]) == pytest.approx(m["squeeze_per_weight"], abs=5e-4)
            assert row[8] == ("yes" if g["sim"]["held"] else "no")
        assert main(["db", "top", str(db), stem, "--json"]) == 0
        got = json.loads(capsys.readouterr().out)["grasps"]
        for rec, g in zip(got, doc["grasps"], strict=True):
            assert rec["pose"] == g["pose"] and rec["width"] == g["width"]
            assert [c["point"] for c in rec["contacts"]] == [c["point"] for c in g["contacts"]]
            assert [c["touch"] for c in rec["contacts"]] == [c["touch"] for c in g["contacts"]]
            for key, value in rec["measures"].items():
                assert value == g["measures"][key], key
            assert _untimed(rec["sim"]) == _untimed(g["sim"])


def test_db_top_orders_gripper_grasps_by_their_measures(simulated, capsys) -> None:
    _, db, _ = simulated
    with GraspDatabase(db) as g:
        stored = list(g.gripper_grasps("prism"))
        for key, sign in (("mu_min", 1), ("epsilon", -1), ("d_star", -1)):
            top = g.top("prism", 5, key)
            values = [sign * getattr(r, key) for r in top]
            assert values == sorted(values) and {r.rank for r in top} == {r.rank for r in
                                                                          stored}
        assert g.top("prism", 1, "margin")[0].squeeze_per_weight == min(
            r.squeeze_per_weight for r in stored)
    assert main(["db", "top", str(db), "prism", "--rank-by", "conditioning"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "gripper grasps, which rank by" in err
    # the option, then the Python keyword (it read "rank_by (--rank-by) 'conditioning'")
    # the command line names the option alone (the API's error adds "(Python: rank_by=)")
    assert err.startswith("synth: error: --rank-by 'conditioning': "), err


def test_db_info_counts_the_gripper_grasps_and_the_loading_reports(simulated, capsys) -> None:
    _, db, docs = simulated
    assert main(["db", "info", str(db), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    n = sum(len(d["grasps"]) for d in docs.values())
    assert info["grasps"] == info["gripper_grasps"] == n and info["kind"] == "gripper"
    assert info["with_report"] == 2  # the gripper document says how the mesh was loaded
    assert main(["db", "info", str(db)]) == 0
    assert f"grasps: {n} ({n} gripper, franka)" in capsys.readouterr().out


def test_json_h5_and_npz_exports_hold_the_gripper_grasps(simulated, tmp_path) -> None:
    h5py = pytest.importorskip("h5py")
    _, db, docs = simulated
    for fmt in ("json", "h5", "npz"):
        assert main(["db", "export", str(db), "--out", str(tmp_path / f"e.{fmt}")]) == 0
    want = [(stem, g) for stem in ("cube", "prism") for g in docs[stem]["grasps"]]
    exported = json.loads((tmp_path / "e.json").read_text())
    got = [(Path(m["name"]).stem, g) for m in exported["meshes"] for g in m["grasps"]]
    assert all(m["grasp_format"] == "synth.gripper_grasps" for m in exported["meshes"])
    assert [s for s, _ in got] == [s for s, _ in want]
    for (_, g), (_, w) in zip(got, want, strict=True):
        assert g["pose"] == w["pose"] and g["measures"]["margin"] == w["measures"]["margin"]
        assert _untimed(g["sim"]) == _untimed(w["sim"])
    npz = np.load(tmp_path / "e.npz")
    with h5py.File(tmp_path / "e.h5") as f:
        cols = {k: f[f"gripper_grasps/{k}"][()] for k in ("pose", "width", "sim_held",
                                                           "mu_min", "rank")}
    for arrays in ({k: npz[f"gripper_{k}"] for k in cols}, cols):
        assert np.array_equal(arrays["pose"], np.array([w["pose"] for _, w in want]))
        assert np.array_equal(arrays["width"], [w["width"] for _, w in want])
        assert np.array_equal(arrays["mu_min"], [w["measures"]["mu_min"] for _, w in want])
        assert np.array_equal(arrays["sim_held"], [float(w["sim"]["held"]) for _, w in want])
        assert arrays["rank"].tolist() == [1, 2, 1, 2]
    assert npz["points"].shape == (0, 3)  # no point-finger grasps


def test_acronym_graspgen_and_isaac_exports_hold_the_gripper_grasps(simulated,
                                                                     tmp_path) -> None:
    pytest.importorskip("h5py")
    pytest.importorskip("yaml")
    from synth.formats import read_gripper_poses

    _, db, docs = simulated
    for fmt, ext in (("acronym", "h5"), ("graspgen", "json"), ("isaac", "yaml")):
        out = tmp_path / fmt
        assert main(["db", "export", str(db), "--format", fmt, "--out", str(out)]) == 0
        for stem, doc in docs.items():
            poses = read_gripper_poses(out / f"{stem}.{ext}")
            want = np.array([g["pose"] for g in doc["grasps"]])
            want[:, :3, 3] *= 0.01  # cm -> m: these formats are in metres
            assert np.allclose(poses.poses, want, rtol=0, atol=1e-12), (fmt, stem)
            held = [bool(g["sim"]["held"]) for g in doc["grasps"]]
            assert [bool(x) for x in poses.labels] == held, (fmt, stem)


def test_a_point_finger_database_refuses_the_gripper_formats_in_one_line(tmp_path,
                                                                         capsys) -> None:
    out = tmp_path / "p.sqlite"
    assert main(["db", "build", str(ROOT / "meshes" / "cube.stl"), "--out", str(out),
                 "--units", "cm", "--evals", "300", "--top", "1", "--workers", "0",
                 "--quiet"]) == 0
    capsys.readouterr()
    assert main(["db", "export", str(out), "--format", "isaac", "--out",
                 str(tmp_path / "i")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no gripper grasps to export as isaac" in err
    # margin means the same for both kinds (the least squeeze per weight first); mu_min is a
    # gripper measure
    assert main(["db", "top", str(out), "cube", "--rank-by", "mu_min"]) == 2
    assert "point-finger grasps, which rank by" in capsys.readouterr().err


@pytest.mark.parametrize("option", [["--contacts", "9"], ["--evals", "500"], ["--regions"],
                                    ["--finger-radius", "0.1"], ["--surface", "mesh"]])
def test_db_build_gripper_refuses_point_finger_options_by_name(option, tmp_path,
                                                               capsys) -> None:
    out = tmp_path / "g.sqlite"
    assert main(["db", "build", str(ROOT / "meshes" / "cube.stl"), "--out", str(out),
                 *READ_OPTS, *option]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{option[0]} applies to point-finger grasps" in err
    assert not out.exists()


def test_db_build_gripper_takes_its_rank_keys_and_resumes(meshes: Path, tmp_path: Path,
                                                          capsys) -> None:
    out = tmp_path / "g.sqlite"
    args = ["db", "build", str(meshes), "--out", str(out), *READ_OPTS, "--rank-by", "mu_min",
            "--workers", "0"]
    assert main(args) == 0
    assert main(args) == 0  # the same build again: resumed, nothing planned
    assert "0 planned" in capsys.readouterr().err
    # resumed without --gripper: told which planner built it, not a list of differences
    assert main(["db", "build", str(meshes), "--out", str(out), "--units", "cm",
                 "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "plan_gripper_file" in err and "--gripper" in err
    assert "other planner parameters" not in err
    doc = plan_gripper_file(str(meshes / "cube.stl"), normalize_params(
        {"gripper": "franka", "units": "cm", "top": 2, "samples": 60, "mass": 0.05,
         "rank_by": "mu_min"}))
    with GraspDatabase(out) as db:
        assert db.params["rank_by"] == "mu_min"
        assert [g.pose.tolist() for g in db.top("cube", 5)] == [g["pose"] for g in
                                                                 doc["grasps"]]


def test_a_gripper_build_checks_min_margin_as_the_command_line_does():
    from synth.database.build import normalize_params

    base = {"gripper": "franka", "units": "m"}
    assert normalize_params({**base, "min_margin": 0})["min_margin"] is None  # 0: no floor
    assert normalize_params({**base, "min_margin": 2})["min_margin"] == 2.0
    assert normalize_params(base)["min_margin"] == 1.0
    for bad in ("2", -1, float("nan"), True):
        with pytest.raises(ValueError, match="min_margin"):
            normalize_params({**base, "min_margin": bad})
