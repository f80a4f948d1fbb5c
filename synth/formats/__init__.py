"""The ecosystem's grasp formats: gripper poses read from other tools, databases written for them.

Readers return :class:`~synth.formats.poses.GripperPoses` (the poses as the file gives them,
converted to a part by :meth:`~synth.formats.poses.GripperPoses.to_part`); writers take
:class:`~synth.formats.objects.ObjectGrasps` (one object's grasps in metres).

* ACRONYM HDF5 (``.h5``, ``.hdf5``): :mod:`synth.formats.acronym`, read and written
  (``synth db export --format acronym``);
* GraspGen JSON (``.json`` with ``object`` and ``grasps.transforms``):
  :mod:`synth.formats.graspgen`, read and written (``--format graspgen``);
* isaac_grasp YAML (``.yaml``, ``.yml``): :mod:`synth.formats.isaac`, read and written
  (``--format isaac``);
* pose arrays (``.npz``; any other ``.json``): :mod:`synth.formats.arrays`, read.
"""

from __future__ import annotations

import os
from pathlib import Path

from synth.errors import InputError
from synth.formats.objects import ObjectGrasps
from synth.formats.poses import GripperPoses, PartPoses

__all__ = ["GripperPoses", "ObjectGrasps", "PartPoses", "read_gripper_poses", "WRITERS"]

#: ``synth db export --format`` names of the writers, and their file extensions.
WRITERS: dict[str, str] = {"acronym": ".h5", "graspgen": ".json", "isaac": ".yaml"}


def read_gripper_poses(path: str | Path) -> GripperPoses:
    """Read gripper poses from any format above, chosen by extension and content.

    Parameters
    ----------
    path : path

    Returns
    -------
    GripperPoses
        Malformed poses are listed in ``errors``; a file that cannot be read at all raises.

    Raises
    ------
    InputError
        A missing or unreadable file, or one without poses.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"path: expected a gripper pose file's path, got {type(path).__name__}")
    where = str(path)
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{where}: a folder, not a gripper pose file")
    if not p.is_file():
        raise InputError(f"{where}: no such file")
    ext = p.suffix.lower()
    if ext in (".h5", ".hdf5"):
        from synth.formats.acronym import read_acronym

        return read_acronym(p)
    if ext in (".yaml", ".yml"):
        from synth.formats.isaac import read_isaac

        return read_isaac(p)
    if ext == ".npz":
        from synth.formats.arrays import read_npz

        return read_npz(p)
    if ext != ".json":
        raise InputError(f"{where}: unknown pose file extension {ext!r}; expected .h5/.hdf5 "
                         "(ACRONYM), .json (GraspGen, or arrays), .yaml/.yml (isaac_grasp) or "
                         ".npz")
    from synth.grasps.candidates import parse_json_file

    doc = parse_json_file(p, "a gripper pose file")
    from synth.formats.graspgen import is_graspgen, read_graspgen

    if is_graspgen(doc):
        return read_graspgen(p, doc)
    from synth.formats.arrays import read_json_poses

    return read_json_poses(p, doc)
