"""The part as MuJoCo collides it: exact convex pieces, and the facets near the hand.

MuJoCo collides a mesh geom as its convex hull, so a non-convex body collides where it is
not. The shape comes from the :class:`~synth.part.Part` the grasps were planned on, loaded,
welded and repaired by the same loader with the same options, never from the raw file (an OBJ
whose vertices are split along normal or texture seams is a set of open sheets until welded).

* A body that is closed and convex (a piece of a V-HACD or CoACD collision mesh) is one
  convex piece, exactly.
* A body the loader united from overlapping closed convex bodies of the file is exactly their
  union: those bodies are its pieces (and they cover any sliver the union left beside it).
* Any other body (a non-convex solid, an open surface) is given, near the hand only, as its
  facets: each triangle extruded ``SLAB_RTOL`` of the part's size into the part, a thin convex
  prism (less where the wall behind it is thinner: at most ``WALL_SHARE`` of the wall's
  thickness, found by casting rays into the part, so no slab stands out of the far side). A
  fingertip or pad then meets the mesh's own facets, with their own normals, at the planned
  contacts. (A convex decomposition is the other way. Measured with CoACD on a robot finger, an open
  mesh: its pieces buried the planned contacts by up to 0.63 tip radii at CoACD's default threshold
  and 0.33 at 0.02, and 6 of its 10 best grasps were pushed out by their own squeeze; decomposing
  such a body took minutes.) Only facets the hand can reach before the part has moved past the
  protocol's threshold are needed; :meth:`PartShape.near` picks those within a distance of the
  fingers. The simulation stops as diverged before a finger sinks half a slab deep.

The part's mass properties are those of its closed bodies (of the hull of its points when none
is closed).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import trimesh
from numpy.typing import NDArray

from synth.errors import InputError, SimulationError

__all__ = ["PartShape", "part_shape", "within", "SLAB_RTOL", "WALL_SHARE", "SHEET_RTOL",
           "FLAT_RTOL", "SLIVER_RTOL"]

#: Depth of each facet's slab, as a fraction of the part's size.
SLAB_RTOL: float = 0.005
#: A slab is at most this share of the wall behind its facet.
WALL_SHARE: float = 0.45
#: A wall thinner than this share of ``SLAB_RTOL`` is no wall: two faces that coincide (a
#: sheet with no thickness, a sliver a union left, faces of two touching pieces), behind
#: which the part goes on or nothing can be done; such a facet keeps the full slab.
SHEET_RTOL: float = 0.05
#: A piece is flat when its hull's volume is below this fraction of its bounding box's.
FLAT_RTOL: float = 1e-6
#: A facet whose doubled area is below this share of its longest edge squared (a height
#: under a thousandth of that edge) is a sliver: its patch is tested for flatness.
SLIVER_RTOL: float = 1e-3
#: Most facets one convex patch of slabs is grown to.
_PATCH_FACETS = 64
#: Least cosine between the normals of two facets of one patch (60 degrees apart at most).
_PATCH_SPREAD = 0.5
#: How deep a patch's slab may reach behind a facet's plane, in that facet's depths (a slab's
#: depth is at most ``WALL_SHARE`` of the wall behind its facet, so twice it stays inside a
#: wall of even thickness).
_PATCH_REACH = 2.0


@dataclass(frozen=True)
class PartShape:
    """The collision shape of one part, in the part's coordinates and units.

    Attributes
    ----------
    pieces : tuple of (m_i, 3) float
        Exact convex pieces (vertices; MuJoCo uses their hull): the convex bodies, and the
        file's convex bodies a united body is made of.
    triangles : (t, 3, 3) float
        Facets of the other bodies, given as slabs near the hand (:meth:`near`).
    corners : (t, 3) int
        The mesh's vertex ids of each facet's corners: facets that share an edge and bend
        away from each other (a convex patch of the surface) become one slab.
    body : (t,) int
        The body of each facet (a wall is measured within its own body).
    slab : float
        The slabs' depth into the part.
    bodies : int
        Bodies of the part.
    faceted : int
        Bodies given as facets.
    inertia : (3, 3) float
        Inertia tensor of the part's closed bodies about ``center``, per unit density.
    volume : float
        Volume that ``inertia`` belongs to.
    center : (3,) float
        Centre of mass of that volume.
    part : Part
        The part (its ray queries measure the walls behind the facets).
    """

    pieces: tuple[NDArray[np.float64], ...] = field(repr=False)
    triangles: NDArray[np.float64] = field(repr=False)
    corners: NDArray[np.int64] = field(repr=False)
    body: NDArray[np.int64] = field(repr=False)
    slab: float
    bodies: int
    faceted: int
    inertia: NDArray[np.float64] = field(repr=False)
    volume: float
    center: NDArray[np.float64] = field(repr=False)
    part: Any = field(repr=False, default=None)

    def near(self, inside: Any) -> tuple[list[NDArray[np.float64]], NDArray[np.float64]]:
        """The pieces and the slabs of the facets ``inside`` selects, and each one's depth.

        Parameters
        ----------
        inside : callable
            Given the triangles (t, 3, 3), whether each may be reached (t,) bool.

        Returns
        -------
        list of (m, 3) float
            Vertices of every convex piece, exact ones first, then one slab per convex patch
            of facets (a patch that is flat for its slivers: a slab per facet, none for a
            sliver).
        (p,) float
            How deep each piece is below the surface a finger touches: inf for the exact
            pieces, the slab's depth (its thinnest facet's) for the others.
        """
        out = list(self.pieces)
        depths = [np.inf] * len(out)
        if len(self.triangles):
            keep = np.asarray(inside(self.triangles), bool)
            tri, corners, body = self.triangles[keep], self.corners[keep], self.body[keep]
            n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            norm = np.linalg.norm(n, axis=1)
            ok = norm > 0
            tri, corners, body, n = tri[ok], corners[ok], body[ok], n[ok] / norm[ok, None]
            depth = self._depths(tri, n, body)
            inner = tri - depth[:, None, None] * n[:, None, :]  # the slabs' inner corners
            tol = 1e-9 * float(np.abs(tri).max(initial=1.0)) + 1e-6 * self.slab
            # slivers (a float32 CAD file has facets 1e-8 of the part thin): a patch of them
            # alone is flat, and MuJoCo refuses a flat mesh with the whole scene
            longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
            thin = norm[ok] < SLIVER_RTOL * longest**2
            for group in _convex_patches(tri, corners, n, inner, depth, tol):
                v = np.concatenate([tri[group].reshape(-1, 3), inner[group].reshape(-1, 3)])
                if thin[group].any() and not _solid(v):
                    # each facet's own slab where that is a solid; a sliver's is not, and
                    # its neighbours' slabs cover it to within its height
                    for f in group:
                        own = np.concatenate([tri[f], inner[f]])
                        if _solid(own):
                            out.append(own)
                            depths.append(float(depth[f]))
                    continue
                out.append(v)
                depths.append(float(depth[group].min()))
        if not out:
            raise SimulationError("no piece of the part is near the hand")
        return out, np.array(depths)

    def _depths(self, tri: NDArray[np.float64], n: NDArray[np.float64],
                body: NDArray[np.int64]) -> NDArray[np.float64]:
        """Each facet's slab depth: ``slab``, or ``WALL_SHARE`` of the wall behind it (a ray
        into the part from its centre, to the first face of its own body; another body met
        first, one that overlaps or touches it, says nothing of the wall, nor does a wall
        thinner than ``SHEET_RTOL`` of a slab) where that is less. The rays start a
        millionth of the part's length inside, and take only faces ahead of that (trimesh's
        rays, used before, count faces up to 1e-6 behind, in any unit: a part smaller than
        one unit met its own facet first, and no wall was ever measured)."""
        depth = np.full(len(tri), self.slab)
        if self.part is None or not len(tri):
            return depth
        eps = 1e-6 * float(self.part.length)
        o = tri.mean(axis=1) - eps * n
        face, t = self.part.first_hits(o, -n)
        own = (face >= 0) & (self.part.face_body[np.maximum(face, 0)] == body)
        wall = np.where(own, t, np.inf)
        wall[wall < SHEET_RTOL * self.slab] = np.inf
        return np.minimum(depth, WALL_SHARE * wall)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no vertices)."""
        return {"pieces": len(self.pieces), "bodies": self.bodies,
                "faceted_bodies": self.faceted, "slab": self.slab}


