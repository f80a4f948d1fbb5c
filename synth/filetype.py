"""What kind of file a path holds, and the one message for a file of the wrong kind.

synth reads meshes (STL, OBJ, PLY, OFF, GLB/GLTF, 3MF), JSON documents (grasp files,
candidate files, gripper descriptions), arrays (NPZ, HDF5), YAML pose files and SQLite grasp
databases. A file handed in where another kind belongs (a mesh as the grasp file, a grasp
file or a database as the mesh) is named as what it is, in one line, before any reader tries
it and fails with a parser's words::

    bracket.stl: a mesh file (STL), not a grasp file written by synth plan --out; plan it
    first (synth plan bracket.stl --out GRASPS.json)

The kind is read from the file's first bytes where they say it (SQLite, HDF5, NPZ/ZIP, GLB,
PLY, OFF, binary STL, JSON), else from its extension. This module imports nothing heavy:
every command checks its files with it before loading numpy, trimesh or a database.
"""

from __future__ import annotations

import json
import os
import re
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from synth.errors import DatabaseFileError, InputError, MeshError

__all__ = ["MESH_FORMATS", "KINDS", "Expected", "MESH", "CANDIDATES", "POSES", "GRASPS",
           "DATABASE", "kind_of", "describe", "require", "read_json"]

#: File extensions of the mesh formats synth reads (through trimesh), without the dot.
MESH_FORMATS: tuple[str, ...] = ("stl", "obj", "ply", "off", "glb", "gltf", "3mf")

#: The kinds :func:`kind_of` tells apart.
KINDS: tuple[str, ...] = ("mesh", "json", "npz", "hdf5", "yaml", "database")

#: The words of each kind in a message.
_WORDS: dict[str, str] = {
    "mesh": "a mesh file", "json": "a JSON file", "npz": "an NPZ array file",
    "hdf5": "an HDF5 file", "yaml": "a YAML file", "database": "an SQLite database",
}
#: Bytes read from the start of a file to tell its kind.
_HEAD = 4096
_SQLITE = b"SQLite format 3\x00"
_HDF5 = b"\x89HDF\r\n\x1a\n"
_ZIP = b"PK\x03\x04"
#: The start of a JSON array (of objects, arrays, strings, numbers or literals), not a TOML
#: or INI file's ``[section]`` header, which also starts with a bracket.
_JSON_ARRAY = re.compile(rb"\[\s*(?:\[\s*)*(?:[{\"\]\-0-9]|(?:true|false|null|NaN|Infinity)\b)")
#: Mesh formats told by their first bytes, and their names.
_MESH_MAGIC: tuple[tuple[bytes, str], ...] = ((b"glTF", "GLB"), (b"ply\n", "PLY"),
                                              (b"ply\r", "PLY"), (b"OFF", "OFF"))
#: What the ``format`` field of synth's JSON documents names.
_JSON_FORMATS: dict[str, str] = {
    "synth.grasps": "a grasp file (JSON written by synth plan --out)",
    "synth.gripper_grasps": "a gripper grasp file (JSON written by synth plan --gripper --out)",
    "synth.ranked": "a ranked candidate file (JSON written by synth rank --out)",
    "synth.ranked_gripper": "a ranked pose file (JSON written by synth rank --gripper --out)",
    "synth.scores": "a score file (JSON written by synth score --out)",
    "synth.gripper": "a gripper description (JSON)",
}


@dataclass(frozen=True)
class Expected:
    """What a command reads in one place: the kinds of file that belong there, in words.

    Attributes
    ----------
    kinds : tuple of str
        Kinds of :data:`KINDS` that belong.
    what : str
        What belongs, for the message (``"a grasp file (synth plan --out)"``).
    hints : dict of str to str
        What to do instead, by the kind found; ``{path}`` is the file's name.
    error : type
        The :class:`~synth.errors.InputError` class raised for a file of another kind.
    """

    kinds: tuple[str, ...]
    what: str
    hints: dict[str, str] = field(default_factory=dict)
    error: type[InputError] = InputError


#: A mesh: ``synth plan MESH``, ``synth rank MESH ...``, ``synth sim --mesh``.
MESH = Expected(("mesh",), "a mesh file (STL, OBJ, PLY, OFF, GLB/GLTF or 3MF)",
                {"database": "its grasps are read with synth db top {path} MESH_NAME"},
                MeshError)
#: Contact sets: ``synth score FILE``, ``synth rank MESH CANDIDATES``.
CANDIDATES = Expected(("json", "npz"), "a candidate file (JSON or NPZ)",
                      {"mesh": "synth plan {path} plans grasps on it, synth rank {path} "
                       "CANDIDATES ranks contact sets on it"})
#: Gripper poses: ``synth rank MESH POSES --gripper``.
POSES = Expected(("json", "npz", "hdf5", "yaml"), "a gripper pose file (ACRONYM .h5, "
                 "GraspGen .json, isaac_grasp .yaml, NPZ or JSON)",
                 {"mesh": "synth rank {path} POSES --gripper NAME ranks poses on it"})
#: A grasp file: ``synth sim GRASPS.json``.
GRASPS = Expected(("json",), "a grasp file written by synth plan --out",
                  {"mesh": "plan it first (synth plan {path} --out GRASPS.json)"})
