"""The bodies of a part, inside tests, and the exposed surface a fingertip can touch.

A part may be made of several bodies: the convex pieces of a robot's or simulator's collision
mesh (V-HACD, CoACD), or a closed body beside open pieces. Each body is one connected
component of ``Part.mesh`` (faces joined through shared edges). A *closed* body is watertight
and has an inside; an *open* piece (a single-sided surface, a scan with holes) is only a
surface, with no inside.

Exposure
--------
Where two bodies touch, overlap or nearly touch, part of each one's surface lies against or
inside the other, and no finger can reach it. A surface point ``p`` with inward normal ``n``
is *exposed* when the point ``p - step * n`` (a small step outward, ``step`` =
``EXPOSURE_STEP_RTOL * length``) lies outside every closed body, its own included, by at
least ``EXPOSURE_MARGIN_RTOL * length``. The margin makes the answer robust: an independent
check with the same step finds the point outside too. Contacts that share a fingertip (the two
of a groove, the three of an inside corner) step along the mean of their normals, towards the
fingertip. Own-body tests matter in narrow slots and acute grooves, where a step off one wall
enters the opposite one. On a part of one convex body every point is exposed.

Inside tests
------------
Convex closed bodies of at most ``_PLANES_MAX`` faces are tested with their face planes:
``max_j (n_j . x - o_j)`` is a lower bound of the distance outside, so a value at least the
margin proves the point is outside by the margin. Other closed bodies use the exact closest
point (:mod:`synth.part.closest`) and the sign of ``x - q`` against the angle-weighted
pseudo-normal at ``q`` (face, edge or vertex normal; Baerentzen and Aanaes, 2005), which is
exact for a closed, consistently wound mesh. A convex body is not tested for the points
stepped off its own faces (it cannot hide them when the step exceeds the margin), and a face
smaller than the step is first tested as one ball round its samples (:meth:`Solids.clear`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from synth.part.closest import BoxTree
from synth.part.features import paired_half_edges
from synth.part.meshcache import cached, face_geometry, scaled_zero
from synth.part.order import group_ids
from synth.part.tolerances import bounds

__all__ = ["Body", "Solids", "body_labels", "compute_bodies", "face_sample_weights",
           "is_convex", "mesh_moments", "solid_moments"]

#: Barycentric weights of the points at which each face's exposure is sampled: the centroid,
#: three points near the corners, three near the edge midpoints and three in between.
_FACE_SAMPLES = np.array(
    [[1 / 3, 1 / 3, 1 / 3]]
    + [np.roll([0.9, 0.05, 0.05], k).tolist() for k in range(3)]
    + [np.roll([0.475, 0.475, 0.05], k).tolist() for k in range(3)]
    + [np.roll([2 / 3, 1 / 6, 1 / 6], k).tolist() for k in range(3)]
)
_BARY_TOL = 1e-9  # barycentric coordinates are scale free
#: How many faces' planes :func:`is_convex` tests every vertex against.
_PLANE_SAMPLES = 64
#: A convex body of more faces than this is tested by its box tree, not by its faces' planes
#: (a test costs a point times the planes: 160 GB at once for a 327,680-face sphere).
_PLANES_MAX = 1024
#: Products of points by planes computed at a time.
_PRODUCTS = 1 << 20
#: The inside test of a closed body that is not convex or has many faces: the box tree of its
#: faces, their numbers in the part's mesh (None: all of them, in order), and whether the body
#: is convex (then a point at any depth inside it is hidden) (:meth:`Solids._mesh_hidden`).
_MeshTest = tuple[BoxTree, np.ndarray | None, bool]


def face_sample_weights() -> np.ndarray:
    """Barycentric weights (10, 3) of the exposure samples of each face."""
    return _FACE_SAMPLES.copy()


@dataclass(frozen=True, eq=False)
class Body:
    """One connected piece of a part.

    Attributes
    ----------
    index : int
        Position in ``Part.bodies``.
    name : str
        Name from the file (node or geometry name, with ``#k`` for the k-th piece of one
        mesh), or ``body{index}``.
    faces : (m,) int
        Faces of ``Part.mesh`` that belong to the body.
    closed : bool
        Watertight and consistently wound: it has an inside.
    convex : bool
        Closed and convex.
    volume : float
        Enclosed volume (0 for an open piece).
    area : float
    exposed_area : float
        Estimate of the area a fingertip can touch (sampled, see the module notes).
    center : (3,) float
        Centre of mass (uniform density) of a closed body, area centroid of an open one.
    bounds : (2, 3) float
        Axis-aligned bounding box.
    """

    index: int
    name: str
    faces: np.ndarray
    closed: bool
    convex: bool
    volume: float
    area: float
    exposed_area: float
    center: np.ndarray
    bounds: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no face list)."""
        return {
            "name": self.name,
            "faces": int(len(self.faces)),
            "closed": self.closed,
            "convex": self.convex,
            "volume": self.volume,
            "area": self.area,
            "exposed_area": self.exposed_area,
        }


