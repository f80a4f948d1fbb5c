"""Which normals score a grasp on a mesh: the facets as given, the smooth surface they may
approximate, or both.

A triangle mesh is either exact (a simulator's collision hull: the facets *are* the object)
or an approximation of a smooth surface (a tessellated CAD cylinder, a scan); synth cannot
tell which. So every contact on a part carries two readings of its normal
(:class:`synth.Contacts`): the mesh's own (``normals``: the facet's inside a face, a direction
of the feature's normal cone at an edge or vertex), along which a fingertip touching the facets
pushes; and the smooth one (``smooth_normals``: interpolated across a tessellated curved patch,
equal to the mesh's on planar facets and sharp features). A *surface model* says which of them
a grasp must hold with:

``"both"`` (the default)
    The grasp counts as closure only if it is closure with both readings, and its d* (and its
    conditioning and epsilon) is the smaller of the two. True for an exact mesh and for the
    surface it approximates: on a collision hull it refuses grasps that hold only on the
    interpolated normals (none of which hold in a simulator), and on a tessellated cylinder it
    keeps the honest answer that no frictionless grasp holds (the facets alone accept some).
``"mesh"``
    The facets are the object (a simulator's collision mesh). Risk: on a tessellated smooth
    part the facets' small tilts give closure that the real, smooth part does not have.
``"smooth"``
    The mesh approximates a smooth surface (a scan, a tessellated CAD part). Risk: on an exact
    polyhedral mesh (a convex decomposition) d* can be overstated, or a grasp reported as
    closure that falls out of a simulator.

Fingertips are seated on the mesh in every model: a tip touching a contact has its centre at
``point - r * normals`` (the mesh's reading), so it touches the facets without sinking into them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from synth.errors import InputError
from synth.limits import DEFAULT_SURFACE, SURFACES
from synth.scores.batch import form_closure_batch
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.quality import scaled_wrenches

__all__ = ["SURFACES", "DEFAULT_SURFACE", "SAME_NORMAL_TOL", "SurfaceScores", "check_surface",
           "readings", "differs", "surface_scores", "worst_reading", "worst_reading_batch"]

#: Two readings of a grasp whose normals differ by at most this (per component) are the same
#: reading: it is scored once. The effect of such a difference on d* is of the same order,
#: far below the LPs' accuracy (1e-7).
SAME_NORMAL_TOL: float = 1e-12


def check_surface(surface: object) -> str:
    """``surface`` if it names a surface model, else an :class:`~synth.InputError`.

    Examples
    --------
    >>> check_surface("mesh")
    'mesh'
    """
    if not isinstance(surface, str) or surface not in SURFACES:
        raise InputError(f"surface: expected one of {', '.join(SURFACES)}, got {surface!r}")
    return surface


def readings(normals: NDArray[np.float64], smooth: NDArray[np.float64], surface: str
             ) -> tuple[NDArray[np.float64], ...]:
    """The normal sets a grasp is scored with under ``surface``: ``(normals, smooth)`` for
    ``"both"``, ``(normals,)`` for ``"mesh"``, ``(smooth,)`` for ``"smooth"``.

    Parameters
    ----------
    normals, smooth : (..., k, 3) float
        The mesh's and the smooth reading's inward unit normals.
    surface : str
        One of :data:`SURFACES`.

    Returns
    -------
    tuple of (..., k, 3) float
    """
    surface = check_surface(surface)
    if surface == "mesh":
        return (normals,)
    if surface == "smooth":
        return (smooth,)
    return (normals, smooth)


def differs(normals: NDArray[np.float64], smooth: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which grasps (B,) have two distinct readings: some normal differs by more than
    :data:`SAME_NORMAL_TOL` (contacts on a tessellated curved patch).

    Parameters
    ----------
    normals, smooth : (B, k, 3) float

    Returns
    -------
    (B,) bool
    """
    return np.asarray(
        (np.abs(np.asarray(smooth) - np.asarray(normals)) > SAME_NORMAL_TOL).any(axis=(1, 2)))


@dataclass(frozen=True)
class SurfaceScores:
    """d* of B grasps under a surface model, with each reading's own.

    Attributes
    ----------
    d_star : (B,) float
        The model's d*: the smaller of the two readings' under ``"both"``.
    closure : (B,) bool
        (Frictional) form closure under the model: with both readings under ``"both"``.
    d_mesh, d_smooth : (B,) float
        d* with the mesh's normals and with the smooth reading's.
    closure_mesh, closure_smooth : (B,) bool
    surface : str
    """

    d_star: NDArray[np.float64]
    closure: NDArray[np.bool_]
    d_mesh: NDArray[np.float64]
    d_smooth: NDArray[np.float64]
    closure_mesh: NDArray[np.bool_]
    closure_smooth: NDArray[np.bool_]
    surface: str


