"""What kind of file a path holds, and the one message for a file of the wrong kind.

synth reads meshes (STL, OBJ, PLY, OFF, GLB/GLTF, 3MF), JSON documents (grasp files,
candidate files, gripper descriptions), arrays (NPZ, HDF5), YAML pose files and SQLite grasp
databases. A file handed in where another kind belongs (a mesh as the grasp file, a grasp
file or a database as the mesh) is named as what it is, in one line, before any reader tries
it and fails with a parser's words::

    bracket.stl: a mesh file (.stl), not a grasp file written by synth plan --out; ...

The kind is read from the file's first bytes where they say it (SQLite, HDF5, NPZ/ZIP, GLB,
PLY, OFF, binary STL, JSON), else from its extension. This module imports nothing heavy:
every command checks its files with it before loading numpy, trimesh or a database.
"""

from __future__ import annotations

import json
import os
import re
import struct
from pathlib import Path
from typing import Any

from synth.errors import InputError

__all__ = ["MESH_FORMATS", "KINDS", "kind_of", "describe", "require_kind", "read_json"]

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
#: What the ``format`` field of synth's JSON documents names.
_JSON_FORMATS: dict[str, str] = {
    "synth.grasps": "a grasp file (synth plan --out)",
    "synth.gripper_grasps": "a gripper grasp file (synth plan --gripper --out)",
    "synth.ranked": "a ranked candidate file (synth rank --out)",
    "synth.ranked_gripper": "a ranked pose file (synth rank --gripper --out)",
    "synth.scores": "a score file (synth score --out)",
    "synth.gripper": "a gripper description",
}


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


def kind_of(path: str | os.PathLike[str]) -> str | None:
    """The kind of file ``path`` holds: one of :data:`KINDS`, or None (unknown, or not a
    readable file).

    Examples
    --------
    >>> kind_of("meshes/cube.stl")  # doctest: +SKIP
    'mesh'
    """
    p = Path(path)
    head = _head(p)
    if head is None:
        return None
    ext = p.suffix.lower().lstrip(".")
    if head.startswith(_SQLITE):
        return "database"
    if head.startswith(_HDF5):
        return "hdf5"
    if head.startswith(_ZIP):
        return "mesh" if ext == "3mf" else "npz" if ext == "npz" else None
    if head.startswith(b"glTF") or head[:4] in (b"ply\n", b"ply\r") or head.startswith(b"OFF"):
        return "mesh"
    if ext == "gltf":
        return "mesh"
    text = head.lstrip()
    if text[:1] in (b"{", b"["):
        return "json"
    if ext in MESH_FORMATS or _binary_stl(p, head) or text[:6].lower() == b"solid ":
        return "mesh"
    if ext in ("yaml", "yml"):
        return "yaml"
    return None


def describe(path: str | os.PathLike[str]) -> str:
    """What ``path`` holds, in words for a message: ``"a mesh file (.stl)"``, ``"a grasp file
    (synth plan --out), JSON"``, ``"an SQLite database"``; ``""`` when unknown."""
    p = Path(path)
    kind = kind_of(p)
    if kind is None:
        return ""
    if kind == "mesh":
        return f"a mesh file (.{p.suffix.lower().lstrip('.') or 'stl'})"
    if kind == "json":
        head = _head(p) or b""
        found = re.search(rb'"format"\s*:\s*"([^"]{1,64})"', head)
        named = _JSON_FORMATS.get(found.group(1).decode("ascii", "replace")) if found else None
        return f"{named}, JSON" if named else _WORDS["json"]
    return _WORDS[kind]


def require_kind(path: str | os.PathLike[str], accepted: tuple[str, ...], what: str,
                 hint: str = "", error: type[InputError] = InputError) -> None:
    """Refuse a file of another kind than ``accepted`` with one line naming what it is.

    A file whose kind cannot be told (a missing file, an unknown layout) passes: its reader
    says what is wrong with it.

    Parameters
    ----------
    path : path
    accepted : tuple of str
        Kinds of :data:`KINDS` that belong here.
    what : str
        What belongs here, for the message (``"a grasp file written by synth plan --out"``).
    hint : str
        What to do instead, appended after a semicolon.
    error : type
        The :class:`~synth.errors.InputError` class raised (``MeshError`` for a mesh, ...).

    Raises
    ------
    InputError
        The file is of another kind.

    Examples
    --------
    >>> require_kind("meshes/cube.stl", ("json",), "a grasp file")  # doctest: +SKIP
    Traceback (most recent call last):
    synth.errors.InputError: meshes/cube.stl: a mesh file (.stl), not a grasp file
    """
    kind = kind_of(path)
    if kind is None or kind in accepted:
        return
    raise error(f"{path}: {describe(path)}, not {what}" + (f"; {hint}" if hint else ""))


def read_json(path: str | os.PathLike[str], what: str = "a JSON file", hint: str = "") -> Any:
    """The JSON document of a file, a file of another kind named as such.

    Parameters
    ----------
    path : path
    what : str
        What the file should be, for the message when it is not JSON.
    hint : str
        What to do instead when it is of another kind (see :func:`require_kind`).

    Raises
    ------
    InputError
        The file is missing, cannot be read, is of another kind (a mesh, a database), or is
        not JSON (the message names it).
    """
    name = str(path)
    require_kind(path, ("json",), what, hint)
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
