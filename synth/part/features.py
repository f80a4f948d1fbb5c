"""Sharp and smooth edges and vertex classes of a mesh, computed once.

An edge is *sharp* when the normals of its two faces differ by more than ``sharp_angle``;
a sharp edge is *convex* (material angle below 180 deg, like a cube edge) or *concave*
(a groove, like the inside edge of an L bracket). An edge with one face is a *boundary*
edge (open mesh). A vertex is

``smooth``
    no sharp edge meets it;
``edge``
    it lies inside a chain of sharp edges (one sharp edge, or two of the same kind that
    continue each other within ``sharp_angle``): a point there behaves as an edge point;
``convex_corner`` / ``concave_corner``
    two or more sharp edges of one kind meet there, turning (a cube corner; an inside corner);
``saddle``
    convex and concave sharp edges meet there (the end of a groove on an outer face);
``boundary``
    an open boundary edge meets it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from synth.errors import InputError
from synth.part.meshcache import cached, face_geometry
from synth.part.order import stable_order

__all__ = ["EDGE_KINDS", "VERTEX_KINDS", "Features", "compute_features", "edge_table",
           "mesh_edge_table", "paired_half_edges", "edge_closure"]

#: Names of the codes in ``Features.edge_kind``.
EDGE_KINDS: tuple[str, ...] = ("smooth", "convex", "concave", "boundary")
#: Names of the codes in ``Features.vertex_kind``.
VERTEX_KINDS: tuple[str, ...] = (
    "smooth",
    "edge",
    "convex_corner",
    "concave_corner",
    "saddle",
    "boundary",
)


@dataclass(frozen=True, eq=False)
class Features:
    """Edge and vertex features of a mesh.

    Attributes
    ----------
    sharp_angle : float
        Dihedral threshold in radians used to classify the edges.
    edges : (e, 2) int
        Unique edges as sorted vertex index pairs (``mesh.edges_unique``).
    edge_faces : (e, 2) int
        The two faces of each edge; -1 in the second column for a boundary edge.
    edge_angle : (e,) float
        Angle between the two face normals in radians (0 for flat); NaN on the boundary.
    edge_kind : (e,) int
        Index into :data:`EDGE_KINDS`.
    edge_length : (e,) float
    face_edges : (f, 3) int
        Unique edge of face corner pairs (0, 1), (1, 2), (2, 0).
    vertex_kind : (v,) int
        Index into :data:`VERTEX_KINDS`.
    vertex_edge : (v,) int
        One sharp (or boundary) edge at each vertex, -1 if none.
    """

    sharp_angle: float
    edges: np.ndarray
    edge_faces: np.ndarray
    edge_angle: np.ndarray
    edge_kind: np.ndarray
    edge_length: np.ndarray
    face_edges: np.ndarray
    vertex_kind: np.ndarray
    vertex_edge: np.ndarray

    def edges_of_kind(self, kind: str) -> np.ndarray:
        """Indices of the edges of one kind (``"smooth"``, ``"convex"``, ...), (k,) int."""
        if kind not in EDGE_KINDS:
            raise InputError(f"kind: expected one of {', '.join(EDGE_KINDS)}, got {kind!r}")
        return np.flatnonzero(self.edge_kind == EDGE_KINDS.index(kind))

    def vertices_of_kind(self, kind: str) -> np.ndarray:
        """Indices of the vertices of one kind (``"convex_corner"``, ...), (k,) int."""
        if kind not in VERTEX_KINDS:
            raise InputError(f"kind: expected one of {', '.join(VERTEX_KINDS)}, got {kind!r}")
        return np.flatnonzero(self.vertex_kind == VERTEX_KINDS.index(kind))

    @property
    def sharp_edges(self) -> np.ndarray:
        """Indices of convex and concave edges, (k,) int."""
        return np.flatnonzero((self.edge_kind == 1) | (self.edge_kind == 2))


def compute_features(mesh: trimesh.Trimesh, sharp_angle: float,
                     face_source: np.ndarray | None = None, seam_angle: float = 0.0
                     ) -> Features:
    """Classify the edges and vertices of ``mesh``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Welded, consistently wound mesh with outward normals.
    sharp_angle : float
        Dihedral threshold in radians.
    face_source : (f,) int, optional
        Which input body each face came from (bodies united on loading). An edge between
        faces of two sources is a seam, a crease of the union, not a tessellated curve: it is
        sharp whenever its faces differ by more than ``seam_angle``.
    seam_angle : float
        Radians; below it a seam is flat.

    Returns
    -------
    Features
    """
    n_v = len(mesh.vertices)
    edges, face_edges, order, starts = mesh_edge_table(mesh)
    mesh._cache.delete("synth_edge_table")  # its sort order is not kept past here
    n_e = len(edges)
    edge_faces = np.full((n_e, 2), -1, np.int64)
    # first and second face of each edge (for a manifold edge: its two faces)
    counts = np.diff(np.append(starts, len(order)))
    edge_faces[:, 0] = order[starts] // 3
    two = counts >= 2
    second = order[starts[two] + 1]  # half-edge 3 face + corner of each edge's second face
    edge_faces[two, 1] = second // 3
    del order, starts, counts

    normals = face_geometry(mesh)[0]
    verts = np.asarray(mesh.vertices, float)
    angle = np.full(n_e, np.nan)
    fa, fb = edge_faces[two, 0], edge_faces[two, 1]
    # convexity: the far vertex of face b lies below the plane of face a. Half-edge 3 f + c
    # runs from corner c to corner c + 1, so the far vertex is corner c + 2 (the loader drops
    # faces with a repeated vertex; on such a face this is one of the edge's own vertices, a
    # height of 0, read as concave)
    far = np.take(np.asarray(mesh.faces, np.int64).ravel(),
                  second - second % 3 + (second % 3 + 2) % 3)
    del second
    near = edges[:, 0][two]
    v_cols = [np.ascontiguousarray(verts[:, k]) for k in range(3)]
    # the cosines and the heights a coordinate at a time, from (f,) and (v,) columns (a third
    # of the time of gathering (n, 3) rows), summed (x + z) + y as einsum sums rows of three
    # (numpy 2.4; another order may round otherwise in the last bit)
    cos, proj = [], []
    for k in range(3):
        n_k = np.ascontiguousarray(normals[:, k])
        a_k = np.take(n_k, fa)
        cos.append(a_k * np.take(n_k, fb))
        proj.append(a_k * (np.take(v_cols[k], far) - np.take(v_cols[k], near)))
    del far, near, a_k
    cos[0] += cos[2]
    cos[0] += cos[1]
    proj[0] += proj[2]
    proj[0] += proj[1]
    cos, proj = cos[0], proj[0]
    angle[two] = np.arccos(np.clip(cos, -1.0, 1.0, out=cos))
    kind = np.full(n_e, 3, np.int8)
    sharp = angle[two] > sharp_angle
    if face_source is not None:
        sharp |= (face_source[fa] != face_source[fb]) & (angle[two] > seam_angle)
    kind[two] = np.where(sharp, np.where(proj < 0, 1, 2), 0)

    d = [np.take(v, edges[:, 1]) - np.take(v, edges[:, 0]) for v in v_cols]
    length = np.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])
    del d, v_cols
    vertex_kind, vertex_edge = _classify_vertices(verts, edges, kind, length, n_v, sharp_angle)
    arrays = (edges, edge_faces, angle, kind, length, face_edges, vertex_kind, vertex_edge)
    for a in arrays:
        a.flags.writeable = False
    return Features(float(sharp_angle), *arrays)


def mesh_edge_table(mesh: trimesh.Trimesh
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`edge_table` of a mesh, kept in its cache until :func:`compute_features` takes
    it: the loader finds a mesh's pieces with it (:func:`synth.part.bodies.body_labels`), and
    the part's features are built from the same table."""
    return cached(mesh, "synth_edge_table",
                  lambda: edge_table(np.asarray(mesh.faces, np.int64), len(mesh.vertices)))


