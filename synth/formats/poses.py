"""Gripper poses read from another tool's file, and how they are brought to the part.

Every reader of :mod:`synth.formats` returns a :class:`GripperPoses`: the poses as the file
gives them (gripper base frame to object frame, 4 x 4), the length unit of their numbers, the
object scale the file declares, and every malformed pose with its index and field. Nothing is
converted on reading; :meth:`GripperPoses.to_part` brings the poses to the part's frame and
unit, and says what it applied.

The object frame of a file is the mesh file's coordinates times the file's object scale
(ACRONYM's and GraspGen's ``object/scale``: their loaders scale the mesh, then apply the poses),
so one mesh unit is ``scale`` pose units. A file without an object scale places the poses
on the object at its physical size: one mesh unit is the part's unit. The mesh is never
rescaled: rotations are kept, translations are divided by the metres per mesh unit.

A pose is malformed when it is not 4 x 4, holds a NaN or an infinity, has a last row other
than ``(0, 0, 0, 1)``, or its rotation block is not a rotation within ``ROTATION_TOL``
(``|R^T R - I| <= 1e-6`` entrywise and ``det R > 0``).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError, shown

__all__ = ["GripperPoses", "PartPoses", "ROTATION_TOL", "check_poses", "canonical_half_turn",
           "number_list"]

#: Largest entry of ``R^T R - I`` (and of the last row's error) of an accepted pose.
ROTATION_TOL: float = 1e-6
#: Relative difference between a file's object scale and the part's unit that is accepted.
_SCALE_RTOL: float = 1e-6


def number_list(value: object, n: int, where: str, key: str) -> NDArray[np.float64]:
    """A file's field of one number per pose (widths, labels) as (n,) floats.

    Raises
    ------
    InputError
        Not numbers (text, objects, null), not finite, or another count than ``n``; the
        field is named.
    """
    try:
        a = np.asarray(value, dtype=float).reshape(-1)  # (null becomes NaN here)
    except (TypeError, ValueError, OverflowError):
        a = np.zeros(0)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise InputError(f"{where}: field '{key}' is {shown(value)}, expected {n} finite "
                         "numbers")
    return a


def check_poses(poses: NDArray[np.float64]) -> list[tuple[int, str]]:
    """Why each malformed pose is malformed.

    Parameters
    ----------
    poses : (n, 4, 4) float
        NaN rows stand for poses that could not be read (their reason is given elsewhere).

    Returns
    -------
    list of (int, str)
        ``(index, reason)`` of every pose that is not a rigid transform.

    Examples
    --------
    >>> check_poses(np.stack([np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0])]))
    [(1, 'rotation block has determinant -1 (a reflection), expected a rotation')]
    """
    T = np.asarray(poses, float)
    out = []
    finite = np.isfinite(T).all(axis=(1, 2))
    R = T[:, :3, :3]
    gram = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(np.where(finite[:, None, None], R, 0.0))
    last = np.abs(T[:, 3] - [0.0, 0.0, 0.0, 1.0]).max(axis=1)
    for i in range(len(T)):
        if not finite[i]:
            out.append((i, "holds a NaN or an infinity"))
        elif last[i] > ROTATION_TOL:
            out.append((i, f"last row is {np.round(T[i, 3], 6).tolist()}, expected [0, 0, 0, 1]"))
        elif gram[i] > ROTATION_TOL:
            out.append((i, f"rotation block is not orthonormal (|R^T R - I| = {gram[i]:.2g}, "
                        f"more than {ROTATION_TOL:g})"))
        elif det[i] < 0:
            out.append((i, "rotation block has determinant -1 (a reflection), expected a "
                        "rotation"))
    return out


def canonical_half_turn(poses: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                              NDArray[np.bool_]]:
    """One pose of each pair {pose, its half-turn about the approach axis z}.

    A pose and its half-turn are the same jaw grasp (the fingers swap). The representative is
    the one whose closing axis x has its largest-magnitude component positive; the half-turn
    negates x and y exactly, so both poses of a pair map to the same matrix, bit for bit.

    Parameters
    ----------
    poses : (n, 4, 4) float

    Returns
    -------
    canonical : (n, 4, 4) float
    turned : (n,) bool
        Whether the pose was turned (its +x pad is the canonical pose's -x pad).

    Examples
    --------
    >>> T = np.diag([-1.0, -1.0, 1.0, 1.0])
    >>> c, turned = canonical_half_turn(T[None])
    >>> c[0].tolist() == np.eye(4).tolist(), bool(turned[0])
    (True, True)
    """
    T = np.asarray(poses, float)
    x = T[:, :3, 0]
    big = x[np.arange(len(T)), np.argmax(np.abs(x), axis=1)]
    turned = big < 0
    out = T.copy()
    out[turned, :3, :2] *= -1.0
    return out, turned


@dataclass(frozen=True)
class PartPoses:
    """Poses brought to a part's frame and unit by :meth:`GripperPoses.to_part`.

    Attributes
    ----------
    poses : (n, 4, 4) float
        Gripper base frame to the part's frame, translations in the part's unit (malformed
        rows as read).
    widths : (n,) float or None
        Widths the file gives, in the part's unit.
    metres_per_unit : float
        Metres per part unit the conversion used (the gripper is scaled by its inverse).
    applied : str
        What was applied, one line.
    """

    poses: NDArray[np.float64] = field(repr=False)
    widths: NDArray[np.float64] | None = field(repr=False)
    metres_per_unit: float
    applied: str


@dataclass(frozen=True)
class GripperPoses:
    """Gripper poses read from a file, as the file gives them.

    Attributes
    ----------
    path : str
    format : str
        ``acronym``, ``graspgen``, ``isaac_grasp``, ``npz`` or ``json``.
    poses : (n, 4, 4) float
        Gripper base frame (approach +z, closing x) to the file's object frame; rows that
        could not be read are NaN (see ``errors``).
    names : tuple of str
        One per pose (the file's grasp names, else ``"0"``, ``"1"``, ...).
    unit : float
        Metres per length unit of the poses' numbers (1 for every ecosystem format).
    unit_name : str
        That unit as the file states it (``"m"``).
    object_scale : float or None
        The file's object scale (mesh coordinates times it give the object frame), None when
        the file has none.
    object_file : str or None
        The mesh file the file names.
    widths : (n,) float or None
        Grasp widths (pad distance) in the poses' unit, when the file gives them.
    labels : (n,) float or None
        The file's own verdict or confidence per pose.
    label_name : str or None
        Where ``labels`` come from (``grasps/qualities/flex/object_in_gripper``, ...).
    object_mass : float or None
        The object's mass in kg, when the file gives one (ACRONYM's ``object/mass``).
    gripper : str or None
        The gripper the file names (ACRONYM's ``gripper/type``), as written.
    errors : tuple of (int, str)
        ``(index, message)`` of every malformed pose; the message names the file and the field.
    """

    path: str
    format: str
    poses: NDArray[np.float64] = field(repr=False)
    names: tuple[str, ...] = field(repr=False)
    unit: float
    unit_name: str
    object_scale: float | None
    object_file: str | None = None
    widths: NDArray[np.float64] | None = field(default=None, repr=False)
    labels: NDArray[np.float64] | None = field(default=None, repr=False)
    label_name: str | None = None
    errors: tuple[tuple[int, str], ...] = ()
    object_mass: float | None = None
    gripper: str | None = None

    def with_checks(self, pose_field: str) -> GripperPoses:
        """The same poses with every malformed pose (:func:`check_poses`) in ``errors``,
        named as ``pose_field`` with ``{i}`` for the index."""
        from dataclasses import replace

        seen = {i for i, _ in self.errors}
        more = [(i, f"{self.path}: candidate {i}: field '{pose_field.format(i=i)}' {why}")
                for i, why in check_poses(self.poses) if i not in seen]
        return replace(self, errors=tuple(sorted(self.errors + tuple(more))))

    def to_part(self, part_metres: float | None, part_unit: str | None) -> PartPoses:
        """The poses in a part's frame and unit.

        Parameters
        ----------
        part_metres : float or None
            Metres per unit of the part's coordinates, None when its unit is unknown.
        part_unit : str or None
            The part's unit, for the message.

        Returns
        -------
        PartPoses

        Raises
        ------
        InputError
            When the part's unit is unknown and the file has no object scale, or when the
            file's object scale and the part's unit disagree (the poses were made for the
            object at another size); or ``part_metres`` is not a positive number.
        """
        if part_metres is not None and (isinstance(part_metres, bool) or not isinstance(
                part_metres, numbers.Real) or not (math.isfinite(part_metres)
                                                   and part_metres > 0)):
            raise InputError(f"part_metres: expected a positive number of metres per unit, or "
                             f"None, got {part_metres!r}")
        if self.object_scale is not None:
            m = self.object_scale * self.unit  # metres per mesh unit, by the file
            if part_metres is not None and abs(m / part_metres - 1.0) > _SCALE_RTOL:
                raise InputError(
                    f"{self.path}: field 'object scale' is {self.object_scale:g}, so one mesh "
                    f"unit is {m:g} m for these poses, but the part's unit {part_unit} is "
                    f"{part_metres:g} m: the poses were made for the object at another size "
                    "(leave out --units to take the file's scale)")
            how = (f"the mesh scaled by the file's object scale {self.object_scale:g} "
                   f"(1 mesh unit = {m:g} m)")
        elif part_metres is None:
            raise InputError(
                f"{self.path}: the poses are in {self.unit_name} and the part's length unit is "
                "unknown (the mesh file does not say): give --units (mm, cm, m, in, ...)")
        else:
            m = part_metres
            how = f"the mesh at its own size in {part_unit} (1 mesh unit = {m:g} m)"
        k = self.unit / m  # pose units -> mesh units
        T = self.poses.copy()
        T[:, :3, 3] *= k
        widths = None if self.widths is None else self.widths * k
        change = ("the same unit: translations as given" if k == 1.0 else
                  f"translations multiplied by {k:g} into the mesh's unit")
        applied = (f"{len(T)} poses from {self.format} file {self.path}: gripper base frame "
                   f"(approach +z, closing x), translations in {self.unit_name} on {how}; "
                   f"{change}, rotations as given")
        return PartPoses(T, widths, m, applied)
