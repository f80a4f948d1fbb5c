"""Parallel-jaw gripper descriptions: collision geometry, pads, opening, grip force, TCP.

A gripper is a small JSON file (the built-in ones are in ``synth/fingers/grippers/``, with
their sources and licences). Lengths are in metres and forces in newtons. The frame is the
one ACRONYM and GraspGen use: origin at the hand's base, approach along +z, fingers closing
along x. Fields:

``format``, ``version``
    ``"synth.gripper"`` and 1.
``name``, ``title``
    Short name and a readable one.
``max_opening``
    Largest distance between the pads, > 0.
``grip_force``
    Rated grip force in newtons, > 0.
``tcp``
    Tool centre point ``[x, y, z]``.
``palm``, ``finger``
    Lists of shapes: ``{"box": {"center": [3], "size": [3]}}`` or ``{"mesh": FILE,
    "rotate_z_deg": A, "offset": [3]}`` (a mesh file beside the description, rotated about z,
    then moved). ``finger`` is the +x finger with its pad surface in the plane x = 0, facing
    -x; at opening ``w`` it is moved by ``(w / 2, 0, finger_z(w))``, and the -x finger is the
    half-turn about z of the +x one.
``pad``
    ``{"center": [y, z], "size": [width, height]}``: the pad rectangle in the plane x = 0 of
    the finger (width along y, height along z).
``finger_z``
    Optional ``[[opening, dz], ...]`` (openings increasing, covering 0 to ``max_opening``):
    how far the fingers rise as the jaws close (a Robotiq linkage's arc), interpolated
    linearly; default 0.
``notes``
    Optional free text: where the numbers come from.

A malformed file is refused with :class:`~synth.errors.InputError` naming the file, the field,
the value and what was expected.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError, shown
from synth.fingers.builtin import BUILTIN_GRIPPERS, GRIPPER_FOLDER

__all__ = ["BUILTIN_GRIPPERS", "Gripper", "GripperShape", "load_gripper", "half_turn"]

_BOX_FACES = np.array([[0, 1, 2], [1, 3, 2], [4, 6, 5], [5, 6, 7], [0, 4, 1], [1, 4, 5],
                       [2, 3, 6], [3, 7, 6], [0, 2, 4], [2, 6, 4], [1, 5, 3], [3, 5, 7]])


def half_turn() -> NDArray[np.float64]:
    """The 4 x 4 half-turn about z (the -x finger is the +x finger so turned)."""
    return np.diag([-1.0, -1.0, 1.0, 1.0])


@dataclass(frozen=True)
class GripperShape:
    """One convex box or mesh of a gripper, in its palm's or finger's frame.

    Attributes
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
        Outward-wound triangles (a box has 12).
    box : (2, 3) float or None
        ``[center, size]`` for a box (FCL then uses its exact box), None for a mesh.
    """

    vertices: NDArray[np.float64] = field(repr=False)
    faces: NDArray[np.int64] = field(repr=False)
    box: NDArray[np.float64] | None = field(repr=False)

    def scaled(self, factor: float) -> GripperShape:
        """The shape with every length multiplied by ``factor``."""
        return GripperShape(self.vertices * factor, self.faces,
                            None if self.box is None else self.box * factor)


def _box(center: NDArray[np.float64], size: NDArray[np.float64]) -> GripperShape:
    corners = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5) for k in (-0.5, 0.5)])
    return GripperShape(center + corners * size, _BOX_FACES.copy(), np.stack([center, size]))


@dataclass(frozen=True)
class Gripper:
    """A parallel-jaw gripper (see the module for the frame and the file format).

    Attributes
    ----------
    name, title : str
    max_opening : float
        Largest pad distance, in ``unit`` lengths.
    grip_force : float
        Rated grip force, newtons.
    tcp : (3,) float
        Tool centre point in the gripper frame.
    palm, finger : tuple of GripperShape
        Palm shapes in the gripper frame; the +x finger's shapes at opening 0.
    pad_center : (2,) float
        ``(y, z)`` of the pad rectangle's centre at opening 0.
    pad_size : (2,) float
        Its width (along y) and height (along z).
    finger_z : (t, 2) float
        ``(opening, rise)`` table.
    source : str
        The description file.
    notes : str
    unit_scale : float
        Lengths of this object per metre (1 as loaded; :meth:`scaled` changes it).
    """

    name: str
    title: str
    max_opening: float
    grip_force: float
    tcp: NDArray[np.float64] = field(repr=False)
    palm: tuple[GripperShape, ...] = field(repr=False)
    finger: tuple[GripperShape, ...] = field(repr=False)
    pad_center: NDArray[np.float64] = field(repr=False)
    pad_size: NDArray[np.float64] = field(repr=False)
    finger_z: NDArray[np.float64] = field(repr=False)
    source: str = ""
    notes: str = field(default="", repr=False)
    unit_scale: float = 1.0

    def scaled(self, factor: float) -> Gripper:
        """The same gripper with lengths multiplied by ``factor`` (metres to a part's unit)."""
        return replace(
            self, max_opening=self.max_opening * factor, tcp=self.tcp * factor,
            palm=tuple(s.scaled(factor) for s in self.palm),
            finger=tuple(s.scaled(factor) for s in self.finger),
            pad_center=self.pad_center * factor, pad_size=self.pad_size * factor,
            finger_z=self.finger_z * factor, unit_scale=self.unit_scale * factor)

    def rise(self, width: float | NDArray[np.float64]) -> NDArray[np.float64] | np.float64:
        """How far the fingers rise along z at opening ``width`` (scalar or (n,): a scalar or
        (n,) result)."""
        return np.interp(width, self.finger_z[:, 0], self.finger_z[:, 1])

    def finger_transforms(self, width: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Poses (4 x 4, in the gripper frame) of the +x and the -x finger at ``width``."""
        T = np.eye(4)
        T[:3, 3] = [0.5 * width, 0.0, float(self.rise(width))]
        return T, half_turn() @ T

    def meshes_at(self, width: float) -> list[tuple[NDArray[np.float64], NDArray[np.int64]]]:
        """Every shape's vertices (in the gripper frame) and faces at opening ``width``."""
        out = [(s.vertices, s.faces) for s in self.palm]
        for T in self.finger_transforms(width):
            out += [(s.vertices @ T[:3, :3].T + T[:3, 3], s.faces) for s in self.finger]
        return out

    def to_json(self) -> dict[str, Any]:
        """What a grasp file says about the gripper (lengths in the part's unit)."""
        return {"name": self.name, "title": self.title, "source": self.source,
                "max_opening": self.max_opening, "grip_force": self.grip_force,
                "tcp": self.tcp.tolist(),
                "pad": {"center": self.pad_center.tolist(), "size": self.pad_size.tolist()},
                "frame": "ACRONYM/GraspGen: origin at the hand's base, approach +z, fingers "
                "closing along x; a pose and its half-turn about z are the same grasp"}


def _field(doc: dict[str, Any], key: str, where: str, expected: str, optional: bool = False
           ) -> Any:
    if key not in doc:
        if optional:
            return None
        raise InputError(f"{where}: missing field '{key}' (expected {expected})")
    return doc[key]


def _vector(value: Any, n: int, where: str, key: str, positive: bool = False
            ) -> NDArray[np.float64]:
    ok = isinstance(value, list) and len(value) == n and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        for v in value)
    if ok and positive:
        ok = all(v > 0 for v in value)
    if not ok:
        what = "positive " if positive else ""
        raise InputError(f"{where}: field '{key}' is {shown(value)}, expected a list of {n} "
                         f"finite {what}numbers")
    return np.array(value, dtype=np.float64)


def _positive(value: Any, where: str, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
            math.isfinite(value) and value > 0):
        raise InputError(f"{where}: field '{key}' is {shown(value)}, expected a positive number")
    return float(value)


def _shapes(value: Any, where: str, key: str, folder: Path) -> tuple[GripperShape, ...]:
    if not isinstance(value, list) or not value:
        raise InputError(f"{where}: field '{key}' is {shown(value)}, expected a non-empty list "
                         "of shapes ({'box': ...} or {'mesh': ...})")
    out = []
    for i, item in enumerate(value):
        at = f"{key}[{i}]"
        if isinstance(item, dict) and set(item) == {"box"} and isinstance(item["box"], dict):
            b = item["box"]
            c = _vector(_field(b, "center", where, "[x, y, z]"), 3, where, f"{at}.box.center")
            s = _vector(_field(b, "size", where, "[sx, sy, sz]"), 3, where, f"{at}.box.size",
                        positive=True)
            out.append(_box(c, s))
        elif isinstance(item, dict) and "mesh" in item and set(item) <= {"mesh", "rotate_z_deg",
                                                                         "offset"}:
            out.append(_mesh_shape(item, where, at, folder))
        else:
            raise InputError(f"{where}: field '{at}' is {shown(item, 60)}, expected "
                             "{'box': {'center': [3], 'size': [3]}} or {'mesh': FILE, "
                             "'rotate_z_deg': A, 'offset': [3]}")
    return tuple(out)


def _mesh_shape(item: dict[str, Any], where: str, at: str, folder: Path) -> GripperShape:
    import trimesh

    name = item["mesh"]
    if not isinstance(name, str) or not name:
        raise InputError(f"{where}: field '{at}.mesh' is {shown(name)}, expected a file name")
    path = folder / name
    if not path.is_file():
        raise InputError(f"{where}: field '{at}.mesh': no such file {str(path)!r}")
    try:
        mesh = cast(trimesh.Trimesh, trimesh.load(path, force="mesh", process=True))
    except Exception as e:  # trimesh raises many kinds, in its own words (or a missing
        # module's): the file's fault is said in the format's, as for a part's mesh
        from synth.part.unreadable import explain

        ext = path.suffix.lower().lstrip(".")
        raise InputError(f"{where}: field '{at}.mesh': cannot read {str(path)!r}: "
                         f"{explain(path, ext, path.read_bytes())}") from e
    if len(mesh.faces) == 0:
        raise InputError(f"{where}: field '{at}.mesh': {str(path)!r} has no triangles")
    angle = item.get("rotate_z_deg", 0.0)
    if isinstance(angle, bool) or not isinstance(angle, (int, float)) or not math.isfinite(angle):
        raise InputError(f"{where}: field '{at}.rotate_z_deg' is {shown(angle)}, expected a "
                         "finite number of degrees")
    offset = _vector(item.get("offset", [0.0, 0.0, 0.0]), 3, where, f"{at}.offset")
    a = math.radians(angle)
    R = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0],
                  [0.0, 0.0, 1.0]])
    V = np.asarray(mesh.vertices, float) @ R.T + offset
    return GripperShape(V, np.asarray(mesh.faces, np.int64), None)


