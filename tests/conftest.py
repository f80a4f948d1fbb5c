"""Shared pytest setup: headless plotting, and the fixtures of the database tests."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from tests.db_support import PARAMS, PLANNER, make_mesh_dir  # noqa: E402


@pytest.fixture
def mesh_dir(tmp_path: Path) -> Path:
    """A folder of small meshes for database builds (see ``tests.db_support``)."""
    return make_mesh_dir(tmp_path)


@pytest.fixture
def reference(tmp_path: Path, mesh_dir: Path) -> Path:
    """An uninterrupted build of ``mesh_dir`` planned in this process."""
    from synth.database import build_database

    out = tmp_path / "reference.sqlite"
    build_database([mesh_dir], out, PARAMS, workers=0, planner=PLANNER, quiet=True)
    return out