def _convex_patches(tri: NDArray[np.float64], corners: NDArray[np.int64],
                    n: NDArray[np.float64], inner: NDArray[np.float64],
                    depth: NDArray[np.float64], tol: float) -> list[list[int]]:
    """Facets grouped into convex patches: each group is connected through shared edges,
    every corner of the group lies on or behind the plane of every facet of it (``n`` points
    out of the part), the facets' normals are within ``_PATCH_SPREAD`` of each other (so
    each corner's inward offset along any of them is behind every plane too), and the facets
    cover the hull of their corners seen along their mean normal: the hull of the group and
    its inner corners ``inner`` (t, 3, 3) (each facet's corners moved ``depth`` along its
    normal) is bounded on the outside by exactly those facets. Inside, the hull reaches at
    most ``_PATCH_REACH`` times a facet's depth behind that facet's plane: a patch that
    bends reaches deeper than its slabs by its sagitta, and on a thin curved wall (a mug's
    side, a bent sheet) a hull grown round the bend came out of the wall's far side, where a
    finger pressing that side met it (on the puck goal, by 40% of the tip's radius). The
    same bound keeps apart flat facets whose walls (so depths) differ by more than twice, as
    over a pocket: their common hull would reach through the thinner wall. Fewer, larger
    slabs, the same surface. Greedy, grown from each facet in turn over its neighbours, at
    most ``_PATCH_FACETS`` facets a patch."""
    t = len(tri)
    edges: dict[tuple[int, int], list[int]] = {}
    for i, (a, b, c) in enumerate(corners.tolist()):
        for e in ((a, b), (b, c), (c, a)):
            edges.setdefault((min(e), max(e)), []).append(i)
    neighbours: list[list[int]] = [[] for _ in range(t)]
    for fs in edges.values():
        for i in fs:
            neighbours[i].extend(j for j in fs if j != i)
    owner = np.full(t, -1)
    groups: list[list[int]] = []
    for seed in range(t):
        if owner[seed] >= 0:
            continue
        group, points = [seed], np.concatenate([tri[seed], inner[seed]])
        owner[seed] = len(groups)
        frontier = list(neighbours[seed])
        while frontier and len(group) < _PATCH_FACETS:
            j = frontier.pop()
            if owner[j] >= 0 or (n[group] @ n[j]).min() < _PATCH_SPREAD:
                continue
            both = np.concatenate([points, tri[j], inner[j]])
            planes = group + [j]
            # every corner and inward corner behind every facet's plane, n . (v - p) <= tol,
            # and none deeper than _PATCH_REACH times that facet's depth
            side = np.einsum("fk,vk->fv", n[planes], both) - np.einsum(
                "fk,fk->f", n[planes], tri[planes, 0])[:, None]
            if side.max() > tol or (side.min(axis=1) < -_PATCH_REACH * depth[planes] - tol
                                    ).any() or not _covers_hull(tri[planes], n[planes]):
                continue
            group.append(j)
            points = both
            owner[j] = len(groups)
            frontier.extend(neighbours[j])
        groups.append(group)
    return groups


