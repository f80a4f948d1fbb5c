"""The :class:`Part`: a cleaned mesh with its features, regions and mass properties."""

from __future__ import annotations

import math
import numbers
from dataclasses import replace
from typing import Any

import numpy as np
import trimesh

from synth.contacts.contacts import Contacts
from synth.errors import InputError
from synth.part import tolerances as tol
from synth.part.bodies import Body, Solids, body_labels, compute_bodies, face_sample_weights
from synth.part.closest import BoxTree
from synth.part.features import EDGE_KINDS, VERTEX_KINDS, Features, compute_features
from synth.part.points import xyz_rows
from synth.part.regions import Region, RegionSet, compute_regions

__all__ = ["Part"]


def _index(value: object, n: int, name: str) -> int:
    """An index into ``n`` items (an integer from 0 to n - 1), or an InputError naming it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not (
            0 <= int(value) < n):
        raise InputError(f"{name}: expected an integer from 0 to {n - 1}, got {value!r}")
    return int(value)


def checked_sharp_angle(value: object) -> float:
    """``sharp_angle`` in radians, in (0, pi), or an InputError naming it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (
            0.0 < float(value) < math.pi):
        raise InputError(f"sharp_angle: expected radians in (0, pi), got {value!r}")
    return float(value)

#: trimesh's cached arrays that only building a part reads (edges, adjacency, angles, and the
#: faces' corners, which :meth:`Part._corners` gathers when asked).
_BUILD_TABLES = frozenset({
    "edges", "edges_face", "edges_sorted", "edges_sparse", "edges_unique", "edges_unique_idx",
    "edges_unique_inverse", "edges_unique_length", "face_adjacency", "face_adjacency_edges",
    "face_adjacency_projections", "face_adjacency_unshared", "face_angles",
    "faces_unique_edges", "triangles", "triangles_cross", "vertices_component_label"})


def _drop_build_tables(mesh: trimesh.Trimesh) -> None:
    """Clear trimesh's cached ``_BUILD_TABLES`` of ``mesh`` (kept: normals, areas, bounds)."""
    mesh._cache.clear(exclude=[k for k in mesh._cache.cache if k not in _BUILD_TABLES])


#: Faces whose exposure :class:`Part` tests at a time.
_EXPOSURE_FACES = 1 << 15