def load_gripper(spec: str | Path) -> Gripper:
    """A gripper by built-in name (``franka``, ``robotiq_2f85``, ``robotiq_2f140``) or file.

    Parameters
    ----------
    spec : str or Path
        A name of :data:`BUILTIN_GRIPPERS` or the path of a JSON description.

    Returns
    -------
    Gripper
        In metres.

    Examples
    --------
    >>> load_gripper("franka").max_opening
    0.08
    """
    if not isinstance(spec, (str, os.PathLike)):
        raise InputError(f"--gripper (Python: gripper=): expected a built-in gripper's name "
                         f"({', '.join(BUILTIN_GRIPPERS)}) or a description file's path, got "
                         f"{type(spec).__name__}")
    key = str(spec)
    path = GRIPPER_FOLDER / BUILTIN_GRIPPERS[key] if key in BUILTIN_GRIPPERS else Path(key)
    where = str(path)
    if not path.is_file():
        raise InputError(f"--gripper (Python: gripper=): {key!r} is neither a built-in "
                         f"gripper ({', '.join(BUILTIN_GRIPPERS)}) nor a description file")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"{where}: not a readable JSON gripper description: {e}") from e
    if not isinstance(doc, dict):
        raise InputError(f"{where}: expected a JSON object, got {type(doc).__name__}")
    fmt = _field(doc, "format", where, "'synth.gripper'")
    if fmt != "synth.gripper" or doc.get("version") != 1:
        raise InputError(f"{where}: field 'format'/'version' is {shown(fmt)}/"
                         f"{shown(doc.get('version'))}, expected 'synth.gripper'/1")
    name = _field(doc, "name", where, "a name")
    if not isinstance(name, str) or not name:
        raise InputError(f"{where}: field 'name' is {shown(name)}, expected a non-empty string")
    title = doc.get("title", name)
    opening = _positive(_field(doc, "max_opening", where, "metres"), where, "max_opening")
    force = _positive(_field(doc, "grip_force", where, "newtons"), where, "grip_force")
    tcp = _vector(_field(doc, "tcp", where, "[x, y, z]"), 3, where, "tcp")
    folder = path.parent
    palm = _shapes(_field(doc, "palm", where, "shapes"), where, "palm", folder)
    finger = _shapes(_field(doc, "finger", where, "shapes"), where, "finger", folder)
    pad = _field(doc, "pad", where, "{'center': [y, z], 'size': [width, height]}")
    if not isinstance(pad, dict):
        raise InputError(f"{where}: field 'pad' is {shown(pad)}, expected {{'center': [y, z], "
                         "'size': [width, height]}")
    pc = _vector(_field(pad, "center", where, "[y, z]"), 2, where, "pad.center")
    ps = _vector(_field(pad, "size", where, "[width, height]"), 2, where, "pad.size",
                 positive=True)
    fz = doc.get("finger_z", [[0.0, 0.0], [opening, 0.0]])
    table = np.array([_vector(r, 2, where, "finger_z row") for r in fz]) if isinstance(
        fz, list) and len(fz) >= 2 else None
    if table is None or np.any(np.diff(table[:, 0]) <= 0) or table[0, 0] > 0 or \
            table[-1, 0] < opening:
        raise InputError(f"{where}: field 'finger_z' is {shown(fz, 60)}, expected at least two "
                         "[opening, dz] rows, openings increasing from 0 to max_opening")
    notes = doc.get("notes", "")
    return Gripper(name, str(title), opening, force, tcp, palm, finger, pc, ps, table,
                   where if key not in BUILTIN_GRIPPERS else key, str(notes))
