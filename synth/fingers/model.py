"""The finger model: a spherical fingertip on a capsule body, and where the fingers sit.

A finger is a ball of radius ``tip_radius`` (the fingertip) and a capsule of radius
``body_radius`` around the segment that leaves the fingertip's centre along the approach
direction for ``body_length``. Contact normals point INTO the part (Trinkle's convention), so
a fingertip touching the surface at ``point`` has its centre at ``point - tip_radius * normal``,
outside the part.

Several contacts may share one fingertip (two in a groove, three in an inside corner). The
shared centre is the point at distance ``tip_radius`` from every touched face plane on the
outer side: ``normal_j . centre = normal_j . point_j - tip_radius`` for each contact ``j`` of the
finger, solved by least squares (minimum-norm correction of the mean single-contact centre,
so one contact gives ``point - r * normal`` exactly and two give the point of the groove's
solution line nearest to the mean).

Tolerances (all relative to the tip radius)
-------------------------------------------
PENETRATION_RTOL
    Default ``Fingers.penetration_tol`` is ``PENETRATION_RTOL * tip_radius``: the depth by which
    a finger may sink into the part, the support plane or another finger and still count as
    touching. 1e-3 of the radius is far above FCL's narrow-phase accuracy (about 1e-6 of the
    geometry's size) and far below any clearance a real hand needs.
SHARED_TIP_FIT_RTOL
    A fingertip shared by several contacts must touch each of them: the tangent point
    ``centre + r * normal_j`` of the solved centre on contact ``j``'s face plane must lie within
    ``SHARED_TIP_FIT_RTOL * tip_radius`` of ``point_j``; otherwise the finger cannot make all
    its contacts at once and the grasp is rejected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from synth.errors import InputError
from synth.scores.arguments import length_arg
from synth.tolerances import NORMAL_NORM_TOL

__all__ = [
    "PENETRATION_RTOL",
    "SHARED_TIP_FIT_RTOL",
    "DEFAULT_TIP_RELATIVE_RADIUS",
    "MIN_TIP_RELATIVE_RADIUS",
    "DEFAULT_BODY_RELATIVE_LENGTH",
    "DEFAULT_BODY_RELATIVE_RADIUS",
    "Fingers",
    "FingerPlacement",
    "finger_frames",
    "default_fingers",
    "tip_centers",
    "part_mesh",
]

PENETRATION_RTOL: float = 1e-3
SHARED_TIP_FIT_RTOL: float = 1e-2
#: ``default_fingers`` picks a tip radius of this fraction of the part's bounding-box diagonal.
DEFAULT_TIP_RELATIVE_RADIUS: float = 0.025
#: ``default_fingers`` refuses a tip radius below this fraction of the part's size (its
#: bounding-box diagonal, or its largest coordinate when that is larger).
MIN_TIP_RELATIVE_RADIUS: float = 1e-12
#: Default body length, in tip radii.
DEFAULT_BODY_RELATIVE_LENGTH: float = 10.0
#: Default body radius, in tip radii (a body thinner than its tip, like a probe).
DEFAULT_BODY_RELATIVE_RADIUS: float = 0.75


def _positive(name: str, value: Any, allow_zero: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as e:
        raise InputError(f"Fingers.{name}: expected a number, got {value!r}") from e
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise InputError(f"Fingers.{name}: expected a finite number {bound}, got {value!r}")
    return x


@dataclass(frozen=True)
class Fingers:
    """Geometry of identical fingers: a spherical tip on a capsule body.

    Parameters
    ----------
    tip_radius : float
        Fingertip radius r, in mesh units (> 0).
    body_length : float or None
        Length of the body's axis segment, which starts at the tip centre and runs along the
        approach direction (>= 0; 0 means a bare fingertip). None gives
        ``DEFAULT_BODY_RELATIVE_LENGTH * tip_radius``.
    body_radius : float or None
        Radius of the body capsule, at most ``tip_radius``. None gives
        ``DEFAULT_BODY_RELATIVE_RADIUS * tip_radius``.
    approach_cone : float
        Half-angle in radians, in [0, pi/2), of the cone around the outward normal in which the
        approach direction may be chosen (0: straight out along ``-normal``).
    penetration_tol : float or None
        Depth a finger may sink into the part, the support plane or another finger and still
        count as touching. None gives ``PENETRATION_RTOL * tip_radius``. Must be below
        ``tip_radius``.
    support_plane : tuple of (3,) float or None
        ``(point, normal)`` of a table under the part; ``normal`` points towards the part. No
        finger, nor its approach path, may cross it.

    Examples
    --------
    >>> f = Fingers(tip_radius=2.0, body_length=30.0, body_radius=1.5)
    >>> f.penetration_tol
    0.002
    """

    tip_radius: float
    body_length: float | None = None
    body_radius: float | None = None
    approach_cone: float = 0.0
    penetration_tol: float | None = None
    support_plane: tuple[np.ndarray, np.ndarray] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        r = _positive("tip_radius", self.tip_radius)
        length = (
            DEFAULT_BODY_RELATIVE_LENGTH * r
            if self.body_length is None
            else _positive("body_length", self.body_length, allow_zero=True)
        )
        rb = (
            DEFAULT_BODY_RELATIVE_RADIUS * r
            if self.body_radius is None
            else _positive("body_radius", self.body_radius)
        )
        if rb > r:
            raise InputError(
                f"Fingers.body_radius (--body-radius): expected at most the tip radius "
                f"(tip_radius, --finger-radius) {r:.6g}, got {rb:.6g} (a body thicker than its "
                "tip would hit the surface beside every contact)"
            )
        cone = _positive("approach_cone", self.approach_cone, allow_zero=True)
        if cone >= math.pi / 2:
            raise InputError(f"Fingers.approach_cone: expected radians in [0, pi/2), got {cone}")
        tol = (
            PENETRATION_RTOL * r
            if self.penetration_tol is None
            else _positive("penetration_tol", self.penetration_tol, allow_zero=True)
        )
        if tol >= min(r, rb):
            raise InputError(
                f"Fingers.penetration_tol: must be below the tip and body radii, got {tol}"
            )
        plane = None
        if self.support_plane is not None:
            try:
                p0, n0 = (np.asarray(v, dtype=float).reshape(3) for v in self.support_plane)
            except (TypeError, ValueError) as e:
                raise InputError(
                    "Fingers.support_plane: expected (point (3,), normal (3,)) or None, "
                    f"got {self.support_plane!r}"
                ) from e
            norm = float(np.linalg.norm(n0))
            if not (np.all(np.isfinite(p0)) and np.isfinite(norm) and norm > NORMAL_NORM_TOL):
                raise InputError(
                    "Fingers.support_plane: point and normal must be finite, normal non-zero"
                )
            p0.setflags(write=False)
            n0 = n0 / norm
            n0.setflags(write=False)
            plane = (p0, n0)
        for name, value in (
            ("tip_radius", r),
            ("body_length", length),
            ("body_radius", rb),
            ("approach_cone", cone),
            ("penetration_tol", tol),
            ("support_plane", plane),
        ):
            object.__setattr__(self, name, value)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description of the finger model (floats and lists)."""
        plane = self.support_plane
        return {
            "tip_radius": float(self.tip_radius),
            "body_length": float(self.body_length),  # type: ignore[arg-type]
            "body_radius": float(self.body_radius),  # type: ignore[arg-type]
            "approach_cone": float(self.approach_cone),
            "penetration_tol": float(self.penetration_tol),  # type: ignore[arg-type]
            "support_plane": None
            if plane is None
            else {"point": plane[0].tolist(), "normal": plane[1].tolist()},
        }


