"""Mesh paths in result files (synth/paths.py): stored relative to the storing file's folder,
resolved from there whatever the current folder; and the provenance of a gripper plan's
three files (run id, mesh path and sha256), as a point-finger plan's."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path

import pytest

from synth.cli import main
from synth.errors import InputError
from synth.paths import resolve_mesh_path, stored_mesh_path

ROOT = Path(__file__).resolve().parents[1]


def test_stored_relative_to_the_documents_folder_and_resolved_back(tmp_path: Path) -> None:
    mesh = tmp_path / "a" / "m.stl"
    doc = tmp_path / "b" / "c" / "p.json"
    assert stored_mesh_path(mesh, doc) == "../../a/m.stl"
    assert stored_mesh_path(mesh, tmp_path / "a" / "p.json") == "m.stl"
    assert resolve_mesh_path("../../a/m.stl", doc) == mesh
    assert stored_mesh_path(mesh, None) == str(mesh)  # no file: absolute
    assert resolve_mesh_path(str(mesh), doc) == mesh  # an absolute path stays


def test_a_document_reached_through_a_linked_folder_still_finds_its_mesh(tmp_path: Path
                                                                        ) -> None:
    (tmp_path / "deep" / "er").mkdir(parents=True)
    mesh = tmp_path / "m.stl"
    mesh.write_text("solid\n")
    os.symlink(tmp_path / "deep" / "er", tmp_path / "link")
    doc = tmp_path / "link" / "p.json"  # really deep/er/p.json
    stored = stored_mesh_path(mesh, doc)
    assert stored == "../../m.stl"  # from the real folder, not "../m.stl" from the link's
    assert resolve_mesh_path(stored, doc) == mesh and resolve_mesh_path(stored, doc).exists()


@pytest.mark.parametrize("bad", [None, "", 3, ["m.stl"]])
def test_a_stored_value_that_is_not_a_path_is_refused_naming_the_field(bad) -> None:
    with pytest.raises(InputError, match=r"p\.json: field mesh\.path: expected"):
        resolve_mesh_path(bad, "p.json")


@pytest.mark.parametrize("gripper", [False, True])
def test_plan_files_resolve_their_mesh_from_another_folder(gripper, tmp_path, monkeypatch,
                                                           capsys) -> None:
    """synth plan meshes/cube.stl --out /tmp/x/c.json, then read from elsewhere."""
    work = tmp_path / "work"
    (work / "meshes").mkdir(parents=True)
    shutil.copy(ROOT / "meshes" / "cube.stl", work / "meshes" / "cube.stl")
    out = tmp_path / "x" / "c.json"
    out.parent.mkdir()
    monkeypatch.chdir(work)
    opts = (["--units", "cm", "--gripper", "franka", "--samples", "60", "--top", "2"]
            if gripper else ["--units", "dm", "--evals", "300", "--top", "1"])
    assert main(["plan", "meshes/cube.stl", "--out", str(out), "--quiet", *opts]) == 0
    capsys.readouterr()
    monkeypatch.chdir(tmp_path / "x")  # another folder, where meshes/cube.stl is not
    doc = json.loads(out.read_text())
    mesh = doc["mesh"]
    assert mesh["path"] == "../work/meshes/cube.stl"
    found = resolve_mesh_path(mesh["path"], out)
    assert found == work / "meshes" / "cube.stl"
    assert mesh["sha256"] == hashlib.sha256(found.read_bytes()).hexdigest()
    assert mesh["units"] == ("centimeters" if gripper else "decimeters")
    assert isinstance(doc["run_id"], str)


def test_a_gripper_plans_png_and_glb_carry_its_run_id_and_mesh(tmp_path, capsys) -> None:
    trimesh = pytest.importorskip("trimesh")
    from PIL import Image

    out = tmp_path / "c.json"
    assert main(["plan", str(ROOT / "meshes" / "cube.stl"), "--units", "cm", "--gripper",
                 "franka", "--samples", "60", "--top", "2", "--out", str(out)]) == 0
    assert "(run " in capsys.readouterr().out
    doc = json.loads(out.read_text())
    run, sha = doc["run_id"], doc["mesh"]["sha256"]
    text = Image.open(out.with_suffix(".png")).text
    assert text["synth.run_id"] == run and text["synth.mesh_sha256"] == sha
    assert run in text["Title"] and "cube.stl" in text["Title"]
    extras = trimesh.load(out.with_suffix(".glb")).metadata["synth"]
    assert extras["run_id"] == run and extras["mesh_sha256"] == sha
    assert extras["pose"] == doc["grasps"][0]["pose"] and extras["params"]["gripper"] == "franka"