def _covers_hull(tri: NDArray[np.float64], n: NDArray[np.float64]) -> bool:
    """Whether facets (a convex surface patch, normals within 60 degrees) cover the hull of
    their corners seen along their mean normal: their projected areas add up to the hull's
    (an L-shaped face, or a patch with a notch, does not: its hull would fill the notch)."""
    from scipy.spatial import ConvexHull

    m = n.sum(axis=0)
    m /= np.linalg.norm(m)
    u = _cross3(m, np.array([1.0, 0.0, 0.0] if abs(m[0]) < 0.9 else [0.0, 1.0, 0.0]))
    u /= np.linalg.norm(u)
    w = _cross3(m, u)
    xy = np.stack([tri @ u, tri @ w], axis=-1)  # (t, 3, 2)
    a, b = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    total = float(np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum()) / 2
    try:
        hull = float(ConvexHull(xy.reshape(-1, 2)).volume)  # a 2-D hull's volume is its area
    except Exception:  # noqa: BLE001 - qhull refuses degenerate input: a single sliver
        return len(tri) == 1
    return hull <= total * (1.0 + 1e-9)


def _cross3(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``np.cross`` of two 3-vectors, the same products and differences without its
    overhead for arrays (a third of the patches' time on a 923k-face bunny's grasp)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def within(centers: NDArray[np.float64], radius: float):  # type: ignore[no-untyped-def]
    """A facet selector for :meth:`PartShape.near`: triangles that come within ``radius`` of
    any of the ``centers`` (n, 3) (tested conservatively, by each triangle's bounding
    sphere)."""
    C = np.asarray(centers, float).reshape(-1, 3)

    def inside(tri: NDArray[np.float64]) -> NDArray[np.bool_]:
        mid = tri.mean(axis=1)
        reach = np.linalg.norm(tri - mid[:, None], axis=2).max(axis=1)
        d = np.linalg.norm(mid[:, None] - C[None], axis=2).min(axis=1)
        return d <= radius + reach

    return inside


def _solid(v: NDArray[np.float64]) -> bool:
    """Whether a piece's hull has a volume MuJoCo can load."""
    if len(v) < 4:
        return False
    extent = np.ptp(v, axis=0)
    if not np.all(extent > 0):
        return False
    try:
        from scipy.spatial import ConvexHull

        return bool(ConvexHull(v).volume > FLAT_RTOL * float(np.prod(extent)))
    except Exception:  # noqa: BLE001 - qhull refuses degenerate input
        return False


def _own_sources(part: Any, body: Any) -> list[int] | None:
    """The closed convex bodies of the file (their numbers in ``part.convex_inputs``) whose
    surfaces a body's faces lie on, when they all do: a body the loader united from them
    (or a sliver the union left) is covered exactly by them. None otherwise."""
    if part.face_source is None or not part.convex_inputs:
        return None
    sources = np.unique(part.face_source[body.faces])
    if not all(int(k) in part.convex_inputs for k in sources):
        return None
    return [int(k) for k in sources]


def _mass_properties(bodies: list[trimesh.Trimesh], points: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], float, NDArray[np.float64]]:
    closed = [b for b in bodies if b.is_watertight and b.volume > 0]
    if not closed:
        closed = [trimesh.convex.convex_hull(points)]
    volume = float(sum(b.volume for b in closed))
    center = sum(b.volume * np.asarray(b.center_mass) for b in closed) / volume
    inertia = np.zeros((3, 3))
    for b in closed:
        d = np.asarray(b.center_mass) - center
        inertia += np.asarray(b.moment_inertia) + b.volume * (np.dot(d, d) * np.eye(3)
                                                              - np.outer(d, d))
    return inertia, volume, np.asarray(center, float)