def paired_half_edges(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """The two half-edges (``3 face + corner``) (m,) and (m,) of every edge of exactly two
    faces, from :func:`mesh_edge_table`, the first by position: the faces they join are
    trimesh's face adjacency."""
    _, _, order, starts = mesh_edge_table(mesh)
    pair = starts[np.diff(starts, append=len(order)) == 2]
    return np.take(order, pair), np.take(order, pair + 1)


def edge_closure(mesh: trimesh.Trimesh) -> tuple[bool, bool]:
    """trimesh's ``is_watertight`` and ``is_winding_consistent`` of ``mesh``, from
    :func:`mesh_edge_table`, and kept in the mesh's cache where trimesh looks for them.

    The same answers as trimesh's: watertight when every edge has exactly two faces;
    consistently wound when the two faces of every such edge run it in opposite directions.
    trimesh finds them from a second grouping of the edges (0.36 s at 1.3M faces, against
    0.03 s here once the loader has the edge table, which it needs for the pieces).
    """
    if mesh.is_empty:  # trimesh: a mesh without faces or vertices is neither
        return False, False
    faces = np.asarray(mesh.faces, np.int64).ravel()
    first, second = paired_half_edges(mesh)
    # half-edge h = 3 face + corner runs from corner h of its face to the next corner
    head = np.take(faces, first - first % 3 + (first % 3 + 1) % 3)
    watertight = len(first) == len(mesh_edge_table(mesh)[3])
    consistent = bool((head == np.take(faces, second)).all())
    mesh._cache["is_watertight"] = watertight
    mesh._cache["is_winding_consistent"] = consistent
    return watertight, consistent


def edge_table(faces: np.ndarray, n_v: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The unique edges of triangles, in one sort, as trimesh numbers them.

    trimesh's chain (``edges``, ``edges_sorted``, ``edges_unique`` by row hashes,
    ``edges_unique_inverse``, ``faces_unique_edges``, ``edges_face``) costs about twice the
    time and three times the memory of this at a million faces; the numbering is the same
    (unique edges ordered by their larger vertex, then their smaller), so a part's features do
    not depend on which built them.

    Parameters
    ----------
    faces : (f, 3) int
    n_v : int
        Number of vertices (below 3e9, so that an edge's key fits 63 bits).

    Returns
    -------
    edges : (e, 2) int
        Unique edges, smaller vertex first (``mesh.edges_unique``).
    face_edges : (f, 3) int
        Each face's edges (``mesh.faces_unique_edges``): the half-edges (a, b), (b, c), (c, a)
        of face (a, b, c).
    order : (3 f,) int
        The half-edges (``3 face + corner``) sorted by edge, stable.
    starts : (e,) int
        Where each edge's half-edges begin in ``order``.
    """
    tail = faces.ravel()  # half-edge 3 face + corner runs from its corner to the next
    head = faces[:, [1, 2, 0]].ravel()
    low, high = np.minimum(tail, head), np.maximum(tail, head)
    del tail, head
    order, key = stable_order(high * np.int64(n_v) + low, n_v * n_v)
    new = np.empty(len(key), bool)
    new[:1] = True
    np.not_equal(key[1:], key[:-1], out=new[1:])
    del key
    starts = np.flatnonzero(new)
    first = np.take(order, starts)
    edges = np.column_stack([np.take(low, first), np.take(high, first)])
    del low, high, first
    inverse = np.empty(len(order), np.int64)
    inverse[order] = np.cumsum(new) - 1
    return edges, inverse.reshape(-1, 3), order, starts


def _classify_vertices(
    verts: np.ndarray,
    edges: np.ndarray,
    kind: np.ndarray,
    length: np.ndarray,
    n_v: int,
    sharp_angle: float,
) -> tuple[np.ndarray, np.ndarray]:
    ends = edges.ravel()
    k2 = np.repeat(kind, 2)

    def _count(mask: np.ndarray) -> np.ndarray:
        return np.bincount(ends[mask], minlength=n_v)

    n_cvx, n_ccv, n_bnd = _count(k2 == 1), _count(k2 == 2), _count(k2 == 3)
    # unit directions of sharp edges pointing away from each end vertex
    sharp = np.flatnonzero((kind == 1) | (kind == 2))
    ab = edges[sharp]
    d = (verts[ab[:, 1]] - verts[ab[:, 0]]) / np.maximum(length[sharp], 1e-300)[:, None]
    dsum = np.zeros((n_v, 3))
    np.add.at(dsum, ab.ravel(), np.stack([d, -d], axis=1).reshape(-1, 3))
    straight = np.linalg.norm(dsum, axis=1) < 2.0 * np.sin(sharp_angle / 2.0)
    n_sharp = n_cvx + n_ccv
    vk = np.zeros(n_v, np.int8)
    vk[(n_sharp >= 2) & (n_ccv == 0)] = 2
    vk[(n_sharp >= 2) & (n_cvx == 0)] = 3
    vk[(n_cvx > 0) & (n_ccv > 0)] = 4
    is_edge = (n_sharp == 1) | ((n_sharp == 2) & straight & ((n_cvx == 2) | (n_ccv == 2)))
    vk[is_edge] = 1
    vk[n_bnd > 0] = 5
    vertex_edge = np.full(n_v, -1, np.int64)
    special = np.flatnonzero(k2 != 0)
    vertex_edge[ends[special]] = special // 2
    return vk, vertex_edge
