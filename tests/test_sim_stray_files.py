"""No stray files: ``synth sim`` writes the grasp file it was asked to and nothing else in the
user's folder, MuJoCo's ``MUJOCO_LOG.TXT`` above all (MuJoCo appends every warning to it in
the current folder unless a handler takes them: :func:`synth.sim.scene.quiet_mujoco`)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from synth.cli import main  # noqa: E402
from synth.sim import SimSettings  # noqa: E402
from tests.sim_support import CUBE7, write_cube, write_grasps  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def test_synth_sim_in_a_folder_leaves_only_its_grasp_file(tmp_path: Path) -> None:
    """A whole ``synth sim`` process (import, decomposition, compile, simulation) run in the
    user's folder: the folder holds the same files after, the grasp file labelled."""
    mesh = write_cube(tmp_path)
    grasps = write_grasps(tmp_path, mesh, *CUBE7)
    before = sorted(os.listdir(tmp_path))
    env = {**os.environ, "SYNTH_CACHE_DIR": str(tmp_path.parent / f"{tmp_path.name}-cache"),
           "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-m", "synth", "sim", grasps.name, "--sim-shake",
                           "0", "--quiet"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, check=False, timeout=300)
    assert done.returncode == 0, done.stderr
    assert sorted(os.listdir(tmp_path)) == before  # no MUJOCO_LOG.TXT, no cache, no temp file
    assert "sim" in json.loads(grasps.read_text())["grasps"][0]


def test_a_simulation_mujoco_warns_about_writes_no_log(tmp_path: Path, monkeypatch) -> None:
    """A simulation that diverges (MuJoCo warns of a bad acceleration and resets; without a
    handler it appends the warning to MUJOCO_LOG.TXT in the current folder) leaves no log."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path.parent / f"{tmp_path.name}-cache"))
    mesh = write_cube(tmp_path)
    grasps = write_grasps(tmp_path, mesh, *CUBE7)
    # servos of 1e9 N/m on fingertips of a microgram at steps of 1 ms blow up at once
    diverging = SimSettings(stiffness=1e9, finger_mass=1e-9, timestep=1e-3, grip=1e6)
    monkeypatch.setattr("synth.cli.sim.settings_from_args", lambda args: diverging)
    assert main(["sim", str(grasps), "--quiet"]) == 0
    label = json.loads(grasps.read_text())["grasps"][0]["sim"]
    assert label["failed_at"] == "diverged"  # MuJoCo did warn
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert sorted(os.listdir(tmp_path)) == sorted([mesh.name, grasps.name])
