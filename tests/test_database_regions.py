"""Contact regions and placement tolerances in a grasp database (schema 3)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from synth.cli import main
from synth.database import GraspDatabase, build_database, export_database
from synth.errors import InputError

MESHES = Path(__file__).resolve().parent.parent / "meshes"


def test_build_with_regions_stores_and_ranks_by_tolerance(tmp_path, capsys):
    folder = tmp_path / "meshes"
    folder.mkdir()
    shutil.copyfile(MESHES / "cube.stl", folder / "cube.stl")
    out = tmp_path / "g.sqlite"
    build_database([folder], out, {"evals": 3000, "top": 4, "regions": True}, workers=0,
                   quiet=True)
    with GraspDatabase(out) as db:
        by_rank = db.top("cube", 4)
        by_tol = db.top("cube", 4, "tolerance")
    assert all(g.tolerance is not None and g.contact_regions is not None for g in by_rank)
    assert [g.tolerance for g in by_tol] == sorted((g.tolerance for g in by_rank), reverse=True)
    assert by_rank[0].contact_regions["tolerance"] == by_rank[0].tolerance
    assert len(by_rank[0].contact_regions["polygons"]) == by_rank[0].n_contacts
    assert main(["db", "top", str(out), "cube", "--rank-by", "tolerance"]) == 0
    assert "tolerance" in capsys.readouterr().out
    export_database(out, tmp_path / "g.npz")
    with np.load(tmp_path / "g.npz") as z:
        assert np.allclose(np.sort(z["tolerance"]), np.sort([g.tolerance for g in by_rank]))
        assert json.loads(str(z["contact_regions"][0]))["certified"] in (True, False)
    export_database(out, tmp_path / "g.json")
    grasp = json.loads((tmp_path / "g.json").read_text())["meshes"][0]["grasps"][0]
    assert grasp["tolerance"] == by_rank[0].tolerance


def test_build_without_regions_stores_none(tmp_path):
    folder = tmp_path / "meshes"
    folder.mkdir()
    shutil.copyfile(MESHES / "cube.stl", folder / "cube.stl")
    out = tmp_path / "g.sqlite"
    build_database([folder], out, {"evals": 3000, "top": 2}, workers=0, quiet=True)
    with GraspDatabase(out) as db:
        assert all(g.tolerance is None for g in db.top("cube", 2))
        with pytest.raises(InputError, match="built without --regions"):
            db.top("cube", 2, "tolerance")  # an order by a measure none of them has
    export_database(out, tmp_path / "g.npz")
    with np.load(tmp_path / "g.npz") as z:
        assert np.isnan(z["tolerance"]).all() and set(z["contact_regions"].tolist()) == {""}