def solid_moments(triangles: np.ndarray) -> tuple[float, np.ndarray]:
    """Signed volume and centre of mass (uniform density) of the solid a closed, consistently
    wound surface bounds: the divergence-theorem integrals trimesh's ``mass_properties`` uses
    (Eberly, "Polyhedral Mass Properties"), without its second moments, which synth never
    reads and which cost most of that function's time on a large mesh.

    Parameters
    ----------
    triangles : (m, 3, 3) float

    Returns
    -------
    volume : float
        Negative for inward normals.
    center : (3,) float
        Meaningless when ``volume`` is zero.
    """
    t = np.asarray(triangles, np.float64)
    return _moments(t[:, 0], t[:, 1], t[:, 2])


def _moments(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[float, np.ndarray]:
    """:func:`solid_moments` of the triangles of corners (m, 3) ``a``, ``b`` and ``c``."""
    cross = np.cross(b - a, c - a)
    f1 = a + b + c
    f2 = a * a + b * b + a * b + c * f1
    volume = float(cross[:, 0] @ f1[:, 0]) / 6.0
    moments = np.einsum("ij,ij->j", cross, f2) / 24.0
    return volume, moments / volume if volume != 0 else np.zeros(3)


def mesh_moments(mesh: trimesh.Trimesh) -> tuple[float, np.ndarray]:
    """:func:`solid_moments` of a mesh's triangles, kept in its cache: the loader's orienting,
    its test of a closed body and the part's bodies ask of the same mesh (0.16 s each at
    1.3M faces). The corners are gathered a column of faces at a time, not as trimesh's
    (f, 3, 3) ``triangles``, which it would keep (0.09 against 0.15 s at 1.3M faces)."""
    def compute() -> tuple[float, np.ndarray]:
        v = np.asarray(mesh.vertices, np.float64)
        f = np.asarray(mesh.faces, np.int64)
        volume, center = _moments(*(np.take(v, f[:, k], axis=0) for k in range(3)))
        center.flags.writeable = False
        return volume, center

    return cached(mesh, "synth_moments", compute)


def is_convex(mesh: trimesh.Trimesh, tolerance: float) -> bool:
    """Whether a closed, connected body is convex.

    Two tests, and the body is convex when it passes both (the second is run first, as it
    refutes most non-convex bodies at a fraction of the cost):

    1. *Local* (trimesh's ``is_convex``, computed from its cached adjacency without its
       slower unshared-vertex table): across every edge between faces of nonzero area, the
       far corner of one face lies below the other's plane by trimesh's threshold
       (``trimesh.tol.planar`` times the body's diagonal).
    2. *Global*: no vertex lies above the plane of one of ``_PLANE_SAMPLES`` faces spread
       over the body by more than the plane's error allows. A fine tessellation of a curved,
       non-convex surface passes the local test, since the angle across each edge shrinks
       with its length (a 1.3M-face blob did, where the same blob at 82k faces did not).

    The two do not prove convexity: a body passes when no sampled plane sees its dent and
    no edge bends inward by trimesh's threshold (a review found a bowl 1.2e-3 of the size
    deep in a finely cut flat side that passes, as it passes trimesh's test). The plane
    test's allowance keeps it from the other error, a convex body refuted by round-off,
    which would only cost time (the exact inside test of any closed body).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Watertight, consistently wound with outward normals, one connected piece.
    tolerance : float
        How far the loader's repairs may have moved a corner
        (:func:`synth.part.tolerances.surface_tolerance`). A face whose smallest height is
        ``h`` has its plane tilted by up to ``4 * tolerance / h`` by such moves, so a vertex
        refutes convexity only when it lies more than ``tolerance * (2 + 4 * d / h)`` above
        the plane (``d`` the body's diagonal, the farthest a vertex can be).

    Returns
    -------
    bool
        Kept in the mesh's cache (the loader and the part ask of the same mesh).
    """
    return cached(mesh, ("synth_is_convex", tolerance), lambda: _is_convex(mesh, tolerance))


def _is_convex(mesh: trimesh.Trimesh, tolerance: float) -> bool:
    faces = np.asarray(mesh.faces, np.int64)
    vertices = np.asarray(mesh.vertices, float)
    normals, area = face_geometry(mesh)
    lo, hi = bounds(vertices)
    diagonal = float(np.linalg.norm(hi - lo))
    # the global test first: it refutes most non-convex bodies at a fraction of the cost
    rows = np.unique(np.linspace(0, len(faces) - 1, _PLANE_SAMPLES).astype(np.int64))
    tri = vertices[faces[rows]]
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    height = 2.0 * area[rows] / longest
    with np.errstate(divide="ignore"):  # a face of no area refutes nothing
        allowed = tolerance * (2.0 + 4.0 * diagonal / height)
    for s in range(0, len(rows), 8):  # (v, 8) at a time
        n = normals[rows[s : s + 8]]
        above = vertices @ n.T - np.einsum("ij,ij->i", tri[s : s + 8, 0], n)
        if (above.max(axis=0) > allowed[s : s + 8]).any():
            return False
    adj = np.asarray(mesh.face_adjacency, np.int64).reshape(-1, 2)
    edges = np.asarray(mesh.face_adjacency_edges, np.int64).reshape(-1, 2)
    ok = (area[adj] > scaled_zero(vertices, 2)).all(axis=1)  # (trimesh's zero at size 1)
    if not ok.any():
        return False
    far = faces[adj[:, 1]].sum(axis=1) - edges.sum(axis=1)  # the other face's third corner
    rise = np.einsum("ij,ij->i", np.take(vertices, far, axis=0)
                     - np.take(vertices, edges[:, 0], axis=0), np.take(normals, adj[:, 0], axis=0))
    return bool(rise[ok].max() < trimesh.tol.planar * diagonal)


def body_labels(mesh: trimesh.Trimesh) -> np.ndarray:
    """Connected component of each face, numbered in order of first face.

    Parameters
    ----------
    mesh : trimesh.Trimesh

    Returns
    -------
    labels : (f,) int
        Read-only; kept in the mesh's cache (the loader splits a mesh the part then labels).
    """
    return cached(mesh, "synth_body_labels", lambda: _body_labels(mesh))


def _body_labels(mesh: trimesh.Trimesh) -> np.ndarray:
    n = len(mesh.faces)
    # faces joined by an edge that has exactly two (trimesh's face adjacency), from the edge
    # table the features are built from (cheaper than trimesh's, and built once)
    first, second = paired_half_edges(mesh)
    a, b = first // 3, second // 3
    graph = coo_matrix((np.ones(len(a), np.int8), (a, b)), shape=(n, n))
    lab = connected_components(graph, directed=False)[1]
    first = group_ids(lab, n)[1]
    remap = np.empty(len(first), np.int64)
    remap[np.argsort(first)] = np.arange(len(first))
    labels = remap[lab]
    labels.flags.writeable = False
    return labels


def compute_bodies(
    mesh: trimesh.Trimesh, labels: np.ndarray, names: list[str] | tuple[str, ...] | None,
    tolerance: float,
) -> list[Body]:
    """The bodies of a mesh with component ``labels`` (exposed area set to the area).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Consistently wound, outward normals.
    labels : (f,) int
        From :func:`body_labels`.
    names : sequence of str, optional
        One per body.
    tolerance : float
        How far repairs may have moved a corner (for :func:`is_convex`).

    Returns
    -------
    list of Body
    """
    n_b = int(labels.max()) + 1
    out = []
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(n_b + 1))
    for b in range(n_b):
        faces = order[bounds[b] : bounds[b + 1]].copy()
        # a part of one body is its own body: no copy, and the mesh's caches serve the part
        sub = mesh if n_b == 1 else cast(trimesh.Trimesh, mesh.submesh([faces], append=True,
                                                                          repair=False))
        volume, center = 0.0, None
        if sub.is_watertight and sub.is_winding_consistent:
            volume, center = mesh_moments(sub)
        closed = volume > 0
        convex = closed and is_convex(sub, tolerance)
        faces.flags.writeable = False
        box = np.asarray(sub.bounds, float)
        center = np.asarray(center if closed else sub.centroid, float)
        for a in (box, center):
            a.flags.writeable = False
        name = names[b] if names is not None and b < len(names) else f"body{b}"
        out.append(Body(b, name, faces, closed, convex, volume if closed else 0.0,
                        float(sub.area), float(sub.area), center, box))
    return out


