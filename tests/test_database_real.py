"""Grasp databases built by ``synth db build`` with the real planner (``synth.plan``).

No ``SYNTH_DB_PLANNER`` override: these builds run the planner ``synth db`` ships with, on
copies of the sample meshes of ``meshes/`` plus broken files, with a small evaluation budget.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tests.db_support import REPO_DIR, snapshot

import synth
from synth.database import GraspDatabase
from synth.plan import plan_mesh_file
from synth.plan.ranking import shown_d_star

REAL_PLANNER = "synth.plan:plan_mesh_file"
PARAMS = {"evals": 10_000, "top": 3, "seed": 0}  # a small budget; 3 grasps on GOOD meshes
GOOD = ("cube.stl", "prism.stl", "bracket.stl")
NO_GRASP = "sphere.stl"  # smooth everywhere: no frictionless form closure exists
BROKEN = {"empty.stl": "file is empty", "random.stl": "not a complete binary STL"}


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "SYNTH_DB_PLANNER"}
    env["PYTHONPATH"] = os.pathsep.join([REPO_DIR, *filter(None, [env.get("PYTHONPATH")])])
    return env


def _build(mesh_dir: Path, out: Path, workers: int) -> subprocess.CompletedProcess[str]:
    args = [f"--{k}={v}" for k, v in PARAMS.items()]
    r = subprocess.run(
        [sys.executable, "-m", "synth", "db", "build", str(mesh_dir), "--out", str(out),
         "--workers", str(workers), *args],
        capture_output=True, text=True, env=_env(), timeout=120,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return r


@pytest.fixture(scope="module")
def mesh_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Sample meshes (three graspable, the sphere), two broken .stl files and a .txt."""
    d = tmp_path_factory.mktemp("real") / "meshes"
    d.mkdir()
    for name in (*GOOD, NO_GRASP):
        shutil.copyfile(Path(REPO_DIR) / "meshes" / name, d / name)
    (d / "empty.stl").write_bytes(b"")
    (d / "random.stl").write_bytes(np.random.default_rng(0).bytes(777))
    (d / "notes.txt").write_text("not a mesh\n")
    return d


@pytest.fixture(scope="module")
def one_worker(mesh_dir: Path) -> tuple[Path, str]:
    """(database, summary on stderr) of a 1-worker build."""
    out = mesh_dir.parent / "one.sqlite"
    return out, _build(mesh_dir, out, 1).stderr


def test_real_build_counts_failures_and_d_star(
    mesh_dir: Path, one_worker: tuple[Path, str]
) -> None:
    out, summary = one_worker
    assert "3 done, 3 failed" in summary and "ignored 1 non-mesh files" in summary
    assert "notes.txt" in summary
    sphere_doc = plan_mesh_file(mesh_dir / NO_GRASP, PARAMS)  # what the planner itself says
    assert sphere_doc["grasps"] == [] and sphere_doc["message"]
    with GraspDatabase(out) as db:
        assert db.planner == REAL_PLANNER
        assert db.params == {**db.params, **PARAMS}
        info = db.info()
        assert (info.meshes, info.done, info.failed, info.duplicates, info.pending) == (
            6, 3, 3, 0, 0,
        )  # fmt: skip
        by_name = {m.name: m for m in db.meshes()}
        assert set(by_name) == {*GOOD, NO_GRASP, *BROKEN}
        sphere = by_name[NO_GRASP]
        assert (sphere.status, sphere.error_kind, sphere.n_grasps) == ("failed", "no_grasp", 0)
        assert sphere.error == f"no grasp found: {sphere_doc['message']}"
        for name, reason in BROKEN.items():
            m = by_name[name]
            assert (m.status, m.error_kind, m.n_grasps) == ("failed", "mesh", 0)
            assert m.error is not None and m.error.startswith("cannot load mesh: ")
            assert reason in m.error and m.path in m.error
        assert {p for p, _, _ in info.failures} == {by_name[n].path for n in (NO_GRASP, *BROKEN)}

        n_checked = 0
        for name in GOOD:
            m = by_name[name]
            assert m.status == "done" and m.error is None and m.planner == REAL_PLANNER
            grasps = list(db.grasps(m.id))
            assert len(grasps) == m.n_grasps == PARAMS["top"]
            assert [g.rank for g in grasps] == list(range(1, m.n_grasps + 1))
            # best first: by d* as printed, then by conditioning
            shown = [(shown_d_star(g.d_star), g.conditioning) for g in grasps]
            assert shown == sorted(shown, reverse=True)
            for g in grasps:
                assert g.points.shape == g.normals.shape == (7, 3)
                fc = synth.form_closure(synth.wrench_matrix(g.points, g.normals))
                assert abs(fc.d_star - g.d_star) <= 1e-7, (name, g.rank, fc.d_star, g.d_star)
                assert fc.is_form_closure and fc.d_star > 0 and g.closure == "form"
                n_checked += 1
        assert n_checked == info.grasps == 3 * len(GOOD)

        # the database holds what the planner returns for the mesh, grasp for grasp
        cube_doc = plan_mesh_file(mesh_dir / "cube.stl", PARAMS)
        stored = list(db.grasps("cube.stl"))
        assert len(stored) == len(cube_doc["grasps"])
        for g, p in zip(stored, cube_doc["grasps"]):
            assert g.d_star == p["d_star"] and g.closure == p["closure"]
            np.testing.assert_array_equal(g.points, p["points"])
            np.testing.assert_array_equal(g.normals, p["normals"])


def test_real_build_one_and_two_workers_identical(
    mesh_dir: Path, one_worker: tuple[Path, str]
) -> None:
    out1, _ = one_worker
    out2 = mesh_dir.parent / "two.sqlite"
    summary = _build(mesh_dir, out2, 2).stderr
    assert "(local, 2 workers)" in summary
    meshes1, grasps1 = snapshot(out1)
    meshes2, grasps2 = snapshot(out2)
    assert len(grasps1) == 3 * len(GOOD)
    assert meshes2 == meshes1
    assert len(grasps2) == len(grasps1)
    for a, b in zip(grasps1, grasps2):
        assert a == b
