"""Plain arrays of gripper poses: NPZ, or JSON lists of 4 x 4 matrices.

NPZ: ``poses`` (or ``transforms``) of shape (n, 4, 4), optional ``widths`` (n,) and a 0-d
string ``units`` (default ``m``, the ecosystem's convention; any trimesh unit name).
JSON: a list of 4 x 4 matrices, or an object with ``poses`` (or ``transforms``), optional
``widths`` and ``units``; or synth's own ``synth.gripper_grasps`` document (``synth plan
--gripper``), whose poses and widths are in its ``units``. There is no object scale: the poses
are on the mesh at its own size in their unit.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from synth.errors import InputError, shown
from synth.formats.graspgen import matrices
from synth.formats.poses import GripperPoses, number_list

__all__ = ["read_npz", "read_json_poses", "unit_metres", "load_npz"]

#: First bytes of a ZIP archive (an NPZ file is one; an empty one starts with the second).
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")
#: First bytes of a single NumPy array file (``numpy.save``).
_NPY_MAGIC = b"\x93NUMPY"


def _holds_objects(z: Any, key: str) -> bool:
    """Whether the array ``key`` of an open NPZ archive is of Python objects (which only
    unpickling reads), told from its header without reading its data."""
    names = z.zip.namelist()
    member = key + ".npy" if key + ".npy" in names else key
    try:
        with z.zip.open(member) as fh:
            version = np.lib.format.read_magic(fh)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
                np.lib.format.read_array_header_2_0
            return bool(read(fh)[2].hasobject)
    except Exception:  # a damaged header: not objects, just unreadable
        return False


def load_npz(path: str | Path, arrays: str) -> dict[str, np.ndarray]:
    """The named arrays of an NPZ archive, never unpickling anything.

    Parameters
    ----------
    path : path
    arrays : str
        The arrays expected, in words for the messages (``"'points', 'normals'"``).

    Raises
    ------
    InputError
        The file cannot be read, is not a ZIP archive (text, a pickle, random bytes), is a
        single ``.npy`` array, is damaged, or holds an array of Python objects.
    """
    where = str(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except IsADirectoryError:
        raise InputError(f"{where}: a folder, not an NPZ file") from None
    except OSError as e:
        raise InputError(f"{where}: not a readable NPZ file ({e.strerror or e})") from None
    if head.startswith(_NPY_MAGIC):
        raise InputError(f"{where}: holds one bare array (a .npy file?), not an NPZ archive of "
                         f"named arrays {arrays}")
    if not head.startswith(_ZIP_MAGIC):
        raise InputError(f"{where}: not a readable NPZ file: not an NPZ archive (a ZIP of named "
                         "arrays, as numpy.savez writes)")
    try:
        with np.load(path, allow_pickle=False) as z:
            out = {}
            for key in z.files:
                try:
                    out[key] = z[key]
                except ValueError:
                    if _holds_objects(z, key):
                        raise InputError(f"{where}: array '{key}' holds Python objects, which "
                                         "synth does not load; save it as numbers (or "
                                         "strings)") from None
                    raise
            return out
    except InputError:
        raise
    except (OSError, ValueError, EOFError, KeyError, NotImplementedError, zipfile.BadZipFile,
            zlib.error) as e:
        raise InputError(f"{where}: not a readable NPZ file (a damaged archive)") from e


def unit_metres(name: Any, where: str, key: str = "units") -> float:
    """Metres per unit of a unit name (``m``, ``mm``, ``meters``, ...)."""
    import trimesh

    try:
        return float(trimesh.units.unit_conversion(str(name), "meters"))
    except Exception as e:  # trimesh raises bare errors for unknown names
        raise InputError(f"{where}: field '{key}' is {shown(name)}, expected a length unit "
                         "(m, mm, cm, in, ...)") from e


#: synth's documents of contact sets, in words: given where gripper poses belong.
_CONTACT_DOCUMENTS: dict[str, str] = {
    "synth.grasps": "a point-finger plan (contact sets; JSON written by synth plan --out)",
    "synth.ranked": "a ranking of contact sets (JSON written by synth rank --out)",
}


def _contact_sets_hint(doc: Any, where: str) -> str | None:
    """The message for contact sets (points, no poses) given where gripper poses belong:
    synth's plan or ranking of point-finger grasps, a score file, or a candidate file of
    ``points``; None for anything else."""
    fmt = doc.get("format") if isinstance(doc, dict) else None
    rank = f"; rank it without --gripper (synth rank MESH {where})"
    if isinstance(fmt, str) and fmt in _CONTACT_DOCUMENTS:
        return f"{where}: {_CONTACT_DOCUMENTS[fmt]}, not gripper poses{rank}"
    if fmt == "synth.scores":
        return (f"{where}: a score file (JSON written by synth score --out): scores of contact "
                "sets, not gripper poses")
    items = doc.get("candidates", doc.get("grasps")) if isinstance(doc, dict) else doc
    if isinstance(items, list) and items and all(
            isinstance(c, dict) and "points" in c and "pose" not in c for c in items):
        return f"{where}: contact sets (a candidate file of 'points'), not gripper poses{rank}"
    return None


def _widths(value: Any, n: int, where: str) -> np.ndarray | None:
    return None if value is None else number_list(value, n, where, "widths")


def read_npz(path: str | Path) -> GripperPoses:
    """The gripper poses of an NPZ file (see the module)."""
    where = str(path)
    arrays = load_npz(path, "'poses' (or 'transforms')[, 'widths', 'units']")
    key = "poses" if "poses" in arrays else "transforms"
    if key not in arrays and "points" in arrays:
        raise InputError(f"{where}: contact sets (arrays 'points', 'normals'), not gripper "
                         f"poses; rank them without --gripper (synth rank MESH {where})")
    if key not in arrays:
        raise InputError(f"{where}: missing array 'poses' (or 'transforms') of shape (n, 4, 4); "
                         f"found {sorted(arrays)}")
    if arrays[key].dtype.kind not in "biuf":
        raise InputError(f"{where}: array '{key}' holds {arrays[key].dtype} values, expected "
                         "numbers")
    T = np.asarray(arrays[key], dtype=float)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise InputError(f"{where}: array '{key}' has shape {T.shape}, expected (n, 4, 4)")
    units = str(arrays["units"]) if "units" in arrays else "m"
    poses = GripperPoses(where, "npz", T, tuple(str(i) for i in range(len(T))),
                         unit_metres(units, where), units, None, None,
                         _widths(arrays.get("widths"), len(T), where))
    return poses.with_checks(key + "[{i}]")


def read_json_poses(path: str | Path, doc: Any) -> GripperPoses:
    """The gripper poses of a parsed JSON document (see the module)."""
    where = str(path)
    widths: Any = None
    units: Any = "m"
    contact_sets = _contact_sets_hint(doc, where)
    if contact_sets is not None:
        raise InputError(contact_sets)
    if isinstance(doc, dict) and doc.get("format") == "synth.gripper_grasps":
        grasps = doc.get("grasps")
        if not isinstance(grasps, list):
            raise InputError(f"{where}: field 'grasps' is {shown(grasps)}, expected a list")
        items = [g.get("pose") if isinstance(g, dict) else None for g in grasps]
        widths = [g.get("width") if isinstance(g, dict) else None for g in grasps]
        if all(w is None for w in widths):  # poses alone: the jaws' width is found again
            widths = None
        units, key, fmt = doc.get("units"), "grasps[].pose", "synth.gripper_grasps"
    elif isinstance(doc, dict):
        key = "poses" if "poses" in doc else "transforms"
        if key not in doc:
            raise InputError(f"{where}: expected a list of 4 x 4 poses, or an object with "
                             f"'poses' (or 'transforms'); found keys {sorted(doc)[:8]}")
        items, widths, units, fmt = doc[key], doc.get("widths"), doc.get("units", "m"), "json"
    else:
        items, key, fmt = doc, "poses", "json"
    T, errors = matrices(items, where, key)
    w = _widths(widths, len(T), where)
    poses = GripperPoses(where, fmt, T, tuple(str(i) for i in range(len(T))),
                         unit_metres(units, where), str(units), None, None, w,
                         errors=tuple(errors))
    return poses.with_checks(key.replace("[]", "[{i}]") if "[]" in key else key + "[{i}]")
