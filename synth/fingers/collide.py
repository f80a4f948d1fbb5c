"""Can the fingers of a grasp physically be placed? Batched checks with numpy and FCL.

For a batch of grasps of one part, :func:`check_fingers` keeps the grasps whose fingers

1. can touch all their contacts (a fingertip shared by several contacts fits them all),
2. do not overlap each other (tips and bodies; exact sphere/capsule distances in numpy),
3. stay on the part's side of an optional support plane, approach path included (numpy),
4. do not penetrate the part deeper than ``Fingers.penetration_tol`` (exact distances, FCL
   within round-off of the limit; a tip is seated along the mesh's own normal, see
   :mod:`synth.scores.surface`, so one touching the facets sinks into none of them), and
5. can come in from outside along an approach direction in the cone without passing through
   the part (FCL: the fingertip swept from beyond the part's bounding sphere to its contact is
   a capsule, which also contains the tip and, the body being thinner, the whole finger).

The cheap numpy stages run first on the whole batch; FCL only sees fingers of grasps still
alive, and a grasp is dropped at its first failing finger. The part's BVH is built once per
mesh and cached (:func:`checker_for`).

Certificates take most sweeps off FCL, with its verdicts to its tolerance
(:meth:`FingerChecker._certify`): a sweep that one supporting plane of the part's convex
hull separates from the part is clear; a tip centre nearer the surface than the tip's radius
(exact distances: libigl's tree, or a :class:`synth.Part`'s own) sinks in; the end of a sweep
seated on the surface, whose box FCL tests against every triangle under the tip, is certified
clear by balls along its axis, and only the rest goes to FCL. On a mesh of ``_TRACE_FACES``
or more the whole sweep is sphere-traced (:meth:`FingerChecker._trace`), so that FCL's BVH is
built only if a sweep grazes the surface, a tip sinks in or a gripper is checked.

A tip centre inside the part (contact far off the surface, or a flipped normal on a thick
part) is caught by the approach check: every path from outside to it crosses the surface.

Limits: approach directions are chosen per finger against the part and the plane only
(the first clear one of :func:`~synth.fingers.geometry.approach_directions`), and fingers
are compared in their final places, not along their approach paths. Contacts are assumed to
lie on the surface: a contact floating off it is not rejected (its tip penetrates nothing).
The part is one FCL object, so each finger is one direct ``fcl.collide`` call against its BVH;
a broad-phase manager would add nothing (every finger's box overlaps the part's).
"""

from __future__ import annotations

import math
import numbers
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import fcl
import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from synth.errors import InputError
from synth.fingers.geometry import (
    approach_directions,
    point_segment_distance,
    quaternions_to,
    segment_segment_distance,
)
from synth.fingers.model import (
    SHARED_TIP_FIT_RTOL,
    FingerPlacement,
    Fingers,
    part_mesh,
    tip_centers,
)
from synth.native import bvh_model, mesh_problem
from synth.part.closest import BoxTree, DistanceBound
from synth.part.tolerances import bounds
from synth.scores.arguments import length_arg
from synth.tolerances import NORMAL_NORM_TOL

__all__ = [
    "OK",
    "ABSENT",
    "UNCHECKED",
    "MISFIT",
    "OVERLAP",
    "PLANE",
    "TIP_PENETRATES",
    "BODY_HITS_PART",
    "APPROACH_BLOCKED",
    "STATUS_NAMES",
    "DEGENERATE_AXIS_TOL",
    "tip_sinks",
    "FingerCheck",
    "FingerChecker",
    "checker_for",
    "check_fingers",
    "finger_placement",
]

#: Per-finger status codes of :attr:`FingerCheck.status`.
OK, ABSENT, UNCHECKED = 0, -2, -1
MISFIT, OVERLAP, PLANE, TIP_PENETRATES, BODY_HITS_PART, APPROACH_BLOCKED = 1, 2, 3, 4, 5, 6
#: A finger's summed outward normals shorter than this (the sum of unit vectors) count as
#: cancelling out (a tip pinched between opposite faces); see ``_approach_axes``.
DEGENERATE_AXIS_TOL: float = 1e-6
#: The near-tip certificate (:meth:`FingerChecker._certify`): the first this many tip radii of
#: an approach sweep are covered by ``_NEAR_BALLS`` balls checked with exact distances.
_NEAR_LENGTH = 1.0
_NEAR_BALLS = 3
#: Meshes of at least this many faces have their sweeps traced (:meth:`FingerChecker._trace`)
#: and FCL's BVH built only on demand: below it, building the BVH costs less than tracing.
_TRACE_FACES = 50_000
#: A trace stops undecided after this many steps, or at a step below this fraction of the
#: capsule's radius (a sweep grazing the surface), and FCL decides.
_TRACE_STEPS = 64
_TRACE_MIN_STEP = 1e-3
#: A traced point whose :class:`~synth.part.closest.DistanceBound` is at least this many times
#: the bound's slack, and above the capsule's radius by at least that slack, steps by the bound
#: instead of an exact distance: there the bound is at least f / (f + 2) of the distance, its
#: step at least sqrt(2 radius slack) (not the grazing step that leaves a sweep undecided), and
#: an exact query costs most. Since the traces end at the bounding planes
#: (:func:`_bounding_planes`), it serves mostly the sweeps that cross a cavity: on a 923k-face
#: bunny's default plan it saves 1,879 of 12,701 exact queries (the plan 1.15 -> 1.03 s); on a
#: 1.3M-face blob, none.
_FAR_BOUND = 4.0
#: The bound is built once the traces have measured this many points exactly: round a convex
#: part they end at the bounding planes before that (the blob's plan: 6,917 points; the
#: bound's build, 0.13 s of it at 1.3M faces, saved nothing). Raised from 10,000 when the
#: local pools (:mod:`synth.plan.polish`) added their contacts' reach checks: a default plan
#: of the 1.3M-face blob measures 13,791 points, of the 923k-face bunny 25,809, and with the
#: bound built at 10,000 they took 1.53 and 1.50 s of CPU against 1.07 and 1.37 s without it.
_BOUND_AFTER = 30_000
#: The hull's planes certify sweeps only on parts whose hull has at most this many distinct
#: facet planes (every corpus part: 6 to 1,992): the certificate is a product of the fingers
#: by the planes, which on a smooth blob's hull (17,592 planes at 20k faces) cost more than
#: the FCL sweeps it saves (a plan 0.58 s -> 2.4 s, 889 MB); the rows go through it in chunks
#: of about ``_PLANE_CHUNK`` products.
_HULL_PLANES, _PLANE_CHUNK = 2048, 1 << 20
#: On a traced mesh, the first this many FCL tests (of the sweeps the traces leave
#: undecided) are made against trees of only the faces near the object, built for each
#: (about 40 ns a face of the mesh to select them); the whole mesh's tree (about 2.5 us a
#: face) after that.
_LOCAL_TREES = 32
#: Verdicts on a finger's first approach sweep (:meth:`FingerChecker._certify`, the traces):
#: clear; its near part clear (the rest to FCL); crossing the surface; its tip sinking in.
_CLEAR, _NEAR, _CROSSES, _SINKS = 2, 1, -1, -2
STATUS_NAMES: dict[int, str] = {
    OK: "ok",
    ABSENT: "absent",
    UNCHECKED: "unchecked",
    MISFIT: "misfit",
    OVERLAP: "overlap",
    PLANE: "plane",
    TIP_PENETRATES: "tip_penetrates",
    BODY_HITS_PART: "body_hits_part",
    APPROACH_BLOCKED: "approach_blocked",
}


