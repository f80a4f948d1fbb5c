"""What is wrong with a mesh file its reader (trimesh) failed on, in plain words.

trimesh's readers fail with their own exceptions (an ``IndexError`` of numpy for an OBJ face
past the last vertex, a ``KeyError: 'y'`` for a PLY vertex without a y coordinate, a bare
``StopIteration`` for a 3MF without a model), whose words mean nothing to the person who
handed in the file. :func:`explain` reads the file again, by the format's own rules, to say
what it lacks or where it goes wrong; when it finds nothing it names the format only. The
reader's exception stays the message's cause (``SYNTH_TRACEBACK=1`` prints it), never its
text.
"""

from __future__ import annotations

import io
import json
import os
import re
import zipfile
from pathlib import Path

__all__ = ["explain", "obj_problem"]

#: The PLY header's coordinate properties of a vertex.
_XYZ = ("x", "y", "z")
#: A line of an OBJ file quoted in a message is cut to this many characters.
_QUOTE = 40


def explain(path: Path, ext: str, data: bytes) -> str:
    """Why ``data``, the bytes of ``path`` (a file of format ``ext``, lower case, no dot),
    cannot be read as a mesh: the first thing found wrong, in words, else that it is not a
    readable file of that format."""
    check = {"obj": _obj, "ply": _ply, "3mf": _threemf, "gltf": _gltf}.get(ext)
    try:
        found = check(path, data) if check is not None else None
    except Exception:  # noqa: BLE001 - a file odd enough to trip this check too: say less
        found = None
    return found or f"not a readable {ext.upper()} file (damaged, cut short, or not " \
        f"{ext.upper()} at all)"


def _count(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"


def _quoted(line: str) -> str:
    line = line.strip()
    return repr(line if len(line) <= _QUOTE else line[: _QUOTE - 3] + "...")


def obj_problem(data: bytes) -> str | None:
    """The first line of an OBJ file that breaks its rules, in words: a vertex without three
    numbers, a face corner that is not a vertex number, or one past the file's vertices (OBJ
    numbers them from 1; negative numbers count back from the last vertex given so far);
    None when every ``v`` and ``f`` line is sound."""
    lines = data.decode("utf-8", "replace").splitlines()
    total = sum(1 for line in lines if line.split()[:1] == ["v"])
    seen = 0
    face = 0
    for number, line in enumerate(lines, start=1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if words[0] == "v":
            try:
                values = [float(w) for w in words[1:]]
            except ValueError:
                return (f"line {number}: a vertex must be three numbers (x y z), found "
                        f"{_quoted(line)}")
            if len(values) < 3:
                return (f"line {number}: a vertex must be three numbers (x y z), found "
                        f"{len(values)} in {_quoted(line)}")
            seen += 1
        elif words[0] == "f":
            if len(words) < 4:
                return (f"line {number}: a face needs at least three corners, found "
                        f"{_quoted(line)}")
            for corner in words[1:]:
                head = corner.split("/", 1)[0]
                if not re.fullmatch(r"[+-]?\d+", head):
                    return (f"line {number}: a face's corners must be vertex numbers, found "
                            f"{corner!r} in {_quoted(line)}")
                index = int(head)
                at = index if index > 0 else seen + 1 + index
                if index == 0 or not 1 <= at <= total:
                    return (f"face {face + 1} (line {number}) refers to vertex {index}, but the "
                            f"file has {_count(total, 'vertex', 'vertices')} (numbered from 1; "
                            "a corrupt file?)")
            face += 1
    return None


def _obj(path: Path, data: bytes) -> str | None:
    return obj_problem(data)


def _ply(path: Path, data: bytes) -> str | None:
    end = data.find(b"end_header")
    if end < 0:
        return "the PLY header is cut short (it has no end_header line)"
    header = data[:end].decode("ascii", "replace").splitlines()
    if not header or header[0].strip() != "ply":
        return "not a PLY file (it does not begin with the line 'ply')"
    form = next((line.split() for line in header if line.split()[:1] == ["format"]), None)
    if form is None or len(form) < 2 or form[1] not in (
            "ascii", "binary_little_endian", "binary_big_endian"):
        return ("the PLY header declares no format (ascii, binary_little_endian or "
                "binary_big_endian)")
    elements: dict[str, list[str]] = {}
    current: list[str] | None = None
    for line in header[1:]:
        words = line.split()
        if words[:1] == ["element"] and len(words) >= 2:
            current = elements.setdefault(words[1], [])
        elif words[:1] == ["property"] and current is not None and len(words) >= 3:
            current.append(words[-1])
    if "vertex" not in elements:
        return "the PLY header declares no vertex element"
    for axis in _XYZ:
        if axis not in elements["vertex"]:
            return f"the PLY header declares no {axis} coordinate for its vertices"
    if "face" in elements and elements["face"] and not {
            "vertex_indices", "vertex_index"} & set(elements["face"]):
        return ("the PLY header declares faces without a vertex_indices list (the corners of "
                "each face)")
    return "its data do not match its PLY header (cut short, or values of the wrong kind)"


def _threemf(path: Path, data: bytes) -> str | None:
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        names = archive.namelist()
    except (zipfile.BadZipFile, ValueError, OSError):
        return "not a 3MF file (a 3MF file is a ZIP archive, and this is none)"
    if not any("3d/3dmodel.model" in n.lower() for n in names):
        return "the 3MF holds no model (its archive has no 3D/3dmodel.model)"
    return "the 3MF's model is not readable (not the 3MF model XML, or damaged)"


def _gltf(path: Path, data: bytes) -> str | None:
    try:
        tree = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        return "not a glTF file (a glTF file is JSON, and this is not)"
    if not isinstance(tree, dict):
        return "not a glTF file (its JSON is not an object)"
    folder = Path(os.path.abspath(path.parent))
    for what in ("buffers", "images"):
        items = tree.get(what, [])
        for item in items if isinstance(items, list) else ():
            uri = item.get("uri") if isinstance(item, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:"):
                continue
            name = what[:-1]
            target = Path(os.path.abspath(folder / uri))
            if target != folder and folder not in target.parents:
                return f"the glTF refers to a{'n' if name == 'image' else ''} {name} " \
                    f"outside its folder: {uri}"
            if not target.is_file():
                return f"the glTF refers to a{'n' if name == 'image' else ''} {name} file " \
                    f"that does not exist: {uri}"
    return None
