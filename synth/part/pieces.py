"""Convex planar pieces of a part's planar face regions.

A *piece* is a convex set of coplanar, wholly exposed faces grown around one face: on it a
contact's normal is fixed and its wrench is affine in its position. The planner optimises
positions over pieces (:mod:`synth.plan.pieces`); contact regions are certified on them
(:mod:`synth.robust`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, QhullError

__all__ = ["PlanarPiece", "convex_piece"]

_MAX_PIECE_FACES = 256


@dataclass(frozen=True)
class PlanarPiece:
    """A convex part of a planar face region, shrunk by a margin, in plane coordinates.

    Attributes
    ----------
    region : int
    faces : (f,) int
    origin : (3,) float
        A point of the plane.
    u, v : (3,) float
        Orthonormal in-plane axes.
    normal : (3,) float
        Inward unit normal.
    A : (h, 2) float
    b : (h,) float
        The shrunk polygon ``A [x, y] <= b`` (rows of ``A`` are unit vectors).
    corners : (c, 2) float
        Corners of the piece before shrinking, in order around it, in plane coordinates.
    """

    region: int
    faces: NDArray[np.int64]
    origin: NDArray[np.float64]
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    normal: NDArray[np.float64]
    A: NDArray[np.float64]
    b: NDArray[np.float64]
    corners: NDArray[np.float64]

    def to_3d(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Plane coordinates ``(..., 2)`` to points ``(..., 3)``."""
        return self.origin + xy[..., :1] * self.u + xy[..., 1:2] * self.v


def convex_piece(part, face: int, margin: float) -> PlanarPiece | None:
    """Grow a convex piece of ``face``'s planar region around it; None if nothing is left.

    Neighbouring faces of the same region are added while the union stays convex (its convex
    hull has the union's area); the polygon is then shrunk by ``margin``. Only faces sampled
    as wholly exposed (``part.face_exposure == 2``) are used; positions found on a piece are
    still checked point by point. Pieces are kept on the part, one per face and margin.
    """
    cache = part.__dict__.setdefault("_synth_pieces", {})
    key = (int(face), float(margin))
    if key not in cache:
        cache[key] = _grow_piece(part, int(face), float(margin))
    return cache[key]


def _grow_piece(part, face: int, margin: float) -> PlanarPiece | None:
    region = int(part.face_region[face])
    reg = part.regions[region]
    if not reg.planar or part.face_exposure[face] != 2:
        return None
    mesh = part.mesh
    n_in = np.asarray(reg.normal, dtype=np.float64)
    corners = part._corners(face)
    origin = corners[0]
    e = corners[1] - origin
    u = e - np.dot(e, n_in) * n_in
    u /= np.linalg.norm(u)
    v = np.cross(n_in, u)

    def to2(pts: NDArray[np.float64]) -> NDArray[np.float64]:
        d = pts - origin
        return np.stack([d @ u, d @ v], axis=-1)

    in_region = (part.face_region == region) & (part.face_exposure == 2)
    neighbours = _face_neighbours(part)
    chosen = [face]
    area = float(mesh.area_faces[face])
    pts = to2(corners)
    frontier = list(neighbours[face])
    seen = {face}
    while frontier and len(chosen) < _MAX_PIECE_FACES:
        f = frontier.pop(0)
        if f in seen or not in_region[f]:
            continue
        seen.add(f)
        cand = np.vstack([pts, to2(part._corners(f))])
        a = area + float(mesh.area_faces[f])
        try:
            hull_area = ConvexHull(cand).volume
        except QhullError:
            continue
        if hull_area <= a * (1 + 1e-6):
            chosen.append(f)
            pts, area = cand, a
            frontier.extend(neighbours[f])
    try:
        hull = ConvexHull(pts)
    except QhullError:
        return None
    A = hull.equations[:, :2]
    b = -hull.equations[:, 2] - margin
    # empty after shrinking? (largest inscribed circle radius < 0)
    res = linprog(
        [0, 0, -1], A_ub=np.hstack([A, np.ones((len(b), 1))]), b_ub=b,
        bounds=[(None, None), (None, None), (0, None)], method="highs",
    )
    if res.status != 0 or res.x[2] <= 1e-12 * part.length:
        return None
    return PlanarPiece(region, np.array(chosen), origin, u, v, n_in, A, b, pts[hull.vertices])


def _face_neighbours(part) -> list[list[int]]:
    cache = part.__dict__.get("_synth_face_neighbours")
    if cache is None:
        nb: list[list[int]] = [[] for _ in range(len(part.mesh.faces))]
        for a, b in part.mesh.face_adjacency:
            nb[a].append(int(b))
            nb[b].append(int(a))
        object.__setattr__(part, "_synth_face_neighbours", nb)
        cache = nb
    return cache
