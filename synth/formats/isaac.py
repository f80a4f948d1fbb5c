"""The ``isaac_grasp`` YAML files of Isaac Sim's grasp editor and Isaac ROS.

Documented layout (format version 1.0)::

    format: isaac_grasp
    format_version: 1.0
    object_frame: ...            # for readers only
    gripper_frame: ...
    grasps:
      "grasp_0":
        confidence: 1.0
        position: [x, y, z]                       # metres, gripper frame in the object frame
        orientation: {w: W, xyz: [X, Y, Z]}       # unit quaternion of that frame
        cspace_position: {...}                    # optional joint values

There is no object scale: the poses are on the object at its physical size, so the part's
unit must be known. The quaternion is normalised when its norm is within ``QUAT_TOL`` of 1
(files print few decimals); a quaternion further from unit length is malformed. synth writes
``confidence`` as its verdict (1.0 or 0.0) and says so in a ``synth`` mapping, with the units,
the object file and scale, and its measures per grasp. Needs PyYAML (``synth[formats]``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from synth.errors import InputError, shown
from synth.formats.objects import ObjectGrasps
from synth.formats.poses import GripperPoses

__all__ = ["read_isaac", "write_isaac", "QUAT_TOL", "quaternion_matrix", "matrix_quaternion"]

#: Largest | |q| - 1 | of a quaternion that is normalised rather than refused.
QUAT_TOL: float = 1e-3


def _yaml() -> Any:
    try:
        import yaml
    except ImportError as e:
        raise InputError('isaac_grasp files are YAML, which needs PyYAML: pip install '
                         '"synth[formats]"') from e
    return yaml


def quaternion_matrix(w: float, xyz: np.ndarray) -> np.ndarray:
    """The rotation matrix (3, 3) of the unit quaternion ``(w, x, y, z)``."""
    x, y, z = xyz
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def matrix_quaternion(R: np.ndarray) -> tuple[float, np.ndarray]:
    """The unit quaternion ``(w, xyz)`` of a rotation matrix (3, 3), with ``w >= 0``
    (Shepperd's method: the largest of the four squares first)."""
    tr = np.trace(R)
    sq = np.array([1 + tr, 1 + 2 * R[0, 0] - tr, 1 + 2 * R[1, 1] - tr, 1 + 2 * R[2, 2] - tr])
    k = int(np.argmax(sq))
    r = math.sqrt(max(sq[k], 0.0))
    s = 0.5 / r
    if k == 0:
        q = [0.5 * r, (R[2, 1] - R[1, 2]) * s, (R[0, 2] - R[2, 0]) * s, (R[1, 0] - R[0, 1]) * s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) * s, 0.5 * r, (R[0, 1] + R[1, 0]) * s, (R[0, 2] + R[2, 0]) * s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) * s, (R[0, 1] + R[1, 0]) * s, 0.5 * r, (R[1, 2] + R[2, 1]) * s]
    else:
        q = [(R[1, 0] - R[0, 1]) * s, (R[0, 2] + R[2, 0]) * s, (R[1, 2] + R[2, 1]) * s, 0.5 * r]
    qa = np.array(q)
    if qa[0] < 0:
        qa = -qa
    return float(qa[0]), qa[1:]


def _numbers(value: Any, n: int) -> np.ndarray | None:
    if not isinstance(value, list) or len(value) != n or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return None
    return np.array(value, dtype=float)