def surface_scores(points: ArrayLike, normals: ArrayLike, smooth: ArrayLike, surface: str,
                   center: ArrayLike, length: float, mu: float = 0.0, edges: int = 8, *,
                   compiled: bool | None = None) -> SurfaceScores:
    """Trinkle's d* (frictional with ``mu > 0``) of B grasps with both readings of their
    normals, and under the surface model.

    Parameters
    ----------
    points, normals, smooth : (B, k, 3) float
        Contacts, the mesh's inward normals and the smooth reading's.
    surface : str
        One of :data:`SURFACES`.
    center : (3,) float
        Moment reference (the centre of mass).
    length : float
        Moment scale (the part's length).
    mu : float
        Coulomb friction coefficient (0: frictionless).
    edges : int
        Sides of the inscribed friction pyramid (with ``mu > 0``).
    compiled : bool or None
        The simplex route (see :func:`synth.form_closure_batch`).

    Returns
    -------
    SurfaceScores

    Examples
    --------
    >>> import numpy as np
    >>> P = np.array([[[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
    ...                [1, 1, 1]]], float) / 2
    >>> N = -np.sign(P) * (np.abs(P) == np.abs(P).max(axis=2, keepdims=True))
    >>> N[0, 6] = [-1, 0, 0]
    >>> s = surface_scores(P, N, N, "both", np.zeros(3), 1.0)
    >>> bool(s.closure[0]), float(s.d_star[0]) == float(s.d_mesh[0])
    (True, True)
    """
    surface = check_surface(surface)
    P = np.asarray(points, float)
    N = np.asarray(normals, float)
    S = np.asarray(smooth, float)
    if P.ndim != 3 or P.shape[2] != 3 or N.shape != P.shape or S.shape != P.shape:
        raise InputError(f"points, normals, smooth: expected three (B, k, 3) arrays, got "
                         f"{P.shape}, {N.shape} and {S.shape}")
    c = np.asarray(center, float)

    def score(PP: NDArray[np.float64], NN: NDArray[np.float64]
              ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        if mu > 0:
            r = frictional_form_closure_batch(PP, NN, mu, center=c, edges=edges,
                                              compiled=compiled)
        else:
            r = form_closure_batch(scaled_wrenches(PP, NN, c, length), compiled=compiled)
        return np.asarray(r.d_star, float), np.asarray(r.closure, bool)

    d_mesh, ok_mesh = score(P, N)
    d_smooth, ok_smooth = d_mesh.copy(), ok_mesh.copy()
    rows = np.flatnonzero(differs(N, S))
    if len(rows):
        d_smooth[rows], ok_smooth[rows] = score(P[rows], S[rows])
    if surface == "mesh":
        d, ok = d_mesh, ok_mesh
    elif surface == "smooth":
        d, ok = d_smooth, ok_smooth
    else:
        d, ok = np.minimum(d_mesh, d_smooth), ok_mesh & ok_smooth
    return SurfaceScores(d.copy(), ok.copy(), d_mesh, d_smooth, ok_mesh, ok_smooth, surface)


def worst_reading_batch(measure: Callable[[NDArray[np.float64], NDArray[np.int64]], ArrayLike],
                        normals: ArrayLike, smooth: ArrayLike,
                        surface: str) -> NDArray[np.float64]:
    """:func:`worst_reading` of a batch of grasps: ``measure(n, rows)`` maps the normals
    (b, k, 3) of the grasps ``rows`` (b,) of the batch to their (b,) values, and each grasp
    gets the smallest over the readings of the surface model (a second reading measured only
    where it differs from the first).

    Parameters
    ----------
    measure : callable((b, k, 3) float, (b,) int) -> (b,) float (array-like)
    normals, smooth : (B, k, 3) float
    surface : str

    Returns
    -------
    (B,) float
    """
    N, S = np.asarray(normals, float), np.asarray(smooth, float)
    sets = readings(N, S, surface)
    out = np.asarray(measure(sets[0], np.arange(len(N))), float).reshape(len(N))
    rows = np.flatnonzero(differs(N, S)) if len(sets) == 2 else np.zeros(0, np.int64)
    if len(rows):
        out[rows] = np.minimum(out[rows], np.asarray(measure(sets[1][rows], rows), float))
    return out


def worst_reading(measure: Callable[[NDArray[np.float64]], float], normals: ArrayLike,
                  smooth: ArrayLike, surface: str) -> float:
    """The smallest value of a grasp measure (conditioning, epsilon) over the readings of the
    surface model: a grasp is only as good as its weaker reading.

    Parameters
    ----------
    measure : callable((k, 3) float) -> float
        The measure of the grasp with the given normals.
    normals, smooth : (k, 3) float
    surface : str

    Returns
    -------
    float
    """
    N, S = np.asarray(normals, float), np.asarray(smooth, float)
    sets = readings(N, S, surface)
    if len(sets) == 2 and not differs(N[None], S[None])[0]:
        sets = sets[:1]
    return float(min(float(measure(n)) for n in sets))
