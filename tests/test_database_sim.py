"""``synth db build --sim``: each mesh's grasps simulated on the worker, the labels stored in the
column ``sim`` and carried by ``db top`` and the exports; the settings are parameters of the
build; a version-4 file from before the column migrates."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import numpy as np
import pytest
import trimesh

pytest.importorskip("mujoco")

from synth.cli import main  # noqa: E402
from synth.database import GraspDatabase  # noqa: E402
from synth.database.build import normalize_params  # noqa: E402
from synth.errors import InputError  # noqa: E402
from synth.sim import SimSettings, simulate_plan  # noqa: E402
from tests.db_fakeplanner import plan_for_sim  # noqa: E402
from tests.db_support import PLANNER  # noqa: E402

SIM_PLANNER = "tests.db_fakeplanner:plan_for_sim"
BUILD = ["--evals", "300", "--top", "2", "--seed", "3", "--workers", "0", "--quiet"]
SIM = ["--sim", "--sim-grip", "50", "--sim-shake", "0.5"]


@pytest.fixture
def meshes(tmp_path: Path) -> Path:
    folder = tmp_path / "meshes"
    folder.mkdir()
    trimesh.creation.box().export(folder / "box.stl")
    return folder


def _build(meshes: Path, out: Path, *extra: str, planner: str = SIM_PLANNER) -> int:
    return main(["db", "build", str(meshes), "--out", str(out), "--planner", planner, *BUILD,
                 *extra])


def _untimed(label: dict) -> dict:
    return {k: v for k, v in label.items() if k != "seconds"}


def test_build_stores_what_synth_sim_says_and_every_reader_carries_it(meshes, tmp_path,
                                                                       capsys):
    out = tmp_path / "g.sqlite"
    assert _build(meshes, out, *SIM) == 0
    # the same document simulated directly, without the database
    doc = plan_for_sim(str(meshes / "box.stl"), normalize_params(
        {"evals": 300, "top": 2, "seed": 3}))
    settings = SimSettings(grip=50.0, shake=0.5)
    want = [_untimed(g["sim"]) for g in simulate_plan(doc, meshes / "box.stl",
                                                      settings)["grasps"]]
    with GraspDatabase(out) as db:
        assert db.params["sim"] == settings.to_dict()
        got = [g.sim for g in db.grasps("box")]
    assert [_untimed(s) for s in got] == want
    assert [s["held"] for s in got] == [True, False]  # one through the shake, one not
    capsys.readouterr()
    assert main(["db", "top", str(out), "box", "--json"]) == 0
    assert [g["sim"] for g in json.loads(capsys.readouterr().out)["grasps"]] == got
    assert main(["db", "top", str(out), "box"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert "held" in table[1] and "failed at" in table[1]
    held = table[1].split().index("held")
    assert table[2].split()[held:held + 2] == ["yes", "-"]
    assert table[3].split()[held:held + 2] == ["no", "squeeze"]
    for fmt in ("npz", "json", "h5"):
        assert main(["db", "export", str(out), "--out", str(tmp_path / f"g.{fmt}")]) == 0
    z = np.load(tmp_path / "g.npz")
    assert [json.loads(t) for t in z["sim"]] == got
    assert z["sim_held"].tolist() == [float(s["held"]) for s in got]
    exported = json.loads((tmp_path / "g.json").read_text())["meshes"][0]["grasps"]
    assert [g["sim"] for g in exported] == got
    import h5py

    with h5py.File(tmp_path / "g.h5") as f:
        assert [json.loads(t) for t in f["grasps/sim"].asstr()[:]] == got


def test_other_settings_do_not_resume_and_an_unsimulated_export_says_so(meshes, tmp_path,
                                                                       capsys):
    out = tmp_path / "g.sqlite"
    assert _build(meshes, out, *SIM) == 0
    capsys.readouterr()
    assert _build(meshes, out, *SIM, "--sim-grip", "5") == 2
    assert "(sim.grip: stored 50.0, asked 5.0)" in capsys.readouterr().err
    assert _build(meshes, out) == 2
    err = capsys.readouterr().err
    assert "(sim: stored {" in err and "asked None)" in err
    plain = tmp_path / "plain.sqlite"
    assert _build(meshes, plain) == 0
    with GraspDatabase(plain) as db:
        assert "sim" not in db.params and [g.sim for g in db.grasps()] == [None, None]
    assert main(["db", "export", str(plain), "--out", str(tmp_path / "p.npz")]) == 0
    z = np.load(tmp_path / "p.npz")
    assert z["sim"].tolist() == ["", ""] and np.isnan(z["sim_held"]).all()


def test_a_simulation_that_cannot_run_keeps_the_grasps_with_its_reason(meshes, tmp_path):
    # the plain test planner's document has no centre of mass: the simulation cannot run,
    # and the mesh is still planned, its grasps stored with an error label saying why
    out = tmp_path / "g.sqlite"
    assert _build(meshes, out, *SIM, planner=PLANNER) == 0
    with GraspDatabase(out) as db:
        m = db.mesh("box")
        labels = [g.sim for g in db.grasps("box")]
    assert m.status == "done" and len(labels) == 2
    for lab in labels:
        assert lab["held"] is None and lab["failed_at"] == "error"
        assert lab["reason"].startswith("simulation failed: ")
        assert "field mesh.center_mass: missing" in lab["reason"]


def test_settings_are_checked_and_completed():
    full = normalize_params({"sim": {"grip": 5}})["sim"]
    assert full == SimSettings(grip=5.0).to_dict()
    assert "sim" not in normalize_params({}) and "sim" not in normalize_params({"sim": None})
    with pytest.raises(InputError, match="unknown setting 'speed'"):
        normalize_params({"sim": {"speed": 1}})
    with pytest.raises(InputError, match="never mix"):  # labels of another simulator
        normalize_params({"sim": {"simulator": "synth.sim 1"}})
    with pytest.raises(InputError, match="'sim': grip: expected a number from 0.001"):
        normalize_params({"sim": {"grip": -1}})
    with pytest.raises(InputError, match="'sim': expected an object of simulation settings"):
        normalize_params({"gripper": "franka", "sim": 3})


def test_a_version_4_file_from_before_the_sim_column_reads_and_migrates(meshes, tmp_path):
    out = tmp_path / "g.sqlite"
    assert _build(meshes, out, planner=PLANNER) == 0
    conn = sqlite3.connect(out)  # a version-4 file written before the column existed
    with conn:
        conn.execute("ALTER TABLE grasps DROP COLUMN sim")
        conn.execute("ALTER TABLE gripper_grasps DROP COLUMN sim")
    conn.close()
    with GraspDatabase(out) as db:
        before = [g.to_dict() for g in db.grasps()]
        assert db.schema_version == 4 and [g["sim"] for g in before] == [None, None]
    trimesh.creation.box(extents=(1.0, 2.0, 3.0)).export(meshes / "box2.stl")
    assert _build(meshes, out, planner=PLANNER) == 0  # a build writes: the columns are added
    conn = sqlite3.connect(out)
    for table in ("grasps", "gripper_grasps"):
        assert "sim" in {r[1] for r in conn.execute(f"PRAGMA table_info({table})")}
    conn.close()
    with GraspDatabase(out) as db:
        assert [g.to_dict() for g in db.grasps("box")] == before
        assert len(list(db.grasps("box2"))) == 2


def test_gripper_build_stores_what_plan_gripper_sim_gives(tmp_path, capsys):
    cube = Path(__file__).resolve().parents[1] / "meshes" / "cube.stl"
    opts = ["--gripper", "franka", "--units", "cm", "--top", "2", "--samples", "60", "--sim",
            "--sim-shake", "0"]
    out = tmp_path / "j.sqlite"
    assert main(["db", "build", str(cube), "--out", str(out), "--workers", "0", "--quiet",
                 *opts]) == 0
    capsys.readouterr()
    assert main(["plan", str(cube), "--no-files", "--json", *opts]) == 0
    want = [_untimed(g["sim"]) for g in json.loads(capsys.readouterr().out)["grasps"]]
    with GraspDatabase(out) as db:
        got = [_untimed(g.sim) for g in db.gripper_grasps("cube")]
    assert len(got) == 2 and got == want


def test_dask_workers_simulate_as_one_process_does(meshes, tmp_path, monkeypatch):
    # the labels come from the worker that planned the mesh: on a Dask cluster of two
    # worker processes they must be those of a build in this process, mesh by mesh
    distributed = pytest.importorskip("distributed")
    from tests.db_support import planner_env

    trimesh.creation.box(extents=[1.0, 2.0, 3.0]).export(meshes / "long.stl")
    for key, value in planner_env().items():
        monkeypatch.setenv(key, value)  # the worker processes import the test planner
    one = tmp_path / "one.sqlite"
    assert _build(meshes, one, *SIM) == 0
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        out = tmp_path / "dask.sqlite"
        assert main(["db", "build", str(meshes), "--out", str(out), "--planner", SIM_PLANNER,
                     "--evals", "300", "--top", "2", "--seed", "3", "--quiet", "--engine",
                     "dask", "--scheduler", cluster.scheduler_address, *SIM]) == 0
    labels = {}
    for path in (one, out):
        with GraspDatabase(path) as db:
            assert db.params["sim"] == SimSettings(grip=50.0, shake=0.5).to_dict()
            labels[path] = {m: [_untimed(g.sim) for g in db.grasps(m)] for m in ("box", "long")}
    assert labels[out] == labels[one]
    assert all(s is not None and "held" in s for grasps in labels[one].values() for s in grasps)