@dataclass(frozen=True)
class FingerPlacement:
    """Where the fingers of one grasp sit.

    Attributes
    ----------
    tip_centers : (f, 3) float
        Fingertip centres, one per finger; contacts sharing a fingertip share its centre.
    tip_radius : float
    approach : (f, 3) float
        Unit approach directions, pointing AWAY from the part (the finger's body runs from the
        tip centre along this direction, and the finger comes in along its opposite).
    body_length : float
    body_radius : float
    contact_finger : (k,) int
        Finger index (row of ``tip_centers``) of each contact.
    """

    tip_centers: np.ndarray
    tip_radius: float
    approach: np.ndarray
    body_length: float
    body_radius: float
    contact_finger: np.ndarray

    @property
    def n_fingers(self) -> int:
        """Number of fingers f."""
        return int(self.tip_centers.shape[0])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict with keys tip_centers, tip_radius, approach, body_length,
        body_radius and frames (:func:`finger_frames`)."""
        return {
            "tip_centers": np.asarray(self.tip_centers, dtype=float).tolist(),
            "tip_radius": float(self.tip_radius),
            "approach": np.asarray(self.approach, dtype=float).tolist(),
            "body_length": float(self.body_length),
            "body_radius": float(self.body_radius),
            "frames": finger_frames(self.tip_centers, self.approach).tolist(),
        }


def finger_frames(tip_centers: Any, approach: Any) -> np.ndarray:
    """A 4 x 4 frame per finger: origin at the tip centre, +z along the finger's approach
    (towards the part, the gripper convention's approach axis), x the world axis least
    aligned with z made perpendicular to it, y = z x x.

    Parameters
    ----------
    tip_centers : (f, 3) float
    approach : (f, 3) float
        Unit directions pointing away from the part (as :class:`FingerPlacement` holds them).

    Returns
    -------
    (f, 4, 4) float

    Examples
    --------
    >>> T = finger_frames([[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]])[0]  # a tip above the part
    >>> (T[:3, 2] + 0.0).tolist(), T[:3, 3].tolist()  # approaching along -z
    ([0.0, 0.0, -1.0], [0.0, 0.0, 1.0])
    """
    c = np.asarray(tip_centers, float).reshape(-1, 3)
    z = -np.asarray(approach, float).reshape(-1, 3)
    z = z / np.linalg.norm(z, axis=1, keepdims=True)
    e = np.eye(3)[np.argmin(np.abs(z), axis=1)]
    x = e - np.einsum("ij,ij->i", e, z)[:, None] * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    T = np.tile(np.eye(4), (len(c), 1, 1))
    T[:, :3, 0], T[:, :3, 1], T[:, :3, 2], T[:, :3, 3] = x, np.cross(z, x), z, c
    return T


def part_mesh(part: Any) -> Any:
    """Return the ``trimesh.Trimesh`` of ``part`` (a mesh itself or any object with ``.mesh``).

    Examples
    --------
    >>> import trimesh
    >>> m = trimesh.creation.box()
    >>> part_mesh(m) is m
    True
    """
    import trimesh

    mesh = part if isinstance(part, trimesh.Trimesh) else getattr(part, "mesh", None)
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(
            "part: expected a trimesh.Trimesh or an object with a .mesh Trimesh, "
            f"got {type(part).__name__}"
        )
    if len(mesh.faces) == 0:
        raise InputError("part: the mesh has no faces")
    return mesh


def default_fingers(part: Any, **overrides: Any) -> Fingers:
    """Fingers sized for ``part``: tip radius 2.5 % of its bounding-box diagonal.

    Body length and radius follow the ``Fingers`` defaults (10 and 0.75 tip radii).

    Parameters
    ----------
    part : trimesh.Trimesh or object with ``.mesh``
    **overrides
        Any other ``Fingers`` field (``approach_cone``, ``support_plane``, ...).

    Examples
    --------
    >>> import trimesh
    >>> round(default_fingers(trimesh.creation.box((3.0, 4.0, 12.0))).tip_radius, 6)
    0.325
    """
    mesh = part_mesh(part)
    names = [f.name for f in fields(Fingers)]
    unknown = sorted(k for k in overrides if k not in names)
    if unknown:
        raise InputError(f"default_fingers: unknown field{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(map(repr, unknown))}; Fingers has {', '.join(names)}")
    overrides = {k: v for k, v in overrides.items() if v is not None}  # None: the default
    lo, hi = np.asarray(mesh.bounds, dtype=float)
    diag = float(np.linalg.norm(hi - lo))
    overrides.setdefault("tip_radius", DEFAULT_TIP_RELATIVE_RADIUS * diag)
    _positive("tip_radius", overrides["tip_radius"])
    # a tip this much smaller than the part vanishes in its coordinates' float64 rounding
    # (a tip centre one radius off the surface is the surface point itself)
    least = MIN_TIP_RELATIVE_RADIUS * max(diag, float(np.abs(np.concatenate([lo, hi])).max()))
    if not float(overrides["tip_radius"]) >= least:
        raise InputError(f"finger radius {overrides['tip_radius']:.3g}: expected at least "
                         f"{least:.3g}, a trillionth of the part's size and distance from the "
                         "origin (a smaller tip is lost in its coordinates' rounding)")
    return Fingers(**overrides)


def tip_centers(
    points: np.ndarray,
    normals: np.ndarray,
    tip_radius: float,
    finger_ids: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fingertip centres of a batch of grasps.

    Parameters
    ----------
    points : (B, k, 3) float
        Contact points on the surface.
    normals : (B, k, 3) float
        Unit inward normals.
    tip_radius : float
    finger_ids : (B, k) int or None
        Finger of each contact, in [0, k). None: one finger per contact.

    Returns
    -------
    centers : (B, k, 3) float
        Centre of finger ``j`` in ``centers[:, j]`` (rows of absent fingers are NaN).
    present : (B, k) bool
        Finger ``j`` has at least one contact.
    misfit : (B, k) float
        Largest distance between a contact and the tangent point of its finger's tip on the
        contact's face plane (0 for single-contact fingers).
    finger_ids : (B, k) int
        The ids used.

    Examples
    --------
    >>> c, *_ = tip_centers(np.zeros((1, 1, 3)), np.array([[[0.0, 0.0, -1.0]]]), 2.0)
    >>> c[0, 0].tolist()
    [0.0, 0.0, 2.0]
    """
    length_arg(tip_radius, "tip_radius")
    if not (isinstance(points, np.ndarray) and isinstance(normals, np.ndarray)
            and points.ndim == 3 and points.shape[2] == 3 and normals.shape == points.shape):
        raise InputError(f"points and normals: expected two (B, k, 3) arrays, got "
                         f"{getattr(points, 'shape', type(points).__name__)} and "
                         f"{getattr(normals, 'shape', type(normals).__name__)}")
    B, k, _ = points.shape
    single = points - tip_radius * normals
    if finger_ids is None:
        ids = np.broadcast_to(np.arange(k), (B, k))
        return single, np.ones((B, k), dtype=bool), np.zeros((B, k)), ids
    ids = finger_ids
    onehot = ids[:, None, :] == np.arange(k)[None, :, None]  # (B, f=k, k)
    count = onehot.sum(axis=2)
    present = count > 0
    w = onehot.astype(float)
    safe = np.maximum(count, 1)[..., None]
    c0 = np.einsum("bfj,bjx->bfx", w, single) / safe
    # Minimum-norm correction of c0 onto the planes n_j . c = n_j . p_j - r.
    A = np.einsum("bfj,bjx,bjy->bfxy", w, normals, normals)
    b = np.einsum("bjx,bjx->bj", normals, points) - tip_radius
    resid = b[:, None, :] - np.einsum("bjx,bfx->bfj", normals, c0)  # (B, f, k)
    g = np.einsum("bfj,bfj,bjx->bfx", w, resid, normals)
    multi = count > 1
    centers = c0.copy()
    if np.any(multi):
        pinv = np.linalg.pinv(A[multi], rcond=1e-10)
        centers[multi] = c0[multi] + np.einsum("nxy,ny->nx", pinv, g[multi])
    tangent = centers[:, :, None, :] + tip_radius * normals[:, None, :, :]  # (B, f, k, 3)
    gap = np.linalg.norm(tangent - points[:, None, :, :], axis=-1)
    misfit = np.where(onehot, gap, 0.0).max(axis=2)
    centers[~present] = np.nan
    return centers, present, misfit, ids