#: A grasp database: ``synth db info/top/export DATABASE``.
DATABASE = Expected(("database",), "a grasp database (SQLite, written by synth db build)",
                    {"mesh": "build one first (synth db build {path} --out DB.sqlite)"},
                    DatabaseFileError)


def _head(path: Path) -> bytes | None:
    try:
        with open(path, "rb") as fh:
            return fh.read(_HEAD)
    except OSError:
        return None


def _binary_stl(path: Path, head: bytes) -> bool:
    """An 80-byte header and a triangle count that matches the file's size exactly."""
    if len(head) < 84:
        return False
    try:
        size = os.path.getsize(path)
    except OSError:
        return False
    return size == 84 + 50 * struct.unpack("<I", head[80:84])[0]


def _sniff(path: Path) -> tuple[str, str] | None:
    """The kind of file and, for a mesh, its format's name (``"STL"``); None: unknown."""
    head = _head(path)
    if head is None:
        return None
    ext = path.suffix.lower().lstrip(".")
    if head.startswith(_SQLITE):
        return "database", ""
    if head.startswith(_HDF5):
        return "hdf5", ""
    if head.startswith(_ZIP):
        return ("mesh", "3MF") if ext == "3mf" else ("npz", "") if ext == "npz" else None
    for magic, name in _MESH_MAGIC:
        if head.startswith(magic):
            return "mesh", name
    if ext == "gltf":  # JSON too
        return "mesh", "GLTF"
    text = head.lstrip()
    if text[:1] == b"{" or _JSON_ARRAY.match(text) or (ext == "json" and text[:1] == b"["):
        return "json", ""
    if ext in MESH_FORMATS:
        return "mesh", ext.upper()
    if _binary_stl(path, head) or text[:6].lower() == b"solid ":
        return "mesh", "STL"
    if ext in ("yaml", "yml"):
        return "yaml", ""
    return None


def kind_of(path: str | os.PathLike[str]) -> str | None:
    """The kind of file ``path`` holds: one of :data:`KINDS`, or None (unknown, or not a
    readable file).

    Examples
    --------
    >>> kind_of("meshes/cube.stl")  # doctest: +SKIP
    'mesh'
    """
    found = _sniff(Path(path))
    return None if found is None else found[0]


def describe(path: str | os.PathLike[str]) -> str:
    """What ``path`` holds, in words for a message: ``"a mesh file (STL)"``, ``"a grasp file
    (JSON written by synth plan --out)"``, ``"an SQLite database"``; ``""`` when unknown."""
    p = Path(path)
    found = _sniff(p)
    if found is None:
        return ""
    kind, name = found
    if kind == "mesh":
        return f"a mesh file ({name})"
    if kind == "json":
        head = _head(p) or b""
        fmt = re.search(rb'"format"\s*:\s*"([^"]{1,64})"', head)
        named = _JSON_FORMATS.get(fmt.group(1).decode("ascii", "replace")) if fmt else None
        return named or _WORDS["json"]
    return _WORDS[kind]


def require(path: str | os.PathLike[str], expected: Expected) -> None:
    """Refuse a file of another kind than ``expected`` with one line naming what it is.

    A file whose kind cannot be told (a missing file, an unknown layout) passes: its reader
    says what is wrong with it.

    Parameters
    ----------
    path : path
    expected : Expected
        What belongs here (:data:`MESH`, :data:`CANDIDATES`, :data:`POSES`, :data:`GRASPS`,
        :data:`DATABASE`, or one of the caller's).

    Raises
    ------
    InputError
        The file is of another kind (``expected.error``, a subclass).

    Examples
    --------
    >>> require("meshes/cube.stl", GRASPS)  # doctest: +SKIP
    Traceback (most recent call last):
    synth.errors.InputError: meshes/cube.stl: a mesh file (STL), not a grasp file written by
    synth plan --out; plan it first (synth plan meshes/cube.stl --out GRASPS.json)
    """
    if Path(path).is_dir():
        raise expected.error(f"{path}: a folder, not {expected.what}")
    kind = kind_of(path)
    if kind is None or kind in expected.kinds:
        return
    hint = expected.hints.get(kind, "").replace("{path}", str(path))
    raise expected.error(f"{path}: {describe(path)}, not {expected.what}"
                         + (f"; {hint}" if hint else ""))


def read_json(path: str | os.PathLike[str], expected: Expected = GRASPS) -> Any:
    """The JSON document of a file, a file of another kind named as such.

    Parameters
    ----------
    path : path
    expected : Expected
        What the file should be (its kinds must include ``"json"``), for the messages.

    Raises
    ------
    InputError
        The file is missing, cannot be read, is of another kind (a mesh, a database), or is
        not JSON (the message names it).
    """
    name, what = str(path), expected.what
    require(path, expected)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{name}: a folder, not {what}") from None
    except UnicodeDecodeError:
        raise InputError(f"{name}: not a text file, so not {what}") from None
    except OSError as e:
        raise InputError(f"{name}: cannot be read ({e.strerror or e})") from e
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise InputError(f"{name}: not JSON ({e.msg} at line {e.lineno}), so not "
                         f"{what}") from None
    except RecursionError:
        raise InputError(f"{name}: JSON nested too deep to read") from None
    except ValueError:  # an integer past Python's digit limit (sys.get_int_max_str_digits)
        raise InputError(f"{name}: holds a number too long to read (more than "
                         f"{sys.get_int_max_str_digits():,} digits), so not {what}") from None
