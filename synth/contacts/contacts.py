"""The :class:`Contacts` result: points on a part's surface with inward normals."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from synth.errors import InputError

__all__ = ["FEATURE_KINDS", "Contacts"]

#: Allowed values of ``Contacts.features``.
FEATURE_KINDS: tuple[str, ...] = ("face", "edge", "vertex")


@dataclass(frozen=True, eq=False)
class Contacts:
    """Frictionless point contacts on a part, one row per contact.

    Each contact carries two readings of the surface's normal (see :mod:`synth.scores.surface`):
    ``normals``, the mesh's own (the facet's inside a face, a direction of the feature's normal
    cone at an edge or a vertex), along which a fingertip touching the mesh pushes; and
    ``smooth_normals``, those of the smooth surface the mesh may approximate (interpolated across
    a tessellated curved patch; the same as ``normals`` on planar facets and sharp features).

    Attributes
    ----------
    points : (n, 3) float
        Contact points on the surface.
    normals : (n, 3) float
        Unit normals of the mesh as given, pointing INTO the object (Trinkle's convention).
    features : (n,) str
        ``"face"``, ``"edge"`` or ``"vertex"``: the feature the contact lies on.
    feature_index : (n,) int
        Face, unique-edge or vertex index of that feature in ``part.mesh``.
    faces : (n,) int
        Face that carries the contact (the face whose plane the normal belongs to).
    unique_normal : (n,) bool
        False where the normal was chosen from a cone (convex edge or corner, saddle).
    region : (n,) int
        Region id of ``faces``, -1 if none.
    finger : (n,) int
        Contacts one fingertip makes together (the 2 of a groove, the 3 of an inside
        corner) share an id; other contacts have distinct ids.
    smooth_normals : (n, 3) float, optional
        Unit inward normals of the smooth reading; default: ``normals``.

    Examples
    --------
    >>> c = Contacts(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), np.array(["face"]),
    ...              np.array([0]), np.array([0]), np.array([True]), np.array([0]),
    ...              np.array([0]))
    >>> len(c)
    1
    """

    points: np.ndarray
    normals: np.ndarray
    features: np.ndarray
    feature_index: np.ndarray
    faces: np.ndarray
    unique_normal: np.ndarray
    region: np.ndarray
    finger: np.ndarray
    # None given: ``normals`` (set by __post_init__, so never None on an instance)
    smooth_normals: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        pts = np.array(self.points, dtype=float, copy=True)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise InputError(f"Contacts.points: expected shape (n, 3), got {pts.shape}")
        n = len(pts)
        nrm = np.array(self.normals, dtype=float, copy=True)
        if nrm.shape != (n, 3):
            raise InputError(f"Contacts.normals: expected shape ({n}, 3), got {nrm.shape}")
        smooth = nrm.copy() if self.smooth_normals is None else np.array(
            self.smooth_normals, dtype=float, copy=True)
        if smooth.shape != (n, 3):
            raise InputError(f"Contacts.smooth_normals: expected shape ({n}, 3), got "
                             f"{smooth.shape}")
        if not (np.isfinite(pts).all() and np.isfinite(nrm).all() and np.isfinite(smooth).all()):
            raise InputError("Contacts: points and normals must be finite")
        conv: dict[str, Any] = {"points": pts, "normals": nrm, "smooth_normals": smooth}
        conv["features"] = np.array(self.features, dtype="<U6", copy=True)
        bad = ~np.isin(conv["features"], FEATURE_KINDS)
        if bad.any():
            raise InputError(
                f"Contacts.features: values must be one of {FEATURE_KINDS}, "
                f"got {sorted(set(conv['features'][bad].tolist()))}"
            )
        for name, dtype in (
            ("feature_index", np.int64),
            ("faces", np.int64),
            ("unique_normal", bool),
            ("region", np.int64),
            ("finger", np.int64),
        ):
            given = np.asarray(getattr(self, name))
            if dtype is not bool and given.size and not (
                    np.issubdtype(given.dtype, np.integer) or given.dtype == bool or (
                    np.issubdtype(given.dtype, np.floating) and np.isfinite(given).all()
                    and (given == np.round(given)).all())):
                raise InputError(f"Contacts.{name}: expected integers, got {given.dtype} "
                                 "values that are not (fractions, NaN or text)")
            conv[name] = np.array(given, dtype=dtype, copy=True)
        for name, arr in conv.items():
            if name not in ("points", "normals", "smooth_normals") and arr.shape != (n,):
                raise InputError(f"Contacts.{name}: expected shape ({n},), got {arr.shape}")
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return len(self.points)

    @property
    def n_fingers(self) -> int:
        """Number of distinct fingertips (distinct ``finger`` ids)."""
        return int(len(np.unique(self.finger)))

    def select(self, mask: np.ndarray | Sequence[int] | Sequence[bool]) -> Contacts:
        """Rows selected by a boolean mask (n,) or an index array.

        Parameters
        ----------
        mask : (n,) bool or (k,) int

        Returns
        -------
        Contacts
        """
        idx = np.asarray(mask)
        if idx.dtype == bool and idx.shape != (len(self),):
            raise InputError(f"Contacts.select: mask shape {idx.shape}, expected ({len(self)},)")
        if idx.dtype != bool and (idx.ndim != 1 or not (
                len(idx) == 0 or np.issubdtype(idx.dtype, np.integer))):
            raise InputError(f"Contacts.select: expected a boolean mask ({len(self)},) or an "
                             f"array of row indices, got {mask!r:.80}")
        if idx.dtype != bool and len(idx) and not (
                -len(self) <= idx.min() and idx.max() < len(self)):
            raise InputError(f"Contacts.select: row indices from {-len(self)} to "
                             f"{len(self) - 1}, got {int(idx.min())} to {int(idx.max())}")
        return Contacts(**{f.name: getattr(self, f.name)[idx] for f in fields(self)})

    @staticmethod
    def concatenate(parts: Sequence[Contacts]) -> Contacts:
        """Join contact sets; finger ids are renumbered so sets stay apart.

        Parameters
        ----------
        parts : sequence of Contacts

        Returns
        -------
        Contacts
        """
        if not parts:
            raise InputError("Contacts.concatenate: need at least one Contacts")
        for i, c in enumerate(parts):
            if not isinstance(c, Contacts):
                raise InputError(f"Contacts.concatenate: item {i} is a "
                                 f"{type(c).__name__}, expected Contacts")
        cols: dict[str, list[np.ndarray]] = {f.name: [] for f in fields(Contacts)}
        offset = 0
        for c in parts:
            for name in cols:
                arr = getattr(c, name)
                if name == "finger":
                    _, arr = np.unique(arr, return_inverse=True)
                    arr = arr + offset
                    offset = int(arr.max()) + 1 if len(arr) else offset
                cols[name].append(arr)
        return Contacts(**{k: np.concatenate(v) for k, v in cols.items()})

    def to_dict(self) -> dict[str, list[Any]]:
        """Plain lists, JSON-serialisable."""
        return {f.name: getattr(self, f.name).tolist() for f in fields(self)}