class Solids:
    """Inside tests against the closed bodies of a part (built by :class:`synth.part.Part`).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The part's mesh, outward normals.
    bodies : sequence of Body
    edge_faces, face_edges : (e, 2) and (f, 3) int
        The two faces of each unique edge and each face's three edges
        (:class:`synth.part.features.Features`).
    index : BoxTree
        The box tree of the whole mesh (the part's own), which serves a body that is the
        whole mesh; other bodies tested by a tree (not convex, or of more than
        ``_PLANES_MAX`` faces) get a tree of their faces.
    """

    def __init__(self, mesh: trimesh.Trimesh, bodies: list[Body] | tuple[Body, ...],
                 edge_faces: np.ndarray, face_edges: np.ndarray, index: BoxTree) -> None:
        fn = face_geometry(mesh)[0]
        vertices = np.asarray(mesh.vertices, float)
        faces = np.asarray(mesh.faces, np.int64)
        # per closed body: its index, its box and its test (a convex body's planes)
        self._tests: list[tuple[int, np.ndarray, np.ndarray | _MeshTest]] = []
        by_tree = [b.closed and (not b.convex or len(b.faces) > _PLANES_MAX) for b in bodies]
        if any(by_tree):
            # angle-weighted corner normals and summed edge normals, for every face's test
            ang = np.asarray(mesh.face_angles, float).ravel()
            flat = faces.ravel()
            self._corner = np.column_stack([
                np.bincount(flat, np.repeat(fn[:, k], 3) * ang, len(vertices))
                for k in range(3)])
            # an edge's is the sum of its two faces' normals, taken when asked
            self._normals, self._faces = fn, faces
            self._face_edges = np.asarray(face_edges, np.int64)
            self._edge_faces = np.asarray(edge_faces, np.int64)
        for b, tree in zip(bodies, by_tree, strict=True):
            if not b.closed:
                continue
            f = b.faces
            if not tree:
                planes = np.hstack([fn[f], -np.einsum("ij,ij->i", fn[f],
                                                      vertices[faces[f, 0]])[:, None]])
                self._tests.append((b.index, b.bounds, planes))
            elif len(f) == len(faces):  # the whole mesh: the part's tree
                self._tests.append((b.index, b.bounds, (index, None, b.convex)))
            else:  # a tree of its own corners (a view of all the part's would pickle whole)
                used, local = np.unique(faces[f], return_inverse=True)
                boxes = BoxTree(vertices[used], local.reshape(-1, 3))
                self._tests.append((b.index, b.bounds, (boxes, f, b.convex)))

    @property
    def bodies(self) -> list[int]:
        """Indices of the closed bodies tested."""
        return [t[0] for t in self._tests]

    def hidden(self, points: np.ndarray, margin: float, reach: float,
               owner: np.ndarray | None = None) -> np.ndarray:
        """Which points lie inside a closed body, or within ``margin`` of one.

        Parameters
        ----------
        points : (n, 3) float
        margin : float
            Distance, in the part's units.
        reach : float
            A point farther than this from a non-convex body's surface counts as outside it
            (not from a convex one's: one of many faces is also tested by its tree).
            Exact for the points synth asks about (a small step off the surface) because
            closed bodies of a part do not overlap (those that did were united on loading,
            :mod:`synth.part.compound`).
        owner : (n,) int, optional
            The body each point was stepped off: a convex body does not hide the points
            stepped off its own surface (a non-convex one may, in its crevices), so it is
            not tested for them.

        Returns
        -------
        hidden : (n,) bool
        """
        pts = np.asarray(points, float)
        out = np.zeros(len(pts), bool)
        for index, box, test in self._tests:
            near = ~out & np.all((pts >= box[0] - margin) & (pts <= box[1] + margin), axis=1)
            if owner is not None and _convex(test):
                near &= owner != index
            rows = np.flatnonzero(near)
            if not len(rows):
                continue
            if isinstance(test, np.ndarray):
                out[rows] = _convex_hidden(test, pts[rows], margin)
            else:
                out[rows] = self._mesh_hidden(*test, pts[rows], margin, reach)
        return out

    def clear(self, points: np.ndarray, radius: np.ndarray, margin: float, reach: float,
              owner: np.ndarray | None = None) -> np.ndarray:
        """Which balls hold no point that :meth:`hidden` would call hidden.

        A ball (centre, radius) is clear of a closed body when it lies outside the body's
        box grown by ``margin``, or its centre is farther than ``reach`` plus the radius from
        the body's surface, or outside the body by more than ``margin`` plus the radius: the
        distance to a surface changes no faster than the point moves, and a ball with no
        surface in it is on one side of it. (The round-off of the distances is covered by
        a relative 1e-6 of the thresholds they are compared with.)

        Parameters
        ----------
        points : (n, 3) float
            The balls' centres.
        radius : (n,) float
        margin, reach, owner
            As for :meth:`hidden`.

        Returns
        -------
        clear : (n,) bool
            True where no point of the ball is hidden; False where some may be.
        """
        pts = np.asarray(points, float)
        r = np.asarray(radius, float)
        ok = np.ones(len(pts), bool)
        for index, box, test in self._tests:
            grow = (margin + r)[:, None]
            near = ok & np.all((pts >= box[0] - grow) & (pts <= box[1] + grow), axis=1)
            if owner is not None and _convex(test):
                near &= owner != index
            rows = np.flatnonzero(near)
            if not len(rows):
                continue
            rr = r[rows]
            if isinstance(test, np.ndarray):  # the planes' bound is no faster than a point
                ok[rows] = _plane_bound(test, pts[rows]) - rr > margin * (1.0 + 1e-6)
            else:
                boxes, faces, convex = test
                d, outside = self._mesh_side(boxes, faces, pts[rows])
                far = np.inf if convex else reach
                ok[rows] = ((d > (far + rr) * (1.0 + 1e-6))
                            | (outside & (d - rr > margin * (1.0 + 1e-6))))
        return ok

    def _mesh_hidden(self, boxes: BoxTree, faces: np.ndarray | None, convex: bool,
                     pts: np.ndarray, margin: float, reach: float) -> np.ndarray:
        """Inside or within ``margin`` of a closed mesh, by its closest point and its
        angle-weighted pseudo-normal there (face, edge or corner). A point with no surface
        within ``reach`` is outside, unless the body is convex."""
        if convex:
            reach = np.inf
        d, outside = self._mesh_side(boxes, faces, pts, reach)
        return (d <= reach) & ((d < margin) | ~outside)

    def _mesh_side(self, boxes: BoxTree, faces: np.ndarray | None, pts: np.ndarray,
                   reach: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """Distances (n,) of points (n, 3) from a closed mesh and which are outside it (by
        the pseudo-normal at the closest point), the latter for those within ``reach``
        (False beyond)."""
        q, f, d = boxes.closest(pts)
        outside = np.zeros(len(pts), bool)
        rows = np.flatnonzero(d <= reach)
        if not len(rows):
            return d, outside
        q, f, p = q[rows], f[rows], pts[rows]
        bary = trimesh.triangles.points_to_barycentric(boxes.vertices[boxes.faces[f]], q,
                                                       method="cramer")
        face = f if faces is None else faces[f]  # in the part's mesh
        small = bary < _BARY_TOL
        pn = self._normals[face].copy()
        on_edge = small.sum(axis=1) == 1
        at_vertex = small.sum(axis=1) >= 2
        # the edge opposite corner k is edge slot (k + 1) % 3: (0,1), (1,2), (2,0)
        k = np.argmax(small, axis=1)
        two = self._edge_faces[self._face_edges[face[on_edge], (k[on_edge] + 1) % 3]]
        pn[on_edge] = self._normals[two[:, 0]] + self._normals[two[:, 1]]
        v = np.argmax(bary, axis=1)
        pn[at_vertex] = self._corner[self._faces[face[at_vertex], v[at_vertex]]]
        outside[rows] = np.einsum("ij,ij->i", p - q, pn) > 0
        return d, outside


def _convex(test: np.ndarray | _MeshTest) -> bool:
    """Whether a body's test (its planes, or its tree) is of a convex body."""
    return isinstance(test, np.ndarray) or test[2]


def _convex_hidden(planes: np.ndarray, pts: np.ndarray, margin: float) -> np.ndarray:
    """Inside or within ``margin`` of the convex body ``planes`` (h, 4): ``n . x + c <= 0``."""
    return _plane_bound(planes, pts) < margin


def _plane_bound(planes: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """``max_j (n_j . x + c_j)`` (n,) of points (n, 3) over a convex body's planes (h, 4), at
    most the distance outside it, ``_PRODUCTS`` products at a time."""
    rows = max(1, _PRODUCTS // len(planes))
    return np.concatenate([(pts[s:s + rows] @ planes[:, :3].T + planes[:, 3]).max(axis=1)
                           for s in range(0, len(pts), rows)] or [np.zeros(0)])