@dataclass(frozen=True)
class FingerCheck:
    """Result of checking B grasps of k contacts with fingers (f = k finger slots).

    Attributes
    ----------
    mask : (B,) bool
        The grasp can be made.
    reasons : tuple of str, length B
        Why each grasp was dropped ("" when accepted), naming the finger (by its index in
        the grasp's :class:`FingerPlacement`) and what it hit.
    status : (B, f) int8
        Per finger slot: ``OK``, a failure code, ``UNCHECKED`` (grasp dropped earlier) or
        ``ABSENT`` (no contact uses this finger id).
    tip_centers : (B, f, 3) float
        NaN for absent fingers.
    approach : (B, f, 3) float
        Chosen unit approach directions (away from the part); NaN where none was found.
    contact_finger : (B, k) int
        Finger slot of each contact.
    fingers : Fingers
    """

    mask: np.ndarray
    reasons: tuple[str, ...]
    status: np.ndarray
    tip_centers: np.ndarray
    approach: np.ndarray
    contact_finger: np.ndarray
    fingers: Fingers

    @property
    def n_accepted(self) -> int:
        """Number of grasps that can be made."""
        return int(self.mask.sum())

    def placement(self, i: int) -> FingerPlacement:
        """Finger geometry of accepted grasp ``i`` (fingers renumbered 0..f_i-1 by slot)."""
        if isinstance(i, bool) or not isinstance(i, numbers.Integral) or not (
                0 <= int(i) < len(self.mask)):
            raise InputError(f"i: expected a grasp index from 0 to {len(self.mask) - 1}, got "
                             f"{i!r}")
        if not self.mask[i]:
            raise InputError(f"grasp {i} was rejected ({self.reasons[i]}); it has no placement")
        slots = np.flatnonzero(self.status[i] != ABSENT)
        renumber = np.full(self.status.shape[1], -1, dtype=int)
        renumber[slots] = np.arange(len(slots))
        f = self.fingers
        return FingerPlacement(
            tip_centers=self.tip_centers[i, slots].copy(),
            tip_radius=float(f.tip_radius),
            approach=self.approach[i, slots].copy(),
            body_length=float(f.body_length),  # type: ignore[arg-type]
            body_radius=float(f.body_radius),  # type: ignore[arg-type]
            contact_finger=renumber[self.contact_finger[i]],
        )


