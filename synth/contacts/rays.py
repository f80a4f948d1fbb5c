"""Contacts from approach rays: a finger moving along a direction hits the surface."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from synth.contacts.contacts import Contacts
from synth.errors import InputError

if TYPE_CHECKING:
    from synth.part.model import Part

__all__ = ["contacts_from_rays"]


def contacts_from_rays(part: Part, origins: np.ndarray, directions: np.ndarray) -> Contacts:
    """Resolve the first hit of each ray on the part's surface.

    Parameters
    ----------
    part : Part
    origins : (r, 3) float
        Start points of the fingertips (outside the part).
    directions : (r, 3) float
        Approach directions (any non-zero length).

    Returns
    -------
    Contacts
        Contacts of the rays that hit, resolved as in :meth:`Part.resolve`; ``finger`` is
        the index of the ray, so rays that miss have no rows and a ray hitting a groove
        gives two rows with its index.

    Examples
    --------
    >>> c = contacts_from_rays(part, [[0, 0, 5.0]], [[0, 0, -1.0]])  # doctest: +SKIP
    """
    o = np.asarray(origins, dtype=float).reshape(-1, 3) if np.size(origins) else np.zeros((0, 3))
    d = np.asarray(directions, dtype=float)
    if d.shape != o.shape or d.ndim != 2:
        raise InputError(f"directions: expected shape {o.shape} like origins, got {d.shape}")
    if not (np.isfinite(o).all() and np.isfinite(d).all()):
        raise InputError("origins and directions must be finite")
    norm = np.linalg.norm(d, axis=1)
    if (norm <= 0).any():
        raise InputError(f"directions: row {int(np.argmin(norm))} has zero length")
    d = d / norm[:, None]
    locs, ray_idx, tri_idx = part.mesh.ray.intersects_location(o, d, multiple_hits=False)
    ray_idx = np.asarray(ray_idx, np.int64)
    order = np.argsort(ray_idx, kind="stable")
    locs, ray_idx, tri_idx = locs[order], ray_idx[order], np.asarray(tri_idx, np.int64)[order]
    c = part.resolve(np.asarray(locs, float).reshape(-1, 3), tri_idx, snap=True)
    return replace(c, finger=ray_idx[c.finger])
