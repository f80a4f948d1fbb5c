"""Values synth derives from a mesh, kept in trimesh's own cache of it.

trimesh empties a mesh's cache whenever its vertices or faces change, so a value kept there is
never read for a mesh it was not computed from. The loader and the part ask several of the
same questions of one mesh object (its pieces, volume, convexity, edge table); each is
answered once.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
import trimesh

from synth.part.tolerances import bounds

__all__ = ["cached", "face_geometry", "scaled_zero"]

T = TypeVar("T")


def scaled_zero(vertices: np.ndarray, power: int = 1) -> float:
    """trimesh's zero (``trimesh.util.TOL_ZERO``, 1e-13 whatever the mesh's size) for a
    quantity of length to this ``power`` (1: a vector's length, 2: a face's cross product,
    twice its area), below which trimesh gives a vector no direction and a face no normal:
    itself for a mesh of size 1 or more, scaled with a smaller mesh's size (the diagonal of
    its box) to that power, so that a part of side 1e-7 has the normals and corner angles it
    would have at side 1 (trimesh's zero gave none of its faces a normal)."""
    v = np.asarray(vertices, np.float64)
    if not len(v):
        return float(trimesh.util.TOL_ZERO)
    lo, hi = bounds(v)
    return float(trimesh.util.TOL_ZERO) * min(1.0, float(np.linalg.norm(hi - lo))) ** power


def cached(mesh: trimesh.Trimesh, key: Any, compute: Callable[[], T]) -> T:
    """``compute()``, kept in ``mesh``'s cache under ``key`` (a string or a tuple whose
    first item names the value) until the mesh changes or the key is deleted."""
    known = mesh._cache[key]  # None when not cached (or the mesh changed)
    if known is None:
        known = mesh._cache[key] = compute()
    return known


def face_geometry(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """trimesh's ``face_normals`` (f, 3) and ``area_faces`` (f,) of ``mesh``, the same values,
    kept where trimesh keeps them.

    Where trimesh has neither, they are found from the corners a coordinate at a time, by
    trimesh's arithmetic (the cross product of ``b - a`` and ``c - b``, its squares summed
    x, y, then z, as trimesh's BLAS dot sums them with OpenBLAS; another BLAS may differ in
    the last bit), without its (f, 3, 3) ``triangles`` and their (f, 3) cross products, which
    it would keep (0.05 against 0.16 s at 1.3M faces). A face has a normal when its cross
    product is longer than :func:`scaled_zero` (trimesh's own test for a mesh of size 1 or
    more; a smaller mesh's faces have the normals trimesh would give them at size 1). Normals
    already given (a face whose normal a repair kept) are left as they are; a mesh with a
    face of no normal is left to trimesh.
    """
    cache = mesh._cache
    if cache["face_normals"] is None and len(mesh.faces):
        v = np.asarray(mesh.vertices, np.float64)
        f = np.asarray(mesh.faces, np.int64)
        cols = [np.ascontiguousarray(v[:, k]) for k in range(3)]
        a, b = [], []  # the sides b - a and c - b, a coordinate each
        for x in cols:
            corner = [np.take(x, f[:, j]) for j in range(3)]
            a.append(corner[1] - corner[0])
            b.append(corner[2] - corner[1])
        cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                 a[0] * b[1] - a[1] * b[0]]
        del a, b
        norm = np.sqrt((cross[0] * cross[0] + cross[1] * cross[1]) + cross[2] * cross[2])
        if cache["area_faces"] is None:
            cache["area_faces"] = norm / 2.0
        if (norm > scaled_zero(v, 2)).all():
            scale = norm ** -1
            cache["face_normals"] = np.column_stack([c * scale for c in cross])
    return np.asarray(mesh.face_normals, np.float64), np.asarray(mesh.area_faces, np.float64)
