"""Decimation of a mesh too large to load, on request (``load_part(..., decimate=N)``).

Quadric edge collapse by fast-simplification (pip ``fast-simplification``, the wrapper of
Sven Forstmann's Fast-Quadric-Mesh-Simplification kept by the PyVista developers; an
optional dependency, imported only here). The corners of the raw triangles are first welded
where they coincide exactly (an STL stores every triangle's corners apart), so that the
collapse sees the surface and not a soup.

The surface error is measured, not assumed: the distance of sampled vertices of each mesh to
the other mesh's surface (exact point-triangle distances, :mod:`synth.part.closest`), both
ways, so it bounds how far the planned surface lies from the file's at those vertices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from synth.errors import InputError
from synth.part.closest import BoxTree

__all__ = ["Decimation", "decimate_mesh", "SAMPLED_VERTICES"]

#: Vertices of each mesh whose distance to the other is measured (all when fewer).
SAMPLED_VERTICES = 20_000


@dataclass(frozen=True)
class Decimation:
    """Result of :func:`decimate_mesh`.

    Attributes
    ----------
    mesh : trimesh.Trimesh
        The decimated mesh (``faces`` triangles or a few fewer).
    faces_before : int
    max_error, mean_error : float
        Largest and mean distance, in the mesh's units, of the sampled vertices of either
        mesh to the other's surface.
    sampled : int
        Vertices measured (of both meshes together).
    """

    mesh: trimesh.Trimesh
    faces_before: int
    max_error: float
    mean_error: float
    sampled: int

    def describe(self, length: float) -> str:
        """One line for ``Part.repairs``."""
        return (f"decimated {self.faces_before:,} triangles to {len(self.mesh.faces):,} "
                f"(quadric edge collapse); surface error at {self.sampled:,} sampled vertices "
                f"max {self.max_error:.3g} ({self.max_error / length:.2g} of the size), mean "
                f"{self.mean_error:.3g}")


def _distances(points: np.ndarray, mesh: trimesh.Trimesh, n: int, seed: int
               ) -> np.ndarray:
    """Exact distances of up to ``n`` of ``points`` (a seeded sample) to ``mesh``."""
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(points), size=min(n, len(points)), replace=False)
    return BoxTree(mesh.vertices, mesh.faces).closest(points[pick])[2]


def decimate_mesh(vertices: np.ndarray, faces: np.ndarray, target: int) -> Decimation:
    """Decimate a triangle mesh to about ``target`` faces and measure the surface error.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int
    target : int
        Faces wanted, at least 4 and fewer than ``m``.

    Returns
    -------
    Decimation

    Examples
    --------
    >>> import trimesh
    >>> m = trimesh.creation.icosphere(4)
    >>> d = decimate_mesh(m.vertices, m.faces, 500)
    >>> len(d.mesh.faces) <= 500 and d.max_error < 0.05
    True
    """
    try:
        import fast_simplification
    except ImportError as e:
        raise InputError("decimate: needs the package fast-simplification (pip install "
                         "fast-simplification, or synth[scale])") from e
    m = trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces, np.int64), process=False)
    before = len(m.faces)
    if not 4 <= int(target) < before:
        raise InputError(f"decimate: expected a face count from 4 to {before - 1:,} (fewer than "
                         f"the mesh's {before:,}), got {target}")
    m.merge_vertices(merge_tex=True, merge_norm=True)
    v, f = fast_simplification.simplify(np.asarray(m.vertices, np.float64),
                                        np.asarray(m.faces, np.int64),
                                        target_reduction=1.0 - int(target) / len(m.faces))
    out = trimesh.Trimesh(np.asarray(v, float), np.asarray(f, np.int64), process=False)
    out.remove_unreferenced_vertices()
    d = np.concatenate([_distances(np.asarray(m.vertices, float), out, SAMPLED_VERTICES, 0),
                        _distances(np.asarray(out.vertices, float), m, SAMPLED_VERTICES, 1)])
    return Decimation(out, before, float(d.max()), float(d.mean()), len(d))
