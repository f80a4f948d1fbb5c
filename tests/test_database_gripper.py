"""``synth db build --gripper``: gripper grasps in the table gripper_grasps (schema 4), and
older files read as they are and migrated on the first write."""

from __future__ import annotations

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
    shutil.copy(ROOT / "meshes" / "prism.stl", meshes / "prism.stl")
    assert main(args) == 0  # a build writes to it: migrated in place
    with GraspDatabase(out) as db:
        assert db.schema_version == 4 and list(db.gripper_grasps()) == []
        assert len(list(db.grasps())) == 4
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
