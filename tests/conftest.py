"""Shared pytest setup: headless plotting, both simplex routes, the database fixtures."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from tests.db_support import PARAMS, PLANNER, make_mesh_dir  # noqa: E402


@pytest.fixture(params=["numpy", "numba"])
def pivot_route(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a test with the numpy lock-step simplex, then with the numba kernel.

    Sets ``SYNTH_SIMPLEX``, whatever the batch size; the numba run is skipped without numba.
    """
    if request.param == "numba":
        pytest.importorskip("numba")
    monkeypatch.setenv("SYNTH_SIMPLEX", request.param)
    return request.param


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