class FingerChecker:
    """FCL model of one part, built once, checking many grasps.

    Parameters
    ----------
    part : trimesh.Trimesh or object with ``.mesh``
        Watertight mesh with outward face normals.
    distance : callable, optional
        Exact distances (n,) of points (n, 3) from the surface (default: a libigl tree of
        the mesh).
    certify : bool
        Decide what it can of each sweep with the certificates of :meth:`_certify` (default);
        False leaves every sweep and tip to FCL, the slower reference they are tested against.

    Examples
    --------
    >>> import trimesh
    >>> checker = FingerChecker(trimesh.creation.box())
    >>> res = checker.check(np.array([[[0.0, 0.0, 0.5]]]), np.array([[[0.0, 0.0, -1.0]]]),
    ...                     Fingers(tip_radius=0.05))
    >>> res.mask.tolist()
    [True]
    """

    def __init__(self, part: Any,
                 distance: Callable[[np.ndarray], np.ndarray] | None = None,
                 certify: bool = True) -> None:
        mesh = part_mesh(part)
        vertices = np.asarray(mesh.vertices, dtype=float)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        problem = mesh_problem(vertices, faces)
        if problem is not None:  # FCL would crash or answer nonsense
            raise InputError(f"part: a mesh FCL cannot check: {problem}")
        # the surface's distance for the near-tip certificate and the traces
        self._distance = distance or BoxTree(vertices, faces).distance
        lo, hi = bounds(vertices)
        self.center: np.ndarray = (lo + hi) / 2.0
        self.radius: float = float(np.linalg.norm(hi - lo)) / 2.0
        # FCL works with absolute tolerances: give it the part centred and of unit size, so
        # a part of 1 mm in metres or 1 km far from the origin is checked like one of 1 m
        self._scale = self.radius if self.radius > 0 else 1.0
        # round-off of a distance computed from these coordinates: a traced distance this
        # close to a radius decides nothing (a seated tip with no penetration tolerance)
        self._slack = 1e-9 * (self.radius + float(np.abs(self.center).max()))
        self.mesh = mesh
        # a large mesh's sweeps are traced with exact distances; FCL's BVH of it (about 2.5 us
        # a face to build) is then built only if more than _LOCAL_TREES sweeps graze the
        # surface (those before go to trees of the faces near them) or a gripper needs it
        self._certify_sweeps = certify
        self._traced = certify and len(faces) >= _TRACE_FACES
        self._bound: DistanceBound | None = None  # for the traces, built when worth it
        self._traced_exactly = 0  # points traced before it is built
        self._exits: np.ndarray | None = None  # the traces' bounding planes, built on first use
        self._fcl: Any = None if self._traced else self._build_fcl()
        self._local_trees = 0  # FCL trees of a few faces built instead (_near_part)
        # the hull's supporting planes separate most sweeps from the part (_certify)
        self._planes = (_support_planes(vertices, _HULL_PLANES) if certify and not self._traced
                        else np.zeros((0, 4)))
        self._objects: dict[tuple[str, float, float], Any] = {}
        self._sizes: dict[int, tuple[float, float]] = {}  # their radius and length, FCL's
        self._request = fcl.CollisionRequest()

    # -- FCL primitives ---------------------------------------------------------------------

    def _build_fcl(self) -> Any:
        vertices = np.asarray(self.mesh.vertices, dtype=float)
        bvh = bvh_model((vertices - self.center) / self._scale,
                        np.asarray(self.mesh.faces, dtype=np.int64))
        return fcl.CollisionObject(bvh, fcl.Transform())

    @property
    def _part(self) -> Any:
        """The part as one FCL object (its BVH built on first use)."""
        if self._fcl is None:
            self._fcl = self._build_fcl()
        return self._fcl

    def _object(self, kind: str, radius: float, length: float = 0.0) -> Any:
        key = (kind, radius, length)
        obj = self._objects.get(key)
        if obj is None:
            r, h = radius / self._scale, length / self._scale
            geom = fcl.Sphere(r) if kind == "sphere" else fcl.Capsule(r, h)
            obj = fcl.CollisionObject(geom, fcl.Transform())
            self._objects[key] = obj
            self._sizes[id(obj)] = (r, h if kind != "sphere" else 0.0)
        return obj

    def _tip_hits(self, tip: Any, center: np.ndarray, position: np.ndarray,
                  radius: float, distance: float = math.nan) -> bool:
        """Whether the tip ball of ``radius`` at ``center`` (``position`` in FCL's frame)
        crosses the surface: by its centre's exact ``distance`` from the surface (computed
        here when not given), FCL only where that is within round-off of ``radius`` or the
        checker certifies nothing."""
        if self._certify_sweeps:
            d = distance if distance == distance else float(self._distance(center[None])[0])
            if abs(d - radius) > self._slack:  # else it touches to round-off: FCL says
                return d < radius
        return self._hits(tip, None, position, np.zeros(3))

    def _hits(self, obj: Any, rotation: np.ndarray | None, position: np.ndarray,
              axis: np.ndarray | None = None) -> bool:
        """Whether ``obj`` (from :meth:`_object`) collides with the part at ``position``
        given in FCL's frame (:meth:`_fcl_frame`), rotated by the quaternion ``rotation``
        (None: unrotated). ``axis`` (3,), if given, is the unit direction of a capsule's axis
        (any for a ball), which bounds the object's box (see :meth:`_near_part`)."""
        if rotation is not None:
            obj.setQuatRotation(rotation)
        obj.setTranslation(position)
        if axis is not None and self._fcl is None:
            r, h = self._sizes[id(obj)]
            part = self._near_part(position, 0.5 * h * np.abs(axis) + r)
        else:
            part = self._part
        if part is None:
            return False
        return bool(fcl.collide(part, obj, self._request, fcl.CollisionResult()))

    def _near_part(self, position: np.ndarray, reach: np.ndarray) -> Any:
        """The part as an FCL object for a test of an object within ``position +- reach``
        (FCL's frame). On a traced mesh whose whole tree is not built, for the first
        ``_LOCAL_TREES`` tests: a tree of only the faces whose boxes meet that box, in the
        same coordinates, so the same triangles are tested against the object (None if
        there are none); then the whole part's."""
        if not self._traced or self._local_trees >= _LOCAL_TREES:
            return self._part
        self._local_trees += 1
        grow = np.asarray(reach, float) + 1e-9  # FCL's frame is of unit size
        lo = (position - grow) * self._scale + self.center
        hi = (position + grow) * self._scale + self.center
        vertices = np.asarray(self.mesh.vertices, float)
        faces = np.asarray(self.mesh.faces, np.int64)
        keep = np.arange(len(faces))
        for k in range(3):  # the faces whose boxes meet it, an axis at a time
            x = [np.take(vertices[:, k], faces[keep, c]) for c in range(3)]
            meet = ((np.maximum(np.maximum(x[0], x[1]), x[2]) >= lo[k])
                    & (np.minimum(np.minimum(x[0], x[1]), x[2]) <= hi[k]))
            keep = keep[meet]
        if not len(keep):
            return None
        used, local = np.unique(faces[keep], return_inverse=True)
        bvh = bvh_model((vertices[used] - self.center) / self._scale, local.reshape(-1, 3))
        return fcl.CollisionObject(bvh, fcl.Transform())

    def _certify(self, centers: np.ndarray, axis: np.ndarray, live: np.ndarray,
                 radius: float, length: float, s: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What exact geometry decides of each live finger's first approach sweep.

        The sweep is a capsule of ``radius`` along ``[c, c + length d]`` from the tip centre
        ``c`` (B, k, 3) along ``axis`` ``d`` (B, k, 3), for the fingers ``live`` (B, k).
        In turn, each finger taking the first that applies:

        1. ``_CLEAR``: a supporting plane ``n . x = h`` of the part's convex hull (the plane
           whose outer side holds ``c`` deepest) has the whole capsule on its outer side,
           ``n . c - h + length min(0, n . d) > radius``, so the part, which lies on the
           other, touches none of it. Most sweeps of a convex part, and of the hull's faces
           of any part, end here, in one matrix product.
        2. ``_SINKS``: the tip centre is nearer the surface than ``radius`` (exact distance),
           so the tip ball, and every sweep that holds it, crosses the surface.
        3. ``_NEAR``: the first ``s`` of the capsule lies inside ``_NEAR_BALLS`` balls centred
           on the axis, each ``s / _NEAR_BALLS`` long and of radius
           ``radius + s / (2 _NEAR_BALLS)``, which the surface is at least that far from
           (exact distances): only the rest of the capsule, which stays clear of the
           contact's neighbourhood, goes to FCL. FCL's box test against a capsule seated on
           the surface opens every triangle under the tip, so its cost grew with the mesh's
           density (1.5 ms a sweep at 1.3M faces); the far capsule costs about 10 us.
        4. ``0``: nothing is certified; FCL checks the whole sweep, as it did before.

        Every certificate needs a margin of ``_slack`` (round-off), so the verdicts are
        FCL's on whole sweeps, but for a tip sunk past ``radius`` by less than FCL's own
        tolerance, which the exact distance calls sunk (a candidate of the coffee mug's
        plan, 2.9e-8 past it: 1.2e-5 of the tip's radius, which FCL had let through).

        Returns
        -------
        verdict : (B, k) int8
        tip_distance : (B, k) float
            The tip centre's distance from the surface where step 2 computed it, else NaN.
        far_mid : (B, k, 3) float
            The far capsule's centre, in FCL's frame.
        """
        B, k = centers.shape[:2]
        verdict = np.zeros(B * k, np.int8)
        tip_distance = np.full(B * k, np.nan)
        rows = np.flatnonzero(live.ravel())
        c, d = centers.reshape(-1, 3)[rows], axis.reshape(-1, 3)[rows]
        if len(rows) and len(self._planes):
            n, h = self._planes[:, :3], self._planes[:, 3]
            at_once = max(1, _PLANE_CHUNK // len(n))
            deepest = np.concatenate([np.argmax(c[i:i + at_once] @ n.T - h, axis=1)
                                      for i in range(0, len(c), at_once)])
            nf = n[deepest]
            gap = (np.einsum("ij,ij->i", nf, c) - h[deepest]
                   + length * np.minimum(np.einsum("ij,ij->i", nf, d), 0.0))
            clear = gap > radius + self._slack
            verdict[rows[clear]] = _CLEAR
            rows, c, d = rows[~clear], c[~clear], d[~clear]
        if len(rows):
            tip_distance[rows] = dist = self._distance(c)
            sinks = dist < radius - self._slack
            verdict[rows[sinks]] = _SINKS
            rows, c, d = rows[~sinks], c[~sinks], d[~sinks]
        if len(rows):
            step = s / _NEAR_BALLS
            t = (np.arange(_NEAR_BALLS) + 0.5) * step
            balls = c[:, None, :] + t[:, None] * d[:, None, :]  # (n, _NEAR_BALLS, 3)
            dist = self._distance(balls.reshape(-1, 3)).reshape(len(rows), _NEAR_BALLS)
            verdict[rows[(dist >= radius + 0.5 * step).all(axis=1)]] = _NEAR
        far_mid = self._fcl_frame(centers + (s + 0.5 * (length - s)) * axis)
        return verdict.reshape(B, k), tip_distance.reshape(B, k), far_mid

    def _trace(self, starts: np.ndarray, dirs: np.ndarray, radius: float, length: float
               ) -> np.ndarray:
        """Verdicts (n,) of the capsules of ``radius`` along ``[a, a + length d]`` from
        ``starts`` (n, 3) along unit ``dirs`` (n, 3): 1 clear of the surface, -1 crossing
        it, 0 undecided (grazing it; left to FCL).

        Sphere tracing with exact distances: a point of the axis at distance ``delta`` from
        the surface is the centre of an empty ball, which holds the capsule's section within
        ``sqrt(delta^2 - radius^2)`` of it along the axis (at the start, the rounded end too;
        at the end of the axis, the other one), so the next point is taken there, never past
        the axis' end; a point of the axis nearer than ``radius`` has surface inside the
        capsule. A point within round-off of ``radius`` decides nothing. The steps grow with
        the distance. A point beyond one of the mesh's bounding planes by more than ``radius``,
        on a sweep that moves away from that plane, ends the trace clear: the rest of the
        capsule lies beyond the plane, where no vertex is. Round a convex part, that comes
        after a step or two (on a 1.3M-face blob, 6,917 points traced instead of 18,524).
        """
        n = len(starts)
        verdict = np.zeros(n, np.int8)
        t = np.zeros(n)
        live = np.arange(n)
        # past the point where the axis leaves the part's bounding sphere grown by ``radius``
        # (for good: it is a line), the capsule is clear (far from a mesh its distance
        # queries are slowest)
        w = starts - self.center
        wd = np.einsum("ij,ij->i", w, dirs)
        grown = self.radius * (1.0 + 1e-9) + radius
        out = -wd + np.sqrt(np.maximum(wd * wd - np.einsum("ij,ij->i", w, w) + grown**2, 0.0))
        exit_ = np.maximum(out, 0.0)
        # past a supporting plane of the mesh by more than ``radius``, moving away from it,
        # the capsule is clear for good too, and that comes much sooner
        if self._exits is None:
            self._exits = _bounding_planes(np.asarray(self.mesh.vertices, float))
        normal, offset = self._exits[:, :3], self._exits[:, 3]
        leaving = dirs @ normal.T >= 0.0  # (n, planes)
        for _ in range(_TRACE_STEPS):
            if not len(live):
                break
            tl = t[live]
            p = starts[live] + tl[:, None] * dirs[live]
            gone = ((p @ normal.T - offset > radius + self._slack) & leaving[live]).any(axis=1)
            verdict[live[gone]] = 1
            live, tl, p = live[~gone], tl[~gone], p[~gone]
            delta = self._trace_distance(p, radius)
            hit = delta < radius - self._slack
            h = np.sqrt(np.maximum(delta * delta - radius * radius, 0.0))
            reach = tl + h
            done = ~hit & (delta >= radius) & ((tl >= length) | (reach >= exit_[live]))
            verdict[live[hit]] = -1
            verdict[live[done]] = 1
            step = np.minimum(reach, length)
            go = ~hit & ~done & (step - tl > _TRACE_MIN_STEP * radius)
            t[live[go]] = step[go]
            live = live[go]
        return verdict

    def _trace_distance(self, points: np.ndarray, radius: float) -> np.ndarray:
        """Distances (n,) of points (n, 3) to the surface for :meth:`_trace`: exact, except
        where the mesh's :class:`~synth.part.closest.DistanceBound` already puts a point
        farther than ``_FAR_BOUND`` times the bound's slack and than ``radius`` plus that
        slack, which is then the distance taken (a shorter step than the exact distance
        allows; the same verdict, since neither is below ``radius`` there)."""
        if self._bound is None:
            if self._traced_exactly < _BOUND_AFTER:
                self._traced_exactly += len(points)
                return self._distance(points)
            self._bound = DistanceBound(self.mesh.vertices, self.mesh.faces)
        out = self._bound(points)
        slack = self._bound.radius
        near = np.flatnonzero(out < max(radius + slack, _FAR_BOUND * slack))
        out[near] = self._distance(points[near])
        return out

    def _fcl_frame(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 3) of the part's frame in FCL's (centred, unit size), all at once:
        converting them one at a time cost more than a collision test."""
        return (np.asarray(points, float) - self.center) / self._scale

    def mesh_object(self, vertices: np.ndarray, faces: np.ndarray) -> Any:
        """An FCL object of a rigid triangle mesh (vertices in its own frame, part units), to
        place with :meth:`mesh_hits` (a gripper's palm or finger).

        Raises
        ------
        InputError
            No face, shapes other than (n, 3) and (m, 3), a coordinate that is not finite
            or a face index out of range (FCL would crash the process on some of them).
        """
        problem = mesh_problem(vertices, faces)
        if problem is not None:
            raise InputError(f"mesh_object: {problem}")
        bvh = bvh_model(np.asarray(vertices, float) / self._scale, np.asarray(faces, np.int64))
        return fcl.CollisionObject(bvh, fcl.Transform())

    def mesh_hits(self, obj: Any, rotation: np.ndarray, translation: np.ndarray) -> bool:
        """Whether ``obj`` (from :meth:`mesh_object`), rotated (3 x 3) and moved in the
        part's frame, intersects the part (any body)."""
        if not isinstance(obj, fcl.CollisionObject):
            raise InputError(f"mesh_hits: obj must come from mesh_object, got "
                             f"{type(obj).__name__}")
        obj.setRotation(np.asarray(rotation, float))
        obj.setTranslation(self._fcl_frame(translation))
        return bool(fcl.collide(self._part, obj, self._request, fcl.CollisionResult()))

    def _penetration(self, center: np.ndarray, radius: float) -> float:
        """Depth by which the ball (center, radius) sinks into the surface: its radius less
        its centre's exact distance from the surface (0 when it touches nothing). FCL's
        deepest contact, used before, fell short of it: 0.0015 for a tip sunk 0.0028 into a
        fine blob (its sphere-triangle depths come from an iterative solver)."""
        return max(0.0, radius - float(self._distance(np.asarray(center, float)[None])[0]))

    def sweep_length(self, fingers: Fingers) -> float:
        """Length of the approach sweep: from the tip centre to beyond the bounding sphere."""
        if not isinstance(fingers, Fingers):
            raise InputError(f"fingers: expected a synth Fingers, got {type(fingers).__name__}")
        length = float(fingers.body_length)  # type: ignore[arg-type]
        return 2.0 * self.radius + 2.0 * fingers.tip_radius + length

    # -- the batched check ------------------------------------------------------------------

    def check(
        self,
        points: np.ndarray,
        normals: np.ndarray,
        fingers: Fingers,
        finger_ids: np.ndarray | None = None,
        depths: bool = True,
    ) -> FingerCheck:
        """Check B grasps; see :func:`check_fingers`."""
        P, N, ids = _validate(points, normals, fingers, finger_ids)
        B, k, _ = P.shape
        r = float(fingers.tip_radius)
        rb = float(fingers.body_radius)  # type: ignore[arg-type]
        L = float(fingers.body_length)  # type: ignore[arg-type]
        tol = float(fingers.penetration_tol)  # type: ignore[arg-type]
        centers, present, misfit, ids = tip_centers(P, N, r, ids)
        status = np.where(present, UNCHECKED, ABSENT).astype(np.int8)
        reasons = [""] * B
        alive = np.ones(B, dtype=bool)
        slot_name = _slot_names(status)

        def fail(b: int, j: int, code: int, text: str) -> None:
            alive[b] = False
            status[b, j] = code
            reasons[b] = text

        def sinks(b: int, j: int) -> None:
            """Fail grasp ``b`` at finger ``j``, whose tip sinks in (by its radius less its
            centre's distance, the one the check measured where it did)."""
            by = ""
            if depths:
                d = tip_distance[b, j]
                by = f" by {r - d if d == d else self._penetration(centers[b, j], r):.3g}"
            fail(b, j, TIP_PENETRATES, f"finger {slot_name[b][j]} tip penetrates the part{by} "
                 f"(a fingertip may sink at most {tol:.3g}, the penetration tolerance)")

        # 1. Shared fingertips must touch all their contacts.
        bad = present & (misfit > SHARED_TIP_FIT_RTOL * r)
        for b, j in zip(*np.nonzero(bad), strict=True):
            if alive[b]:
                cs = np.flatnonzero(ids[b] == j).tolist()
                fail(b, j, MISFIT, f"finger {slot_name[b][j]} cannot touch contacts {cs} at "
                     f"once (off by {misfit[b, j]:.3g})")

        # 2. Tip-tip overlaps.
        iu, ju = np.triu_indices(k, 1)
        if len(iu):
            dist = np.linalg.norm(centers[:, iu] - centers[:, ju], axis=-1)
            both = present[:, iu] & present[:, ju]
            close = both & (dist < 2.0 * r - tol)
            for b, p in zip(*np.nonzero(close), strict=True):
                if alive[b]:
                    i, j = iu[p], ju[p]
                    fail(b, i, OVERLAP, f"fingers {slot_name[b][i]} and {slot_name[b][j]} "
                         f"overlap (tips {dist[b, p]:.3g} apart, less than 2 r = {2 * r:.3g})")
                    status[b, j] = OVERLAP

        # 3. Approach directions (cone around the mean outward normal of each finger).
        onehot = (ids[:, None, :] == np.arange(k)[None, :, None]).astype(float)
        gram = np.einsum("bfj,bjx,bjy->bfxy", onehot, N, N)
        away = np.where(present[..., None], centers - self.center, 0.0)
        axis = _approach_axes(-np.einsum("bfj,bjx->bfx", onehot, N), gram, away)
        axis[~present] = (0.0, 0.0, 1.0)
        dirs = approach_directions(axis.reshape(-1, 3), float(fingers.approach_cone))
        m = dirs.shape[1]
        dirs = dirs.reshape(B, k, m, 3)
        D = self.sweep_length(fingers)
        usable = np.ones((B, k, m), dtype=bool)
        tip_below = np.zeros((B, k), dtype=bool)
        if fingers.support_plane is not None:
            p0, n0 = fingers.support_plane
            h = (centers - p0) @ n0  # (B, k)
            h_far = h[..., None] + D * (dirs @ n0)  # (B, k, m)
            tip_below = present & (h < r - tol)
            usable = ~tip_below[..., None] & (h_far >= r - tol)
            for b, j in zip(*np.nonzero(tip_below | (present & ~usable.any(axis=2))), strict=True):
                if alive[b]:
                    what = "tip" if tip_below[b, j] else "approach"
                    fail(b, j, PLANE, f"finger {slot_name[b][j]} {what} crosses the support plane")

        # 4-5. Tip against part, then the approach sweep: certificates, then FCL
        sweep = self._object("capsule", r - tol, D)
        tip = self._object("sphere", r - tol)
        approach = np.full((B, k, 3), np.nan)
        rot = quaternions_to(dirs.reshape(-1, 3)).reshape(B, k, m, 4)
        mid = self._fcl_frame(centers[:, :, None, :] + 0.5 * D * dirs)  # (B, k, m, 3)
        tips = self._fcl_frame(centers)
        near = _NEAR_LENGTH * r
        live_usable = usable & (present & alive[:, None])[..., None]
        first = np.argmax(live_usable, axis=2)  # each finger's first usable direction
        axis0 = np.take_along_axis(dirs, first[..., None, None], axis=2)[:, :, 0]
        sweeping = np.asarray(live_usable.any(axis=2))
        tip_distance = np.full((B, k), np.nan)
        far_mid = np.zeros((B, k, 3))
        verdict = np.zeros((B, k), np.int8)
        others = np.zeros((B, k, m), np.int8)  # traced verdicts of the other directions
        body_verdict = np.zeros((B, k), np.int8)  # and of a blocked finger's body
        if self._traced:  # the first usable direction of each finger traced in one batch
            rows = np.flatnonzero(sweeping.ravel())
            traced = self._trace(centers.reshape(-1, 3)[rows], axis0.reshape(-1, 3)[rows],
                                 r - tol, D)
            verdict.ravel()[rows] = np.select([traced > 0, traced < 0], [_CLEAR, _CROSSES])
            # a finger whose first sweep crosses tries its other directions, then (all of
            # them blocked) its body along the first: traced as well, since FCL's BVH of
            # such a mesh takes seconds to build (2.4 s at 923k faces)
            crossed = sweeping & (verdict == _CROSSES)
            bi, ji, di = np.nonzero(crossed[..., None] & live_usable
                                    & (np.arange(m) != first[..., None]))
            others[bi, ji, di] = self._trace(centers[bi, ji], dirs[bi, ji, di], r - tol, D)
            if L > 0:
                bi, ji = np.nonzero(crossed & ~(others > 0).any(axis=2))
                body_verdict[bi, ji] = self._trace(centers[bi, ji], dirs[bi, ji, first[bi, ji]],
                                                   rb - tol, L)
        elif self._certify_sweeps:
            verdict, tip_distance, far_mid = self._certify(centers, axis0, sweeping, r - tol, D,
                                                           near)
        far = self._object("capsule", r - tol, D - near)
        # a sweep whose near part is certified clear has FCL decide its far part here, in
        # one pass (the loop below would ask the same, one finger at a time)
        far_hits = np.zeros((B, k), bool)
        bi, ji = np.nonzero(sweeping & (verdict == _NEAR))
        if len(bi):
            rot_far = rot[bi, ji, first[bi, ji]]
            far_hits[bi, ji] = [self._hits(far, rot_far[q], far_mid[b, j]) for q, (b, j)
                                in enumerate(zip(bi.tolist(), ji.tolist(), strict=True))]
        # a finger whose first sweep is clear takes it (undone below for the fingers after a
        # grasp's first failing one, which stay unchecked)
        settled = sweeping & ((verdict == _CLEAR) | ((verdict == _NEAR) & ~far_hits))
        approach[settled] = axis0[settled]
        status[settled] = OK
        todo = present & ~settled
        loop = np.flatnonzero(alive & todo.any(axis=1))
        reset = settled[loop].any(axis=1).tolist()
        first_l, verdict_l = first[loop].tolist(), verdict[loop].tolist()
        todo_l = todo[loop].tolist()
        for q, b in enumerate(loop.tolist()):
            for j in range(k):
                if not todo_l[q][j]:
                    continue
                v = verdict_l[q][j]
                if v == _SINKS:  # its first sweep crosses the surface and the tip sinks in
                    sinks(b, j)
                    break
                options = np.flatnonzero(usable[b, j]).tolist()
                chosen, tip_checked = -1, False
                for d in options:
                    if d == first_l[q][j] and v:  # decided (its far part too, above)
                        hit = v == _CROSSES or bool(v == _NEAR and far_hits[b, j])
                    elif others[b, j, d]:
                        hit = bool(others[b, j, d] < 0)
                    else:
                        hit = self._hits(sweep, rot[b, j, d], mid[b, j, d], dirs[b, j, d])
                    if not hit:
                        chosen = d
                        break
                    if not tip_checked:
                        tip_checked = True
                        if self._tip_hits(tip, centers[b, j], tips[b, j], r - tol,
                                          tip_distance[b, j]):
                            sinks(b, j)
                            break
                if not alive[b]:
                    break
                if chosen < 0:
                    d0 = options[0]
                    body = self._object("capsule", rb - tol, L)
                    if body_verdict[b, j] and d0 == first[b, j]:
                        body_hits = bool(body_verdict[b, j] < 0)
                    else:
                        body_hits = L > 0 and self._hits(body, rot[b, j, d0], self._fcl_frame(
                            centers[b, j] + 0.5 * L * dirs[b, j, d0]), dirs[b, j, d0])
                    if body_hits:
                        fail(b, j, BODY_HITS_PART, f"finger {slot_name[b][j]} body hits the part")
                    else:
                        fail(b, j, APPROACH_BLOCKED,
                             f"finger {slot_name[b][j]} approach blocked by the part")
                    break
                approach[b, j] = dirs[b, j, chosen]
                status[b, j] = OK
            if not alive[b] and reset[q]:
                after = settled[b] & (np.arange(k) > j)
                status[b, after], approach[b, after] = UNCHECKED, np.nan

        # 6. Tip-body and body-body overlaps between fingers, with the chosen directions.
        live = np.flatnonzero(alive)
        if len(iu) and len(live) and L > 0:
            c, a = centers[live], approach[live]
            end = c + L * a
            ci, cj, ei, ej = c[:, iu], c[:, ju], end[:, iu], end[:, ju]
            both = present[live][:, iu] & present[live][:, ju]
            tb = np.minimum(point_segment_distance(ci, cj, ej), point_segment_distance(cj, ci, ei))
            bb = segment_segment_distance(ci, ei, cj, ej)
            hit = both & ((tb < r + rb - tol) | (bb < 2.0 * rb - tol))
            for q, p in zip(*np.nonzero(hit), strict=True):
                b = live[q]
                if alive[b]:
                    i, j = iu[p], ju[p]
                    fail(b, i, OVERLAP, f"fingers {slot_name[b][i]} and {slot_name[b][j]} "
                         "overlap (body against finger)")
                    status[b, j] = OVERLAP
        for arr in (status, centers, approach, ids, alive):
            arr.setflags(write=False)
        return FingerCheck(
            mask=alive,
            reasons=tuple(reasons),
            status=status,
            tip_centers=centers,
            approach=approach,
            contact_finger=np.ascontiguousarray(ids),
            fingers=fingers,
        )


def _support_planes(vertices: np.ndarray, most: int) -> np.ndarray:
    """Supporting planes (F, 4) of the convex hull of ``vertices`` (n, 3): unit outward
    normals ``n`` and offsets ``h`` with ``n . v <= h`` for every vertex, one per distinct
    facet plane. The offsets are the vertices' own maxima, not qhull's (whose facets may leave
    a point outside by its merging tolerance), so each plane supports the mesh exactly. None
    (shape (0, 4)) for a flat or degenerate set, or a hull of more than ``most`` planes: no
    certificate then."""
    try:
        hull = ConvexHull(vertices)
    except (QhullError, ValueError):
        return np.zeros((0, 4))
    n = np.unique(np.round(hull.equations[:, :3], 9), axis=0)  # coplanar facets: one plane
    if len(n) > most:
        return np.zeros((0, 4))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    h = np.empty(len(n))
    step = max(1, 2_000_000 // max(1, len(vertices)))  # bounded memory for a large mesh
    for s in range(0, len(n), step):
        h[s:s + step] = (vertices @ n[s:s + step].T).max(axis=0)
    return np.column_stack([n, h])


def _bounding_planes(vertices: np.ndarray) -> np.ndarray:
    """Supporting planes (42, 4) of ``vertices`` (n, 3) along the directions of an
    icosphere's vertices (unit outward normals ``n``, offsets ``h`` = the vertices' maximum
    of ``n . v``): a polytope about the mesh (about a sphere, 7% of its radius beyond it at
    most), whose planes cost the same to test however many faces the mesh has."""
    n = np.asarray(trimesh.creation.icosphere(subdivisions=1).vertices, float)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    h = np.full(len(n), -np.inf)
    step = 1 << 16
    for s in range(0, len(vertices), step):  # no (v, 42) temporary
        np.maximum(h, (vertices[s:s + step] @ n.T).max(axis=0), out=h)
    return np.column_stack([n, h])


def _approach_axes(outward_sum: np.ndarray, normal_gram: np.ndarray,
                   away: np.ndarray) -> np.ndarray:
    """Unit cone axes (B, f, 3): the normalised sum of each finger's outward normals.

    Parameters
    ----------
    outward_sum : (B, f, 3) float
        Sum of the outward normals (``-normal``) of each finger's contacts.
    normal_gram : (B, f, 3, 3) float
        Sum of ``n n^T`` over each finger's contacts.
    away : (B, f, 3) float
        Tip centre minus the part's centre.

    When the sum (nearly) vanishes, the tip is pinched between faces whose normals cancel (two
    walls of a channel); the axis is then ``away`` projected onto the directions orthogonal to
    all those normals (along the channel, outwards), or ``away`` itself if there is none.
    """
    norm = np.linalg.norm(outward_sum, axis=-1)
    ok = norm > DEGENERATE_AXIS_TOL
    axis = outward_sum / np.where(ok, norm, 1.0)[..., None]
    if np.all(ok):
        return axis
    bad = ~ok
    w, v = np.linalg.eigh(normal_gram[bad])  # (n, 3), (n, 3, 3); columns are eigenvectors
    free = w < DEGENERATE_AXIS_TOL * np.maximum(w[:, -1:], 1.0)
    proj = np.einsum("nxe,ne,nye,ny->nx", v, free.astype(float), v, away[bad])
    fallback = np.where(np.linalg.norm(proj, axis=1, keepdims=True) > 0, proj, away[bad])
    fallback_norm = np.linalg.norm(fallback, axis=1, keepdims=True)
    fallback = np.where(fallback_norm > 0, fallback / np.where(fallback_norm > 0, fallback_norm, 1),
                        (0.0, 0.0, 1.0))
    axis[bad] = fallback
    return axis


def _slot_names(status: np.ndarray) -> list[list[int]]:
    """Finger index of each slot in the grasp's placement (slots renumbered past absent ones)."""
    present = status != ABSENT
    return (np.cumsum(present, axis=1) - 1).tolist()


def _validate(
    points: Any, normals: Any, fingers: Any, finger_ids: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    if not isinstance(fingers, Fingers):
        raise InputError(f"fingers: expected a synth Fingers, got {type(fingers).__name__}")
    try:
        P = np.asarray(points, dtype=float)
        N = np.asarray(normals, dtype=float)
    except (TypeError, ValueError) as e:
        raise InputError("points, normals: expected float arrays of shape (B, k, 3)") from e
    if P.ndim == 2:
        P = P[None]
        if N.ndim == 2:
            N = N[None]
    if P.ndim != 3 or P.shape[-1] != 3 or P.shape[1] == 0:
        raise InputError(f"points: expected shape (B, k, 3) or (k, 3), got {np.shape(points)}")
    if N.shape != P.shape:
        raise InputError(f"normals: expected shape {P.shape} like points, got {np.shape(normals)}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(N))):
        raise InputError("points, normals: contain NaN or infinity")
    norm = np.linalg.norm(N, axis=-1, keepdims=True)
    if np.any(norm <= NORMAL_NORM_TOL):
        raise InputError("normals: some normals have (near) zero length")
    N = N / norm
    B, k, _ = P.shape
    ids = None
    if finger_ids is not None:
        raw = np.asarray(finger_ids)
        if raw.dtype.kind not in "iu":
            raise InputError(f"finger_ids: expected integers, got dtype {raw.dtype}")
        if raw.shape == (k,):
            raw = np.broadcast_to(raw, (B, k))
        if raw.shape != (B, k):
            raise InputError(f"finger_ids: expected shape ({k},) or ({B}, {k}), got {raw.shape}")
        if raw.size and (raw.min() < 0 or raw.max() >= k):
            raise InputError(
                f"finger_ids: expected values in [0, {k}), got {raw.min()}..{raw.max()}"
            )
        ids = np.ascontiguousarray(raw, dtype=np.int64)
    return P, N, ids


_CHECKERS: "weakref.WeakKeyDictionary[Any, FingerChecker]" = weakref.WeakKeyDictionary()


def checker_for(part: Any) -> FingerChecker:
    """The cached :class:`FingerChecker` of ``part``'s mesh (built on first use; a
    :class:`synth.Part` lends it its surface distance).

    The cache is keyed by the mesh object and dropped with it; a mesh edited in place after
    its first check keeps its old BVH, so build a new ``FingerChecker`` after editing.
    """
    mesh = part_mesh(part)
    checker = _CHECKERS.get(mesh)
    if checker is None:
        checker = FingerChecker(mesh, getattr(part, "surface_distance", None))
        _CHECKERS[mesh] = checker
    return checker


def check_fingers(
    part: Any,
    points: np.ndarray,
    normals: np.ndarray,
    fingers: Fingers,
    finger_ids: np.ndarray | None = None,
    depths: bool = True,
) -> FingerCheck:
    """Which of B candidate grasps of ``part`` can physically be made by the fingers.

    Parameters
    ----------
    part : trimesh.Trimesh or object with ``.mesh``
        Watertight, outward face normals. Its FCL model is built once and cached.
    points : (B, k, 3) float
        Contact points on the surface ((k, 3) is one grasp).
    normals : (B, k, 3) float
        Inward unit normals (normalised here).
    fingers : Fingers
    finger_ids : (k,) or (B, k) int, optional
        Finger of each contact, in [0, k); contacts with the same id share one fingertip.
        Default: one finger per contact.
    depths : bool
        Say in ``reasons`` how deep a penetrating tip sinks (a distance query per such tip,
        where the check did not already make it). False for callers that read only the
        mask: the verdicts are the same.

    Returns
    -------
    FingerCheck
        ``mask`` (B,), ``reasons``, per-finger ``status``, ``tip_centers`` and ``approach``;
        ``placement(i)`` gives the :class:`FingerPlacement` of an accepted grasp.

    Examples
    --------
    >>> import trimesh
    >>> box = trimesh.creation.box((2.0, 2.0, 2.0))
    >>> pts = np.array([[[0.0, 0.0, 1.0], [0.1, 0.0, 1.0]]])
    >>> nrm = np.array([[[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]]])
    >>> check_fingers(box, pts, nrm, Fingers(tip_radius=0.1)).reasons[0]
    'fingers 0 and 1 overlap (tips 0.1 apart, less than 2 r = 0.2)'
    """
    return checker_for(part).check(points, normals, fingers, finger_ids, depths)


def tip_sinks(part: Any, centers: np.ndarray, tip_radius: float) -> np.ndarray:
    """How deep each fingertip sinks into the part (its radius less its centre's exact
    distance from the surface; 0 when clear).

    A grasp :func:`check_fingers` accepts has every sink at most ``Fingers.penetration_tol``.

    Parameters
    ----------
    part : trimesh.Trimesh or object with ``.mesh``
    centers : (f, 3) float
        Fingertip centres.
    tip_radius : float

    Returns
    -------
    (f,) float
        In the part's units.

    Examples
    --------
    >>> import trimesh
    >>> tip_sinks(trimesh.creation.box(), np.array([[0.0, 0.0, 0.6]]), 0.1).tolist()
    [0.0]
    """
    checker = checker_for(part)
    try:
        C = np.asarray(centers, dtype=float)
    except (TypeError, ValueError, OverflowError):
        C = np.zeros(0)
    if C.ndim not in (1, 2) or C.shape[-1] != 3 or not np.isfinite(C).all():
        raise InputError(f"centers: expected finite fingertip centres (f, 3), got {centers!r:.80}")
    length_arg(tip_radius, "tip_radius")
    return np.array([checker._penetration(c, float(tip_radius)) for c in C.reshape(-1, 3)])


def finger_placement(
    part: Any,
    points: np.ndarray,
    normals: np.ndarray,
    fingers: Fingers,
    finger_ids: np.ndarray | None = None,
) -> FingerPlacement:
    """Finger geometry of one grasp (points, normals (k, 3)); InputError if it cannot be made."""
    P = np.asarray(points, dtype=float)
    if P.ndim != 2:
        raise InputError(f"points: expected one grasp of shape (k, 3), got {P.shape}")
    ids = None if finger_ids is None else np.asarray(finger_ids)[None]
    res = check_fingers(part, P[None], np.asarray(normals, dtype=float)[None], fingers, ids)
    return res.placement(0)
