"""Helpers shared by the database tests: a folder of small meshes and database snapshots."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from synth.database import GraspDatabase

__all__ = ["TESTS_DIR", "REPO_DIR", "PLANNER", "PARAMS", "make_mesh_dir", "planner_env", "snapshot"]

TESTS_DIR = str(Path(__file__).resolve().parent)
REPO_DIR = str(Path(TESTS_DIR).parent)
PLANNER = "tests.db_fakeplanner:plan_mesh_file"
PARAMS: dict[str, Any] = {"evals": 300, "top": 5, "seed": 3}

GOOD = ("box.stl", "ico.stl", "sub/box2.stl", "sub/deeper/cyl.obj")
BROKEN = ("empty.stl", "random.stl")
DUPLICATE = "sub/dup.stl"  # same bytes as box.stl


def make_mesh_dir(root: Path) -> Path:
    """Four good meshes (two in sub-folders), a duplicate, two broken .stl and a .txt."""
    d = root / "meshes"
    (d / "sub" / "deeper").mkdir(parents=True)
    trimesh.creation.box().export(d / "box.stl")
    trimesh.creation.icosphere(subdivisions=1).export(d / "ico.stl")
    trimesh.creation.box(extents=(1.0, 2.0, 3.0)).export(d / "sub" / "box2.stl")
    trimesh.creation.cylinder(radius=0.5, height=1.0, sections=12).export(
        d / "sub" / "deeper" / "cyl.obj"
    )
    shutil.copyfile(d / "box.stl", d / DUPLICATE)
    (d / "empty.stl").write_bytes(b"")
    (d / "random.stl").write_bytes(np.random.default_rng(0).bytes(777))
    (d / "notes.txt").write_text("not a mesh\n")
    return d


def planner_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    """Environment for a subprocess that plans with the test planner."""
    env = dict(os.environ)
    env["SYNTH_DB_PLANNER"] = PLANNER
    env["PYTHONPATH"] = os.pathsep.join([REPO_DIR] + ([env["PYTHONPATH"]] if
                                                        env.get("PYTHONPATH") else []))  # fmt: skip
    env.update(extra or {})
    return env


def snapshot(path: str | os.PathLike[str]) -> tuple[list[tuple[Any, ...]], list[tuple[Any, ...]]]:
    """Everything stored except timings: mesh rows and grasps (as the planner's dicts)."""
    with GraspDatabase(path) as db:
        meshes = [
            (m.id, m.path, m.name, m.sha256, m.size, m.status, m.error_kind, m.error,
             m.duplicate_of, m.units, m.length, m.n_grasps, m.params, m.planner)
            for m in db.meshes()
        ]  # fmt: skip
        grasps = [(g.mesh_id, g.rank, g.to_dict()) for g in db.grasps()]
    return meshes, grasps
