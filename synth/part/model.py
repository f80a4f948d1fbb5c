"""The :class:`Part`: a cleaned mesh with its features, regions and mass properties."""

from __future__ import annotations

from typing import Any

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from synth.contacts.contacts import Contacts
from synth.errors import InputError
from synth.part import tolerances as tol
from synth.part.features import EDGE_KINDS, VERTEX_KINDS, Features, compute_features
from synth.part.regions import Region, RegionSet, compute_regions

__all__ = ["Part"]


class Part:
    """A rigid part to grasp: a cleaned triangle mesh and everything derived from it.

    Build one with :func:`synth.load_part`; everything is computed in the constructor and
    the object is read-only afterwards (do not modify ``part.mesh`` in place).

    Attributes
    ----------
    mesh : trimesh.Trimesh
        Welded, consistently wound mesh with outward face normals.
    units : str or None
        Length unit (a trimesh unit name such as ``"millimeters"``), None if unknown.
    length : float
        Characteristic length: the diagonal of the axis-aligned bounding box, in ``units``.
        Used only to make tolerances and moment arms scale-free.
    center_mass : (3,) float
    volume : float
        Meaningful only for a watertight mesh (see ``warnings``).
    repairs : tuple of str
        What the loader changed.
    warnings : tuple of str
        What the loader could not fix and what it means for the results.
    source : str or None
        File the part came from.
    sha256 : str or None
        Hash of that file's bytes.
    features : Features
        Sharp/smooth edges and vertex classes.
    regions : tuple of Region
        Planar facets and smooth patches.
    face_region : (f,) int
        Region id of each face.
    """

    _frozen: bool = False

    def __init__(
        self,
        mesh: trimesh.Trimesh,
        *,
        units: str | None = None,
        sharp_angle: float = tol.SHARP_ANGLE,
        repairs: tuple[str, ...] | list[str] = (),
        warnings: tuple[str, ...] | list[str] = (),
        source: str | None = None,
        sha256: str | None = None,
    ) -> None:
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError("Part: mesh must be a non-empty trimesh.Trimesh")
        sharp_angle = float(sharp_angle)
        if not 0.0 < sharp_angle < np.pi:
            raise InputError(f"sharp_angle: expected radians in (0, pi), got {sharp_angle}")
        self.mesh = mesh
        self.units = units
        self.repairs = tuple(repairs)
        self.warnings = tuple(warnings)
        self.source = source
        self.sha256 = sha256
        self.length = float(np.linalg.norm(mesh.extents))
        self.volume = float(mesh.volume)
        self.center_mass = np.asarray(
            mesh.center_mass if mesh.is_watertight else mesh.centroid, float
        )
        self.center_mass.flags.writeable = False
        self.features: Features = compute_features(mesh, sharp_angle)
        self._regions: RegionSet = compute_regions(
            mesh, self.features, tol.COPLANAR_ANGLE, tol.PATCH_HALF_ANGLE
        )
        self.regions: tuple[Region, ...] = self._regions.regions
        self.face_region: np.ndarray = self._regions.face_region
        tri = np.asarray(mesh.triangles, float)
        tri.flags.writeable = False
        self._triangles = tri
        centroids = tri.mean(axis=1)
        self._centroid_tree = cKDTree(centroids)
        self._face_radius_max = float(
            np.linalg.norm(tri - centroids[:, None, :], axis=2).max() * (1 + 1e-9)
        )
        fn = np.asarray(mesh.face_normals, float)
        self._plane_normals = fn
        self._plane_offsets = np.einsum("ij,ij->i", fn, tri[:, 0])
        edge = np.roll(tri, -1, axis=1) - tri  # edges (0,1), (1,2), (2,0)
        en = np.cross(fn[:, None, :], edge)  # in-plane, pointing into the triangle
        en /= np.maximum(np.linalg.norm(en, axis=2, keepdims=True), 1e-300)
        self._edge_normals = en
        self._edge_offsets = np.einsum("ijk,ijk->ij", en, tri)
        self._vertex_cone = self._build_vertex_cone()
        self._frozen = True

    def __setattr__(self, name: str, value: Any) -> None:
        if self._frozen:
            raise AttributeError(f"Part is read-only (cannot set {name!r})")
        object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        src = f" from {self.source!r}" if self.source else ""
        return (
            f"<Part{src}: {len(self.mesh.faces)} faces, {len(self.regions)} regions, "
            f"length {self.length:.4g} {self.units or '(unit unknown)'}>"
        )

    # tolerances -----------------------------------------------------------------------
    @property
    def feature_tolerance(self) -> float:
        """Distance within which a point is on an edge or vertex, in ``units``."""
        return tol.FEATURE_RTOL * self.length

    @property
    def surface_tolerance(self) -> float:
        """Distance within which ``resolve`` accepts a point as on the surface."""
        return tol.ON_SURFACE_RTOL * self.length

    @property
    def watertight(self) -> bool:
        """True when the mesh is a closed manifold (volume and inside tests are valid)."""
        return bool(self.mesh.is_watertight)

    # features -------------------------------------------------------------------------
    def _build_vertex_cone(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CSR of (vertex -> one (face, inward normal) per incident normal group)."""
        faces = np.asarray(self.mesh.faces, np.int64)
        n_v = len(self.mesh.vertices)
        group = self._regions.face_group
        v = faces.ravel()
        g = np.repeat(group, 3)
        key = v * (int(group.max()) + 1) + g
        _, first = np.unique(key, return_index=True)  # sorted by vertex, then group
        cone_faces = first // 3
        cone_normals = self._regions.corner_normals.reshape(-1, 3)[first]
        counts = np.bincount(v[first], minlength=n_v)
        off = np.concatenate([[0], np.cumsum(counts)])
        for a in (off, cone_faces, cone_normals):
            a.flags.writeable = False
        return off, cone_faces, cone_normals

    def normal_cone(self, kind: str, index: int) -> np.ndarray:
        """Inward normals of the facets around a feature.

        Parameters
        ----------
        kind : {"face", "edge", "vertex"}
        index : int
            Face, unique-edge or vertex index.

        Returns
        -------
        normals : (k, 3) float
            One normal for a face, two for an edge, one per incident facet (planar
            region or smooth component) for a vertex.
        """
        if kind == "face":
            return -np.asarray(self.mesh.face_normals[[index]], float)
        if kind == "edge":
            fs = self.features.edge_faces[index]
            return -np.asarray(self.mesh.face_normals[fs[fs >= 0]], float)
        if kind == "vertex":
            off, _, cn = self._vertex_cone
            return np.array(cn[off[index] : off[index + 1]])
        raise InputError(f"kind: expected 'face', 'edge' or 'vertex', got {kind!r}")

    def edge_kind(self, index: int) -> str:
        """Kind of a unique edge: one of ``"smooth", "convex", "concave", "boundary"``."""
        return EDGE_KINDS[int(self.features.edge_kind[index])]

    def vertex_kind(self, index: int) -> str:
        """Kind of a vertex (see :data:`synth.part.features.VERTEX_KINDS`)."""
        return VERTEX_KINDS[int(self.features.vertex_kind[index])]

    # contacts -------------------------------------------------------------------------
    def resolve(
        self, points: np.ndarray, faces: np.ndarray | None = None, *, snap: bool = False
    ) -> Contacts:
        """Turn surface points into contacts with inward normals.

        Parameters
        ----------
        points : (n, 3) float
            Points on the surface (within ``surface_tolerance``), or anywhere if ``snap``.
        faces : (n,) int, optional
            Face of each point when known (skips the closest-point search).
        snap : bool
            Project the points onto the surface instead of refusing distant ones.

        Returns
        -------
        Contacts
            One row per contact; a point on a concave edge or in a concave corner gives
            several rows sharing its ``finger`` id (= the point's index).

        Examples
        --------
        >>> c = part.resolve([[0.5, 0.0, 0.0]])  # doctest: +SKIP
        """
        from synth.part.resolve import resolve_points

        return resolve_points(self, np.asarray(points, float), faces, snap=snap)

    def raycast(self, origins: np.ndarray, directions: np.ndarray) -> Any:
        """Contacts where fingers moving from ``origins`` along ``directions`` first hit.

        See :func:`synth.contacts.contacts_from_rays`.
        """
        from synth.contacts.rays import contacts_from_rays

        return contacts_from_rays(self, origins, directions)
