"""Tolerances of the part model (mesh loading, features, regions, normal resolution).

Lengths are relative to the part's characteristic length ``Part.length`` (the diagonal of
its axis-aligned bounding box), so every test is scale-free; angles are in radians.

SHARP_ANGLE
    Default dihedral threshold: an edge whose two face normals differ by more than this is
    sharp (convex or concave), otherwise smooth. 30 degrees keeps every tessellation of a
    curved surface with at least 12 segments per turn smooth, and every edge of a box,
    prism (60 deg) or hexagonal nut (60 deg) sharp. Settable per part (``sharp_angle=``).
COPLANAR_ANGLE
    Two adjacent faces are coplanar (same planar facet) when their normals differ by less
    than this. 1e-4 rad is above the normal noise of float32 STL coordinates on faces that
    are not slivers and far below the dihedral angle of any sensible tessellation.
PATCH_HALF_ANGLE
    A smooth component whose face normals all lie within this angle of their mean is one
    region; a wider one (a whole cylinder side, a sphere) is split into patches along the
    cells of an icosahedron (each cell within 37.4 deg of its direction).
FEATURE_RTOL
    A surface point within ``FEATURE_RTOL * length`` of a vertex or edge is on that vertex
    or edge (so it gets a normal cone or several contacts rather than a face normal).
ON_SURFACE_RTOL
    ``Part.resolve`` accepts points within ``ON_SURFACE_RTOL * length`` of the surface
    (unless asked to snap them onto it).
WELD_RTOL
    Vertices closer than about ``WELD_RTOL * length`` are welded (rounding to decimals).
DEGENERATE_RTOL
    Faces whose smallest height is below ``DEGENERATE_RTOL * length`` are dropped.
FLAT_RTOL
    A mesh whose vertex cloud has a third principal extent below ``FLAT_RTOL * length``
    is a flat sheet and is refused.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "SHARP_ANGLE",
    "COPLANAR_ANGLE",
    "PATCH_HALF_ANGLE",
    "FEATURE_RTOL",
    "ON_SURFACE_RTOL",
    "WELD_RTOL",
    "DEGENERATE_RTOL",
    "FLAT_RTOL",
]

SHARP_ANGLE: float = float(np.radians(30.0))
COPLANAR_ANGLE: float = 1e-4
PATCH_HALF_ANGLE: float = float(np.radians(40.0))
FEATURE_RTOL: float = 1e-6
ON_SURFACE_RTOL: float = 1e-6
WELD_RTOL: float = 1e-9
DEGENERATE_RTOL: float = 1e-9
FLAT_RTOL: float = 1e-6