def part_shape(part: Any) -> PartShape:
    """The collision shape of a planned part (see the module).

    Parameters
    ----------
    part : synth.Part
        The part the grasps were planned on (:func:`synth.load_part`).

    Returns
    -------
    PartShape

    Examples
    --------
    >>> s = part_shape(load_part("meshes/cube.stl", "dm"))  # doctest: +SKIP
    >>> len(s.pieces), s.faceted
    (1, 0)
    """
    from synth.part.model import Part

    if not isinstance(cast(object, part), Part):  # (part stays Any for the type checker)
        raise InputError(f"part: expected a synth.Part (load_part), got {type(part).__name__}")
    pieces: list[NDArray[np.float64]] = []
    faces: list[NDArray[np.int64]] = []
    used: set[int] = set()
    with np.errstate(divide="ignore", invalid="ignore"):  # trimesh on open bodies' volume
        meshes = [part.mesh.submesh([b.faces], append=True) for b in part.bodies]
        for b, m in zip(part.bodies, meshes, strict=True):
            own = None if b.convex else _own_sources(part, b)
            if b.convex and _solid(np.asarray(m.vertices, float)):
                pieces.append(np.asarray(m.vertices, float))
            elif own is not None:
                for k in own:
                    if k not in used and _solid(part.convex_inputs[k]):
                        pieces.append(part.convex_inputs[k])
                    used.add(k)
            else:
                faces.append(np.asarray(b.faces, np.int64))
        inertia, volume, center = _mass_properties(meshes, np.asarray(part.mesh.vertices))
    shell = np.concatenate(faces) if faces else np.zeros(0, np.int64)
    tri = np.asarray(part.mesh.triangles, float)[shell]
    corners = np.asarray(part.mesh.faces, np.int64)[shell]
    return PartShape(tuple(pieces), tri, corners, np.asarray(part.face_body, np.int64)[shell],
                     SLAB_RTOL * float(part.length),
                     len(part.bodies), len(faces), inertia, volume, center, part)
