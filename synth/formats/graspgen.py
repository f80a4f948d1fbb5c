"""GraspGen's grasp files (JSON): read their poses, write a database's grasps in their layout.

GraspGen (NVIDIA, 2025) documents one JSON object per object (docs/GRASP_DATASET_FORMAT.md):
``object.file`` (the mesh, relative to the object dataset's root), ``object.scale`` (the mesh
scale at which the grasps were sampled and evaluated), ``grasps.transforms`` (n 4 x 4 poses of
the gripper's base link: approach +z, closing x, metres) and ``grasps.object_in_gripper``
(n booleans, the success mask). Only those documented keys are relied on.

synth writes those keys and adds a ``synth`` object: the units (``m``), what
``object_in_gripper`` really holds (synth's verdict, not GraspGen's simulation), the widths,
the mass and synth's measures per grasp.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from synth.errors import InputError, shown
from synth.formats.objects import ObjectGrasps
from synth.formats.poses import GripperPoses, number_list

__all__ = ["read_graspgen", "write_graspgen", "is_graspgen"]


def is_graspgen(doc: Any) -> bool:
    """Whether a parsed JSON document has GraspGen's layout (``object`` and
    ``grasps.transforms``)."""
    return (isinstance(doc, dict) and isinstance(doc.get("object"), dict)
            and isinstance(doc.get("grasps"), dict) and "transforms" in doc["grasps"])


def matrices(items: Any, where: str, key: str) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """(n, 4, 4) poses from a JSON list of 4 x 4 lists; a row that is not 4 x 4 numbers is
    NaN, with its error naming ``key[i]``."""
    if not isinstance(items, list):
        raise InputError(f"{where}: field '{key}' is {shown(items)}, expected a list of 4 x 4 "
                         "matrices")
    T = np.full((len(items), 4, 4), np.nan)
    errors = []
    for i, m in enumerate(items):
        try:
            a = np.asarray(m, dtype=float)
        except (TypeError, ValueError):
            a = None
        if a is None or a.shape != (4, 4):
            got = "not numbers" if a is None else f"shape {a.shape}"
            errors.append((i, f"{where}: candidate {i}: field '{key}[{i}]' is {got}, expected "
                           "a 4 x 4 matrix"))
        else:
            T[i] = a
    return T, errors


def read_graspgen(path: str | Path, doc: dict[str, Any]) -> GripperPoses:
    """The gripper poses of a parsed GraspGen grasp JSON document.

    Parameters
    ----------
    path : path
        The file (for messages).
    doc : dict
        With ``object.scale`` and ``grasps.transforms``; ``object.file`` and
        ``grasps.object_in_gripper`` are read when present.

    Returns
    -------
    GripperPoses
        Poses in metres on the mesh scaled by ``object.scale``.
    """
    where = str(path)
    scale = doc["object"].get("scale")
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not (
            math.isfinite(scale) and scale > 0):
        raise InputError(f"{where}: field 'object.scale' is {shown(scale)}, expected a positive "
                         "number (the mesh scale the grasps refer to)")
    units = doc.get("synth", {}).get("units", "m") if isinstance(doc.get("synth"), dict) else "m"
    if units != "m":
        raise InputError(f"{where}: field 'synth.units' is {shown(units)}; GraspGen files are in "
                         "metres ('m')")
    T, errors = matrices(doc["grasps"]["transforms"], where, "grasps.transforms")
    labels = doc["grasps"].get("object_in_gripper")
    lab = None if labels is None else number_list(labels, len(T), where,
                                                  "grasps.object_in_gripper")
    widths = doc["synth"].get("widths") if isinstance(doc.get("synth"), dict) else None
    w = None if widths is None else number_list(widths, len(T), where, "synth.widths")
    obj = doc["object"].get("file")
    poses = GripperPoses(where, "graspgen", T, tuple(str(i) for i in range(len(T))), 1.0, "m",
                         float(scale), obj if isinstance(obj, str) else None, w, lab,
                         "grasps.object_in_gripper" if lab is not None else None,
                         tuple(errors))
    return poses.with_checks("grasps.transforms[{i}]")


def write_graspgen(path: str | Path, obj: ObjectGrasps) -> None:
    """Write one object's grasps as a GraspGen grasp JSON file (see the module)."""
    def num(x: float) -> float | None:
        return float(x) if math.isfinite(x) else None

    doc = {"object": {"file": obj.object_file, "scale": obj.object_scale},
           "grasps": {"transforms": obj.poses.tolist(),
                      "object_in_gripper": [bool(b) for b in obj.label]},
           "synth": {"written_by": obj.written_by, "units": "m", "frame": obj.frame,
                     "object_scale": "metres per mesh unit: the poses refer to the mesh scaled "
                     "by object.scale",
                     "object_in_gripper": obj.label_meaning, "gripper": obj.gripper,
                     "mass": obj.mass, "mass_units": "kg", "mass_note": obj.mass_note,
                     "widths": obj.widths.tolist(),
                     "measure_units": obj.measure_units,
                     "measures": {k: [num(x) for x in v] for k, v in obj.measures.items()}}}
    Path(path).write_text(json.dumps(doc) + "\n", encoding="utf-8")
