"""ACRONYM's grasp files (HDF5): read their poses, write a database's grasps in their layout.

ACRONYM (Eppner et al., 2021; github.com/NVlabs/acronym) stores one object per HDF5 file:

=========================================  ===================================================
dataset                                    meaning
=========================================  ===================================================
``grasps/transforms``  (n, 4, 4) float     gripper base frame (approach +z, closing x) to the
                                           object frame, metres
``grasps/qualities/flex/object_in_gripper``  (n,) int: 1 when the object stayed in the gripper
                                           in ACRONYM's FleX simulation
``object/file``                            the mesh file, relative to a mesh root folder
``object/scale``                           the object frame is the mesh file's coordinates
                                           times this (the loader scales the mesh, then applies
                                           the poses)
``object/mass``                            kg
``gripper/type``                           the gripper's name (``panda``)
=========================================  ===================================================

synth writes the same layout, its measures under ``grasps/qualities/synth/<measure>``, the
grasp widths under ``grasps/widths`` (metres), and says in attributes what each dataset holds:
the file's ``units`` (``m``), and ``object_in_gripper``'s ``meaning`` (synth's verdict, not a
FleX simulation).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from synth.errors import InputError
from synth.formats.objects import ObjectGrasps
from synth.formats.poses import GripperPoses

__all__ = ["read_acronym", "write_acronym", "recorded_gripper", "LABEL"]

#: Where ACRONYM's loader reads its success label.
LABEL = "grasps/qualities/flex/object_in_gripper"


def _h5py() -> Any:
    try:
        import h5py
    except ImportError as e:
        raise InputError('ACRONYM files are HDF5, which needs h5py: pip install "synth[h5]"'
                         ) from e
    return h5py


def _text(value: Any) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)


def recorded_gripper(path: str | Path) -> str | None:
    """The gripper an ACRONYM file names (``gripper/type``), or None: no such dataset, no
    text there, no h5py, or no HDF5 file (the callers' own reading says what is wrong)."""
    try:
        h5py = _h5py()
        with h5py.File(str(path), "r") as f:
            return _name(f, "gripper/type")
    except (InputError, OSError):
        return None


def _name(f: Any, key: str) -> str | None:
    """The text of the dataset ``key`` of an open HDF5 file, None where there is none."""
    import h5py

    item = f.get(key)
    if not isinstance(item, h5py.Dataset):
        return None
    try:
        value = item[()]
        return value.decode("utf-8") if isinstance(value, bytes) else (
            value if isinstance(value, str) else None)
    except (TypeError, ValueError, OSError):  # not text, or not readable as it
        return None


def _numbers(f: Any, key: str, where: str) -> np.ndarray:
    """The dataset ``key`` of an open HDF5 file as float numbers, or an InputError that says
    what it holds instead (a group, text, compound records)."""
    import h5py

    item = f[key]
    if not isinstance(item, h5py.Dataset):
        raise InputError(f"{where}: '{key}' is a group, expected a dataset of numbers")
    if item.dtype.kind not in "biuf":
        raise InputError(f"{where}: dataset '{key}' holds {item.dtype} values, expected "
                         "numbers")
    return np.asarray(item[()], dtype=float)


def read_acronym(path: str | Path) -> GripperPoses:
    """The gripper poses of an ACRONYM HDF5 grasp file.

    Parameters
    ----------
    path : path
        With ``grasps/transforms`` (n, 4, 4) and ``object/scale``.

    Returns
    -------
    GripperPoses
        Poses in metres on the mesh scaled by ``object/scale``; labels from
        ``grasps/qualities/flex/object_in_gripper`` when present.
    """
    h5py = _h5py()
    where = str(path)
    try:
        f = h5py.File(where, "r")
    except OSError as e:
        raise InputError(f"{where}: not a readable HDF5 file: {e}") from e
    with f:
        if "grasps/transforms" not in f:
            export = str(f.attrs.get("format", "")).startswith("synth.")
            raise InputError(f"{where}: missing dataset 'grasps/transforms' (ACRONYM's (n, 4, 4) "
                             "gripper poses)" + ("; this is a whole database exported by synth "
                                                 "db export: give one mesh's poses, from synth "
                                                 "db export --format acronym" if export else ""))
        T = _numbers(f, "grasps/transforms", where)
        if T.ndim != 3 or T.shape[1:] != (4, 4):
            raise InputError(f"{where}: dataset 'grasps/transforms' has shape {T.shape}, "
                             "expected (n, 4, 4)")
        if "object/scale" not in f:
            raise InputError(f"{where}: missing dataset 'object/scale' (the scale of the mesh "
                             "the poses refer to)")
        scales = _numbers(f, "object/scale", where).reshape(-1)
        if scales.size != 1:
            raise InputError(f"{where}: dataset 'object/scale' holds {scales.size} numbers, "
                             "expected one")
        scale = float(scales[0])
        if not (np.isfinite(scale) and scale > 0):
            raise InputError(f"{where}: dataset 'object/scale' is {scale!r}, expected a "
                             "positive number")
        unit_name = _text(f.attrs.get("units", "m"))
        if unit_name != "m":
            raise InputError(f"{where}: attribute 'units' is {unit_name!r}; ACRONYM files are "
                             "in metres ('m')")
        labels = _numbers(f, LABEL, where) if LABEL in f else None
        if labels is not None and labels.shape != (len(T),):
            raise InputError(f"{where}: dataset '{LABEL}' has shape {labels.shape}, expected "
                             f"({len(T)},)")
        widths = _numbers(f, "grasps/widths", where) if "grasps/widths" in f else None
        if widths is not None and widths.shape != (len(T),):
            raise InputError(f"{where}: dataset 'grasps/widths' has shape {widths.shape}, "
                             f"expected ({len(T)},)")
        obj = _text(f["object/file"][()]) if "object/file" in f else None
        gripper = _name(f, "gripper/type")
        mass = None
        if "object/mass" in f:  # NaN where synth's own export had no mass: none
            m = _numbers(f, "object/mass", where).reshape(-1)
            mass = float(m[0]) if m.size == 1 and np.isfinite(m[0]) and m[0] > 0 else None
    poses = GripperPoses(where, "acronym", T, tuple(str(i) for i in range(len(T))), 1.0, "m",
                         scale, obj, widths, labels, LABEL if labels is not None else None,
                         object_mass=mass, gripper=gripper)
    return poses.with_checks("grasps/transforms[{i}]")


def write_acronym(path: str | Path, obj: ObjectGrasps) -> None:
    """Write one object's grasps in ACRONYM's layout (see the module).

    Parameters
    ----------
    path : path
        The ``.h5`` file to write.
    obj : ObjectGrasps
    """
    h5py = _h5py()
    text = h5py.string_dtype("utf-8")
    with h5py.File(str(path), "w") as f:
        f.attrs["format"] = "acronym"
        f.attrs["written_by"] = obj.written_by
        f.attrs["units"] = "m"
        f.attrs["frame"] = obj.frame
        t = f.create_dataset("grasps/transforms", data=obj.poses)
        t.attrs["units"] = "m"
        w = f.create_dataset("grasps/widths", data=obj.widths)
        w.attrs["units"] = "m"
        lab = f.create_dataset(LABEL, data=obj.label.astype(np.int64))
        lab.attrs["meaning"] = obj.label_meaning
        for name, values in obj.measures.items():
            d = f.create_dataset(f"grasps/qualities/synth/{name}", data=values)
            d.attrs["units"] = obj.measure_units[name]
        f.create_dataset("object/file", data=obj.object_file, dtype=text)
        s = f.create_dataset("object/scale", data=obj.object_scale)
        s.attrs["meaning"] = "metres per mesh unit: the poses refer to the mesh scaled by this"
        m = f.create_dataset("object/mass", data=np.nan if obj.mass is None else obj.mass)
        m.attrs["units"] = "kg"
        m.attrs["meaning"] = obj.mass_note
        f.create_dataset("gripper/type", data=obj.gripper, dtype=text)