class Part:
    """A rigid part to grasp: a cleaned triangle mesh and everything derived from it.

    Build one with :func:`synth.load_part`; everything is computed in the constructor and
    the object is read-only afterwards (do not modify ``part.mesh`` in place).

    A part may hold several bodies (the connected components of its mesh): the convex pieces
    of a collision mesh, or closed bodies beside open pieces. They move as one rigid part:
    the centre of mass is that of the closed bodies together, the characteristic length that
    of the whole, fingers are checked against every body, and contacts lie only on the
    *exposed* surface (:meth:`exposed`, :mod:`synth.part.bodies`).

    Attributes
    ----------
    mesh : trimesh.Trimesh
        Welded, consistently wound mesh with outward face normals (all bodies).
    units : str or None
        Length unit (a trimesh unit name such as ``"millimeters"``), None if unknown.
    length : float
        Characteristic length: the diagonal of the axis-aligned bounding box, in ``units``.
        Used only to make tolerances and moment arms scale-free.
    precision : float
        Rounding error of the stored coordinates
        (:func:`~synth.part.tolerances.coordinate_precision`), in ``units``; every length
        tolerance is at least a few times this.
    center_mass : (3,) float
        Of the closed bodies together (uniform density); the area centroid when no body is
        closed.
    volume : float
        Sum of the closed bodies' volumes.
    bodies : tuple of Body
        The connected pieces, in the order of their first face.
    face_body : (f,) int
        Body of each face.
    face_exposure : (f,) int8
        2 where the whole face is exposed, 1 where only part of it is, 0 where none of it is
        (sampled at 10 points per face; on a part of one body every face is 2).
    repairs : tuple of str
        What the loader changed, including bodies united into one.
    warnings : tuple of str
        What the loader could not fix and what it means for the results.
    dropped : tuple of str
        Bodies of the file that are not part of this part (a file holding several objects
        far apart), one line each.
    sharp_angle : float
        Dihedral angle (radians) above which an edge is sharp.
    body : int or str
        Which object of the file the loader kept (``load_part``'s ``body``).
    decimate : int or None
        The face count the file was decimated to on loading (``load_part``'s ``decimate``).
    load_options : dict
        How to load the same part again: :func:`synth.load_part` keywords (``units``,
        ``body``, ``sharp_angle`` in radians, ``decimate``).

    Parameters
    ----------
    face_source : (f,) int, optional
        For bodies united on loading, which input body each face came from: the seams
        between them are creases (sharp edges), never smoothed over. Kept as the attribute
        of the same name (None when not given).
    convex_inputs : dict of int to (v, 3) float, optional
        The input bodies (as numbered in ``face_source``) that were closed and convex, by
        their vertices: a body united from such pieces is exactly their union. Kept as the
        attribute of the same name (empty when not given).
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
        body_names: tuple[str, ...] | list[str] | None = None,
        dropped: tuple[str, ...] | list[str] = (),
        precision: float | None = None,
        face_source: np.ndarray | None = None,
        body: int | str = "largest",
        convex_inputs: dict[int, np.ndarray] | None = None,
        decimate: int | None = None,
    ) -> None:
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError("Part: mesh must be a non-empty trimesh.Trimesh")
        sharp_angle = checked_sharp_angle(sharp_angle)
        if units is not None:
            try:
                trimesh.units.unit_conversion(units, "meters")
            except Exception:  # trimesh raises bare errors for a name it does not know
                raise InputError(f"Part: units: expected a length unit trimesh knows (such as "
                                 f"'millimeters' or 'm'), or None, got {units!r}") from None
        if precision is not None and (isinstance(precision, bool) or not isinstance(
                precision, numbers.Real) or not (math.isfinite(precision) and precision >= 0)):
            raise InputError(f"Part: precision: expected a finite length >= 0 (or None), got "
                             f"{precision!r}")
        self.mesh = mesh
        self.units = units
        self.sharp_angle = sharp_angle
        self.body = body
        self.decimate = decimate
        self.repairs = tuple(repairs)
        self.warnings = tuple(warnings)
        self.dropped = tuple(dropped)
        self.source = source
        self.sha256 = sha256
        self.length = float(np.linalg.norm(mesh.extents))
        self.precision = float(tol.coordinate_precision(mesh.vertices) if precision is None
                               else precision)
        labels = body_labels(mesh)  # read-only
        self.face_body: np.ndarray = labels
        bodies = compute_bodies(mesh, labels, body_names,
                                tol.surface_tolerance(self.length, self.precision))
        closed = [b for b in bodies if b.closed]
        self.volume = float(sum(b.volume for b in closed))
        if closed:
            weights = np.array([b.volume for b in closed])
            self.center_mass = weights @ np.array([b.center for b in closed]) / weights.sum()
        else:
            self.center_mass = np.asarray(mesh.centroid, float)
        self.center_mass.flags.writeable = False
        src = None if face_source is None else np.asarray(face_source, np.int64)
        if src is not None and src.shape != (len(mesh.faces),):
            raise InputError(f"face_source: expected shape ({len(mesh.faces)},), got {src.shape}")
        if src is not None:
            src.flags.writeable = False
        self.face_source = src
        self.convex_inputs = dict(convex_inputs or {})
        # the edge and adjacency tables trimesh cached while the bodies were found are several
        # times the mesh's own size; the features build their own in one sort, and what the
        # part needs of them is in its features (trimesh computes them again on demand), so
        # dropping them here keeps them out of the peak memory of everything that follows
        _drop_build_tables(mesh)
        self.features: Features = compute_features(mesh, sharp_angle, src, tol.COPLANAR_ANGLE)
        self._regions: RegionSet = compute_regions(
            mesh, self.features, tol.COPLANAR_ANGLE, tol.PATCH_HALF_ANGLE, self.precision
        )
        self.regions: tuple[Region, ...] = self._regions.regions
        self.face_region: np.ndarray = self._regions.face_region
        self._vertex_cone = self._build_vertex_cone()
        self._index = BoxTree(mesh.vertices, mesh.faces)
        needs = len(bodies) > 1 or any(b.closed and not b.convex for b in bodies)
        self._solids = (Solids(mesh, bodies, self.features.edge_faces, self.features.face_edges,
                               self._index) if needs else None)
        _drop_build_tables(mesh)  # the corner angles the regions and solids read
        self._index.build()  # after the solids' temporaries are freed
        self.face_exposure, self.bodies = self._exposure(bodies)
        self._frozen = True

    def _exposure(self, bodies: list[Body]) -> tuple[np.ndarray, tuple[Body, ...]]:
        """Face exposure codes (f,) and the bodies with their exposed areas."""
        n_f = len(self.mesh.faces)
        exposure = np.full(n_f, 2, np.int8)
        frac = np.ones(n_f)
        if len(bodies) > 1 and self._solids is not None and self._solids.bodies:
            w = face_sample_weights()
            normals = np.asarray(self.mesh.face_normals, float)
            step, margin, reach = self._exposure_step()
            # a convex body never hides a point stepped off its own surface when the step
            # exceeds the margin (else: no owner, -1, and every body is tested)
            face_body = (np.asarray(self.face_body, np.int64) if margin < step * (1.0 - 1e-6)
                         else np.full(n_f, -1, np.int64))
            # a block of faces at a time: the tests' temporaries are tens of rows a point
            # (3.4 GB for the 3.5M points of a two-body 885k-face mug, all at once)
            for s in range(0, n_f, _EXPOSURE_FACES):
                faces = np.arange(s, min(s + _EXPOSURE_FACES, n_f))
                samples = np.einsum("sk,fkx->fsx", w, self._corners(faces))
                # a face smaller than the exposure step is clear if a ball holding its
                # stepped samples is (one test instead of one a sample)
                centre = samples.mean(axis=1)
                radius = np.linalg.norm(samples - centre[:, None], axis=2).max(axis=1)
                small = np.flatnonzero(radius < step)  # (a larger ball reaches its own face)
                clear = self._solids.clear(centre[small] + step * normals[faces[small]],
                                           radius[small], margin, reach,
                                           face_body[faces[small]])
                faces = np.delete(faces, small[clear])
                samples = np.delete(samples, small[clear], axis=0)
                pts = samples.reshape(-1, 3) + step * np.repeat(normals[faces], len(w), axis=0)
                ok = ~self._solids.hidden(pts, margin, reach,
                                          np.repeat(face_body[faces], len(w)))
                ok = ok.reshape(len(faces), len(w))
                frac[faces] = ok.mean(axis=1)
                exposure[faces] = np.where(ok.all(axis=1), 2, np.where(ok.any(axis=1), 1, 0))
        exposure.flags.writeable = False
        area = np.asarray(self.mesh.area_faces, float) * frac
        return exposure, tuple(replace(b, exposed_area=float(area[b.faces].sum()))
                               for b in bodies)

    def _corners(self, faces: Any = slice(None)) -> np.ndarray:
        """Corners (n, 3, 3) of ``faces`` (an index or mask of faces; all by default),
        gathered from the vertices on each call: the part keeps no (f, 3, 3) copy of them
        (94 MB at 1.3M faces)."""
        return self._index.vertices[self._index.faces[faces]]

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

    @property
    def load_options(self) -> dict[str, Any]:
        """:func:`synth.load_part` keywords that load this part again from its file."""
        return {"units": self.units, "body": self.body, "sharp_angle": self.sharp_angle,
                "decimate": self.decimate}

    # tolerances -----------------------------------------------------------------------
    @property
    def feature_tolerance(self) -> float:
        """Distance within which a point is on an edge or vertex, in ``units``."""
        return max(tol.FEATURE_RTOL * self.length, tol.PRECISION_FACTOR * self.precision)

    @property
    def surface_tolerance(self) -> float:
        """Distance within which ``resolve`` accepts a point as on the surface."""
        return tol.surface_tolerance(self.length, self.precision)

    @property
    def watertight(self) -> bool:
        """True when every body is closed (volume and inside tests are valid)."""
        return all(b.closed for b in self.bodies)

    # exposure -------------------------------------------------------------------------
    def exposed(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """Which surface points a fingertip can touch (see :mod:`synth.part.bodies`).

        Parameters
        ----------
        points : (n, 3) float
            Points on the surface.
        normals : (n, 3) float
            Inward normals (normalised here); for contacts that share a fingertip (a groove,
            an inside corner), the sum of their normals, so the step goes towards the
            fingertip.

        Returns
        -------
        exposed : (n,) bool
            All True on a part of one convex body.
        """
        pts = xyz_rows(points, "points")
        nrm = xyz_rows(normals, "normals", len(pts))
        nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        return self._exposed(pts, nrm)

    def _exposed(self, pts: np.ndarray, inward: np.ndarray) -> np.ndarray:
        if self._solids is None:
            return np.ones(len(pts), bool)
        step, margin, reach = self._exposure_step()
        return ~self._solids.hidden(pts - step * inward, margin, reach)

    def _exposure_step(self) -> tuple[float, float, float]:
        """The exposure test's step off the surface, margin and reach (lengths)."""
        step = tol.EXPOSURE_STEP_RTOL * self.length
        margin = max(tol.EXPOSURE_MARGIN_RTOL * self.length,
                     tol.PRECISION_FACTOR * self.precision)
        return step, margin, 2.0 * step + margin

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
        counts = {"face": len(self.mesh.faces), "edge": len(self.features.edges),
                  "vertex": len(self.mesh.vertices)}
        if kind not in counts:
            raise InputError(f"kind: expected 'face', 'edge' or 'vertex', got {kind!r}")
        index = _index(index, counts[kind], f"{kind} index")
        if kind == "face":
            return -np.asarray(self.mesh.face_normals[[index]], float)
        if kind == "edge":
            fs = self.features.edge_faces[index]
            return -np.asarray(self.mesh.face_normals[fs[fs >= 0]], float)
        off, _, cn = self._vertex_cone
        return np.array(cn[off[index] : off[index + 1]])

    def edge_kind(self, index: int) -> str:
        """Kind of a unique edge: one of ``"smooth", "convex", "concave", "boundary"``."""
        return EDGE_KINDS[int(self.features.edge_kind[_index(index, len(self.features.edges),
                                                             "edge index")])]

    def vertex_kind(self, index: int) -> str:
        """Kind of a vertex (see :data:`synth.part.features.VERTEX_KINDS`)."""
        return VERTEX_KINDS[int(self.features.vertex_kind[_index(index, len(self.mesh.vertices),
                                                                 "vertex index")])]

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

        return resolve_points(self, points, faces, snap=snap)

    def surface_distance(self, points: np.ndarray) -> np.ndarray:
        """Distance (n,) from each point (n, 3) to the part's surface (every body's faces;
        unsigned: a point inside a body is as far as it is from its surface).

        Examples
        --------
        >>> from synth import load_part
        >>> part = load_part("meshes/cube.stl")  # doctest: +SKIP
        >>> part.surface_distance([[0.0, 0.0, 2.0]])  # doctest: +SKIP
        array([1.5])
        """
        return self._index.distance(xyz_rows(points, "points"))

    def first_hits(self, origins: np.ndarray, directions: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
        """The first face (n,) each ray from ``origins`` (n, 3) along unit ``directions``
        (n, 3) meets ahead of its origin, and how far (n,); -1 and inf for a miss (see
        :meth:`synth.part.closest.BoxTree.first_hits`: single precision)."""
        o = xyz_rows(origins, "origins")
        return self._index.first_hits(o, xyz_rows(directions, "directions", len(o)))

    def raycast(self, origins: np.ndarray, directions: np.ndarray) -> Any:
        """Contacts where fingers moving from ``origins`` along ``directions`` first hit.

        See :func:`synth.contacts.contacts_from_rays`.
        """
        from synth.contacts.rays import contacts_from_rays

        return contacts_from_rays(self, origins, directions)
