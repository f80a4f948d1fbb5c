"""The right message for the wrong file (:mod:`synth.filetype`).

A mesh where a grasp, candidate, pose or database file belongs, and a grasp file, candidate
file or database where a mesh belongs, is named as what it is: one line, exit status 2, for
every command that reads files.
"""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from synth.cli import main
from synth.errors import DatabaseFileError, InputError, MeshError
from synth.filetype import (
    CANDIDATES,
    DATABASE,
    GRASPS,
    MESH,
    MESH_FORMATS,
    describe,
    kind_of,
    read_json,
    require,
)
from tests.cli_support import CUBE_FC

MESHES = Path(__file__).resolve().parent.parent / "meshes"


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    """One file of each kind: a binary STL, an ASCII PLY, a grasp file, a candidate file, an
    NPZ, an SQLite database, a GLB-less STL renamed .json, and a text file."""
    out = {"mesh": tmp_path / "cube.stl", "grasps": tmp_path / "cube.grasps.json",
           "candidates": tmp_path / "cands.json", "npz": tmp_path / "cands.npz",
           "database": tmp_path / "grasps.sqlite", "stl_as_json": tmp_path / "mesh.json",
           "ply": tmp_path / "cube.ply", "text": tmp_path / "notes.txt"}
    shutil.copy(MESHES / "cube.stl", out["mesh"])
    shutil.copy(MESHES / "cube.stl", out["stl_as_json"])
    out["ply"].write_text("ply\nformat ascii 1.0\nelement vertex 0\nend_header\n")
    out["grasps"].write_text(json.dumps({"format": "synth.grasps", "version": 1,
                                         "grasps": []}))
    out["candidates"].write_text(json.dumps([CUBE_FC]))
    np.savez(out["npz"], points=np.zeros((1, 7, 3)), normals=np.zeros((1, 7, 3)))
    with sqlite3.connect(out["database"]) as db:
        db.execute("CREATE TABLE meta (key TEXT)")
    out["text"].write_text("hello\n")
    return out


def test_kinds_are_told_by_content_then_extension(files: dict[str, Path]) -> None:
    assert kind_of(files["mesh"]) == "mesh"
    assert kind_of(files["ply"]) == "mesh"
    assert kind_of(files["stl_as_json"]) == "mesh"  # the bytes of a binary STL
    assert kind_of(files["grasps"]) == "json"
    assert kind_of(files["candidates"]) == "json"
    assert kind_of(files["npz"]) == "npz"
    assert kind_of(files["database"]) == "database"
    assert kind_of(files["text"]) is None
    assert kind_of(files["mesh"].parent / "missing.stl") is None
    assert kind_of(files["mesh"].parent) is None  # a folder
    # a bracket starts a JSON array, and a TOML or INI file's section header too
    folder = files["text"].parent
    for text, kind in (("[project]\nname = 'x'\n", None), ("[[tool.x]]\na = 1\n", None),
                       ("[section]\nkey=value\n", None), ('[{"a": 1}]', "json"),
                       ("[\n  [1, 2], [3]\n]", "json"), ("[]", "json"), ("[null]", "json"),
                       ("[-1.5]", "json")):
        (folder / "x.cfg").write_text(text)
        assert kind_of(folder / "x.cfg") == kind, text
    (folder / "x.json").write_text("[project]\n")  # named JSON: read (and refused) as JSON
    assert kind_of(folder / "x.json") == "json"
    for name in MESH_FORMATS:  # every mesh extension, even with contents it cannot tell
        (files["text"].parent / f"x.{name}").write_text("# a mesh\n")
        assert kind_of(files["text"].parent / f"x.{name}") == "mesh", name


def test_descriptions_name_synth_documents(files: dict[str, Path]) -> None:
    assert describe(files["mesh"]) == "a mesh file (STL)"
    assert describe(files["stl_as_json"]) == "a mesh file (STL)"
    assert describe(files["ply"]) == "a mesh file (PLY)"
    assert describe(files["grasps"]) == "a grasp file (JSON written by synth plan --out)"
    assert describe(files["candidates"]) == "a JSON file"
    assert describe(files["database"]) == "an SQLite database"
    assert describe(files["text"]) == ""


def test_require_names_the_file_what_it_is_and_what_belongs(files: dict[str, Path]) -> None:
    with pytest.raises(InputError) as e:
        require(files["mesh"], GRASPS)
    assert str(e.value) == (f"{files['mesh']}: a mesh file (STL), not a grasp file written by "
                            f"synth plan --out; plan it first (synth plan {files['mesh']} "
                            "--out GRASPS.json)")
    with pytest.raises(MeshError, match="an SQLite database, not a mesh file"):
        require(files["database"], MESH)
    with pytest.raises(DatabaseFileError, match="a mesh file .STL., not a grasp database"):
        require(files["mesh"], DATABASE)
    with pytest.raises(InputError, match="an SQLite database, not a candidate file"):
        require(files["database"], CANDIDATES)
    # files of the kind asked, and files whose kind is unknown (their reader says why), pass
    for path, expected in ((files["mesh"], MESH), (files["ply"], MESH),
                           (files["grasps"], GRASPS), (files["npz"], CANDIDATES),
                           (files["candidates"], CANDIDATES), (files["database"], DATABASE),
                           (files["text"], MESH), (files["text"], GRASPS)):
        require(path, expected)


