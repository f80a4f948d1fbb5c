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
    Faces whose smallest height is below ``DEGENERATE_RTOL * length``, or below the
    coordinates' precision (their normal is then noise), are slivers: repaired by an edge
    flip or a merge of two corners (:mod:`synth.part.repair`), dropped only where that fails.
FLAT_RTOL
    A mesh whose vertex cloud has a third principal extent below ``FLAT_RTOL * length``
    is a flat sheet and is refused (as a piece of a part with several bodies it is kept as an
    open surface).
EXPOSURE_STEP_RTOL
    A surface point is exposed when a step of ``EXPOSURE_STEP_RTOL * length`` outward along
    its normal lands outside every other closed body (see :mod:`synth.part.bodies`). 2e-3
    covers the gaps between the pieces of convex decompositions (1e-5 to 1e-3 of the size):
    a face across such a gap from another piece is hidden.
EXPOSURE_MARGIN_RTOL
    ... by at least ``EXPOSURE_MARGIN_RTOL * length``, so that a check of its own agrees.
GROUP_GAP_RTOL
    Two bodies of a file belong to one part when the gap between them is at most this
    fraction of the file's bounding-box diagonal; bodies farther apart are separate objects
    (a file holding several parts), of which one is planned. Convex decompositions leave gaps
    of 1e-5 to 1e-3 of the size, and up to 2% where the decomposition drops a thin neck
    (measured on pybullet's random objects); 5% keeps those whole.
PRECISION_FACTOR
    Coordinates carry a rounding error of their own (``coordinate_precision``): float32
    files (every binary STL) hold about 7 significant digits of the coordinate, so a part far
    from its origin is known far less precisely than its size suggests. Every length
    tolerance is at least ``PRECISION_FACTOR`` times that error, and the coplanarity test
    widens by the normal error it causes on small faces.
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
    "EXPOSURE_STEP_RTOL",
    "EXPOSURE_MARGIN_RTOL",
    "GROUP_GAP_RTOL",
    "PRECISION_FACTOR",
    "bounds",
    "coordinate_precision",
    "stored_as_float32",
    "surface_tolerance",
]

SHARP_ANGLE: float = float(np.radians(30.0))
COPLANAR_ANGLE: float = 1e-4
PATCH_HALF_ANGLE: float = float(np.radians(40.0))
FEATURE_RTOL: float = 1e-6
ON_SURFACE_RTOL: float = 1e-6
WELD_RTOL: float = 1e-9
DEGENERATE_RTOL: float = 1e-9
FLAT_RTOL: float = 1e-6
EXPOSURE_STEP_RTOL: float = 2e-3
EXPOSURE_MARGIN_RTOL: float = 1e-5
GROUP_GAP_RTOL: float = 5e-2
PRECISION_FACTOR: float = 4.0

_F32_RELATIVE = 2.0**-24  # half a float32 ulp, relative
_F64_RELATIVE = 2.0**-53


def surface_tolerance(length: float, precision: float) -> float:
    """Distance within which a point of a part of this size, and coordinates of this
    precision, is on its surface (``Part.surface_tolerance``); no repair moves the surface
    farther than this."""
    return max(ON_SURFACE_RTOL * length, PRECISION_FACTOR * precision)


def bounds(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest coordinates (3,) and (3,) of points (n, 3), one column at a time:
    numpy's reductions along the first axis of an (n, 3) array took 10x as long (86 against
    8 ms for 3.9M points)."""
    p = np.asarray(points, dtype=np.float64)
    return (np.array([p[:, c].min() for c in range(p.shape[1])]),
            np.array([p[:, c].max() for c in range(p.shape[1])]))


#: Rows at a time of the float32 test of :func:`coordinate_precision`.
_BLOCK = 1 << 16


def stored_as_float32(vertices: np.ndarray) -> bool:
    """Whether every coordinate is exactly a float32 (binary STL, float32 PLY), a block of
    rows at a time (without (v, 3) temporaries: at 3.9M vertices each is 94 MB of fresh
    pages)."""
    v = np.asarray(vertices, dtype=np.float64)
    return all(np.array_equal(b.astype(np.float32).astype(np.float64), b)
               for b in (v[i:i + _BLOCK] for i in range(0, len(v), _BLOCK)))


def coordinate_precision(vertices: np.ndarray) -> float:
    """Rounding error of a mesh's stored coordinates, in its units.

    Half an ulp of the largest coordinate in the precision the file stored: float32 when
    every value is exactly a float32 (binary STL, float32 PLY), else float64; or, for text
    files written with a fixed number of decimals (4 to 8), half the last decimal when that
    is larger. The decimals are read from the values only where they show them: every value
    a nonzero multiple of the last decimal, and one at least of three significant digits
    ending in it, or three different values ending in it (a small part's 0.0012). Round
    numbers (0.5, 0.25, 5e-08) are written exactly with any number of decimals and say
    nothing of it; taken as 4 decimals they gave a box of side 1e-8 a rounding error of
    5e-5, 5,000 times its size.

    Parameters
    ----------
    vertices : (v, 3) float

    Returns
    -------
    float

    Examples
    --------
    >>> coordinate_precision(np.array([[1000.0, 0.0, 0.0]], np.float32).astype(float))
    5.9604644775390625e-05
    >>> coordinate_precision(np.array([[0.1235, 2.5, -1.0]]))  # 4 decimals
    5e-05
    >>> coordinate_precision(np.array([[0.5, -0.5, 0.5]]))  # round: float32, exact
    2.9802322387695312e-08
    """
    v = np.asarray(vertices, dtype=np.float64)
    if v.size == 0:
        return 0.0
    lo, hi = bounds(v.reshape(len(v), -1))
    top = float(np.abs(np.concatenate([lo, hi])).max())
    err = top * (_F32_RELATIVE if stored_as_float32(v) else _F64_RELATIVE)
    sample = v.ravel()[:: max(1, v.size // 4096)]
    frac = sample[sample != np.round(sample)]
    # text written with a fixed number of decimals (4 to 8): half the last decimal
    for digits in range(4, 9) if len(frac) else ():
        scaled = frac * 10.0**digits
        steps = np.round(scaled)
        if not np.all(np.abs(scaled - steps) <= 1e-3):
            continue  # not on this grid (a finer one may hold them)
        if not steps.all():
            continue  # a value these decimals would write as 0: they are more
        last = np.abs(steps) % 10 != 0  # the value needs its last decimal
        if np.any(last & (np.abs(steps) >= 100)) or len(np.unique(np.abs(steps[last]))) >= 3:
            err = max(err, 0.5 * 10.0**-digits)
        break
    return err