def read_isaac(path: str | Path) -> GripperPoses:
    """The gripper poses of an ``isaac_grasp`` YAML file (see the module).

    Returns
    -------
    GripperPoses
        Poses in metres on the object at its physical size (no object scale); labels are the
        grasps' ``confidence``.
    """
    yaml = _yaml()
    where = str(path)
    try:
        doc = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
        raise InputError(f"{where}: not a readable YAML file: {e}") from e
    if not isinstance(doc, dict) or doc.get("format") != "isaac_grasp":
        got = doc.get("format") if isinstance(doc, dict) else doc
        raise InputError(f"{where}: field 'format' is {shown(got)}, expected 'isaac_grasp'")
    if str(doc.get("format_version")) != "1.0":
        raise InputError(f"{where}: field 'format_version' is {shown(doc.get('format_version'))},"
                         " expected 1.0")
    grasps = doc.get("grasps")
    if not isinstance(grasps, dict):
        raise InputError(f"{where}: field 'grasps' is {shown(grasps)}, expected a mapping of "
                         "named grasps")
    n = len(grasps)
    T = np.full((n, 4, 4), np.nan)
    conf = np.full(n, np.nan)
    errors = []
    for i, (name, g) in enumerate(grasps.items()):
        at = f"grasps.{name}"
        bad = None
        pos = _numbers(g.get("position"), 3) if isinstance(g, dict) else None
        o = g.get("orientation") if isinstance(g, dict) else None
        w = o.get("w") if isinstance(o, dict) else None
        xyz = _numbers(o.get("xyz"), 3) if isinstance(o, dict) else None
        if not isinstance(g, dict):
            bad = f"'{at}' is {shown(g)}, expected a mapping"
        elif pos is None:
            bad = f"'{at}.position' is {shown(g.get('position'))}, expected [x, y, z]"
        elif xyz is None or isinstance(w, bool) or not isinstance(w, (int, float)):
            bad = f"'{at}.orientation' is {shown(o)}, expected {{w: W, xyz: [X, Y, Z]}}"
        else:
            q = np.concatenate([[w], xyz])
            norm = float(np.linalg.norm(q))
            if not (np.isfinite(q).all() and np.isfinite(pos).all()):
                bad = f"'{at}' holds a NaN or an infinity"
            elif abs(norm - 1.0) > QUAT_TOL:
                bad = (f"'{at}.orientation' has norm {norm:.6g}, expected a unit quaternion "
                       f"(within {QUAT_TOL:g})")
            else:
                q = q / norm
                T[i] = np.eye(4)
                T[i, :3, :3] = quaternion_matrix(q[0], q[1:])
                T[i, :3, 3] = pos
        c = g.get("confidence") if isinstance(g, dict) else None
        if isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c):
            conf[i] = float(c)
        elif c is not None and bad is None:  # left out: no verdict; anything else is wrong
            bad = f"'{at}.confidence' is {shown(c)}, expected a number"
        if bad is not None:
            errors.append((i, f"{where}: candidate {i} ({name}): field {bad}"))
    poses = GripperPoses(where, "isaac_grasp", T, tuple(str(k) for k in grasps), 1.0, "m", None,
                         None, None, conf, "confidence", tuple(errors))
    return poses.with_checks("grasps[{i}]")


def write_isaac(path: str | Path, obj: ObjectGrasps) -> None:
    """Write one object's grasps as an ``isaac_grasp`` file (see the module).

    The poses are written on the object at its physical size: with the object scale applied
    (``object_scale`` metres per mesh unit), as the format has no scale field.
    """
    yaml = _yaml()

    def num(x: float) -> float | None:
        return float(x) if math.isfinite(x) else None

    grasps = {}
    for i, T in enumerate(obj.poses):
        w, xyz = matrix_quaternion(T[:3, :3])
        grasps[f"grasp_{i}"] = {
            "confidence": 1.0 if obj.label[i] else 0.0,
            "position": [float(v) for v in T[:3, 3]],
            "orientation": {"w": w, "xyz": [float(v) for v in xyz]}}
    doc = {"format": "isaac_grasp", "format_version": 1.0,
           "object_frame": f"{obj.object_file} scaled by {obj.object_scale!r} (metres per mesh "
           "unit)",
           "gripper_frame": f"{obj.gripper} base frame (approach +z, closing x)",
           "grasps": grasps,
           "synth": {"written_by": obj.written_by, "units": "m", "frame": obj.frame,
                     "object_file": obj.object_file, "object_scale": obj.object_scale,
                     "confidence": obj.label_meaning, "gripper": obj.gripper,
                     "mass": obj.mass, "mass_units": "kg", "mass_note": obj.mass_note,
                     "widths": [float(v) for v in obj.widths],
                     "measure_units": obj.measure_units,
                     "measures": {k: [num(x) for x in v] for k, v in obj.measures.items()}}}
    Path(path).write_text(yaml.safe_dump(doc, sort_keys=False, width=1000), encoding="utf-8")