def test_read_json_refuses_other_kinds_by_name(files: dict[str, Path]) -> None:
    assert read_json(files["grasps"])["format"] == "synth.grasps"
    with pytest.raises(InputError, match="an SQLite database, not a grasp file"):
        read_json(files["database"])
    binary = files["text"].with_name("bin.json")
    binary.write_bytes(b"\xff\xfe\x00{")
    with pytest.raises(InputError, match="not a text file, so not a grasp file"):
        read_json(binary)
    with pytest.raises(InputError, match="no such file"):
        read_json(files["text"].with_name("missing.json"))


def _refused(capsys: pytest.CaptureFixture[str], *argv: object) -> str:
    """Run a command that must refuse its input: exit status 2 and one line on stderr."""
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert status == 2, (argv, status, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("synth: error: "), (argv, err)
    assert "Traceback" not in err
    return lines[0]


def test_every_command_names_a_file_of_the_wrong_kind(files: dict[str, Path], tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    mesh, grasps, db = files["mesh"], files["grasps"], files["database"]
    cases = [
        # a grasp file, a database, an NPZ where the mesh belongs
        (["plan", grasps, "--no-files"], f"{grasps}: a grasp file (JSON written by synth plan "
         "--out), not a mesh file"),
        (["plan", db, "--no-files"], f"{db}: an SQLite database, not a mesh file"),
        (["plan", files["npz"], "--no-files"], "an NPZ array file, not a mesh file"),
        (["rank", db, files["candidates"]], f"{db}: an SQLite database, not a mesh file"),
        (["sim", grasps, "--mesh", grasps, "--no-files"], "a grasp file (JSON written by "
         "synth plan --out), not a mesh file"),
        # a mesh or a database where candidates, poses or a grasp file belong
        (["rank", files["candidates"], mesh], f"{mesh}: a mesh file (STL), not a candidate "
         f"file (JSON or NPZ); synth plan {mesh} plans grasps on it, synth rank {mesh} "
         "CANDIDATES"),
        (["rank", mesh, db], f"{db}: an SQLite database, not a candidate file"),
        (["rank", mesh, mesh, "--gripper", "franka", "--units", "m"],
         f"{mesh}: a mesh file (STL), not a gripper pose file"),
        (["score", mesh], f"{mesh}: a mesh file (STL), not a candidate file (JSON or NPZ)"),
        (["score", files["stl_as_json"]], "mesh.json: a mesh file (STL), not a candidate file"),
        (["score", db], f"{db}: an SQLite database, not a candidate file"),
        (["sim", mesh], f"{mesh}: a mesh file (STL), not a grasp file written by synth plan"),
        (["sim", mesh, "--no-files"], f"{mesh}: a mesh file (STL), not a grasp file"),
        (["sim", db, "--no-files"], f"{db}: an SQLite database, not a grasp file"),
        # a mesh or a grasp file where the database belongs
        (["db", "info", mesh], f"{mesh}: a mesh file (STL), not a grasp database (SQLite, "
         f"written by synth db build); build one first (synth db build {mesh} --out "
         "DB.sqlite)"),
        (["db", "info", grasps], "a grasp file (JSON written by synth plan --out), not a grasp "
         "database"),
        (["db", "top", mesh, "cube"], f"{mesh}: a mesh file (STL), not a grasp database"),
        (["db", "export", mesh, "--out", tmp_path / "x.h5"], "a mesh file (STL), not a grasp "
         "database"),
        (["db", "export", grasps, "--out", tmp_path / "x.json"], "not a grasp database"),
    ]
    for argv, words in cases:
        before = sorted(p.name for p in tmp_path.iterdir())
        line = _refused(capsys, *argv)
        assert words in line, (argv, line)
        assert sorted(p.name for p in tmp_path.iterdir()) == before, argv  # nothing written


def test_a_folder_and_a_number_too_long_are_named(tmp_path):
    """A folder where a file belongs is called a folder; an integer past Python's digit limit
    is bad input in words, not Python's advice to raise the limit."""
    from synth.filetype import GRASPS, read_json

    folder = tmp_path / "g.json"
    folder.mkdir()
    with pytest.raises(InputError, match="g.json: a folder, not a grasp file"):
        read_json(folder, GRASPS)
    big = tmp_path / "big.json"
    big.write_text('{"format": ' + "9" * 5000 + "}")
    with pytest.raises(InputError, match="holds a number too long to read") as e:
        read_json(big, GRASPS)
    assert "set_int_max_str_digits" not in str(e.value)
