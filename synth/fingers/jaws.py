"""Closing a parallel-jaw gripper on a part: where its pads land, and the contacts they make.

In the gripper frame (approach +z, closing along x) each pad is a rectangle of the plane
perpendicular to x: the +x pad spans ``y`` in ``pad_y +- width / 2`` and ``z`` in
``pad_z + rise +- height / 2``, and the -x pad is its half-turn about z. Closing from the open
width, the +x pad moving along -x first touches the part where the part reaches furthest
along +x inside the pad's prism (the rectangle swept along x); the -x pad where it reaches
furthest along -x. That extreme is exact on a triangle mesh: it is the largest ``x`` among

* the mesh vertices inside the rectangle,
* the points where mesh edges cross the rectangle's four sides, and
* the points where the rectangle's four corner lines (parallel to x) pierce triangles.

The jaws close symmetrically about the hand, so the pose is moved along its x axis until both
pads touch at once (the arm places the hand; the part does not move): the grasp width is the
distance between the two extremes. A pad lying flat on a face touches a patch (every candidate
within ``touch_tol`` of the extreme): the contact is the centre of the patch's bounding box,
and its normal is the pad's. At a part's edge or vertex pressed into the pad the normal is the
pad's too. A pad whose touch lies only on the rim of its rectangle against a face that is not
parallel to it (the pad's own edge digging into a slope) makes no trustworthy contact: such
poses are reported as ``EDGE_TOUCH`` and dropped. A Robotiq pad rises as the jaws close
(``finger_z``): its rectangle is placed at the rise of the width found, and the search is
repeated until the width no longer changes (three rounds at most).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from synth.fingers.gripper import Gripper

__all__ = ["JawContacts", "close_jaws", "LANDED", "MISSES", "TOO_WIDE", "EDGE_TOUCH",
           "JAW_STATUS"]

LANDED, MISSES, TOO_WIDE, EDGE_TOUCH = 0, 1, 2, 3
#: Words for :attr:`JawContacts.status`.
JAW_STATUS: dict[int, str] = {LANDED: "landed", MISSES: "a pad misses the part",
                              TOO_WIDE: "wider than the opening",
                              EDGE_TOUCH: "a pad's rim digs into a slope"}
#: A touched face counts as parallel to the pad when its normal is this close to x (1 degree).
_PARALLEL_COS = float(np.cos(np.radians(1.0)))


@dataclass(frozen=True)
class JawContacts:
    """Where the jaws of B gripper poses land on a part.

    Attributes
    ----------
    poses : (B, 4, 4) float
        The poses moved along their x axis so both pads touch at once (gripper frame to part
        frame).
    width : (B,) float
        Distance between the pads when both touch; NaN where they do not land.
    points : (B, 2, 3) float
        Contact points in the part's frame, the +x pad's first.
    normals : (B, 2, 3) float
        Inward unit normals (the pads' closing directions).
    patch : (B, 2) float
        Diagonal of each contact patch's bounding box in the pad plane (0 at a point contact).
    status : (B,) int
        ``LANDED``, ``MISSES``, ``TOO_WIDE`` or ``EDGE_TOUCH``.
    """

    poses: NDArray[np.float64] = field(repr=False)
    width: NDArray[np.float64] = field(repr=False)
    points: NDArray[np.float64] = field(repr=False)
    normals: NDArray[np.float64] = field(repr=False)
    patch: NDArray[np.float64] = field(repr=False)
    status: NDArray[np.int64]

    @property
    def landed(self) -> NDArray[np.bool_]:
        """Poses whose pads both touch within the opening."""
        return self.status == LANDED


def _extreme(V: NDArray[np.float64], F: NDArray[np.int64], FN: NDArray[np.float64],
             y0: float, y1: float, z0: float, z1: float, sign: float, tol: float
             ) -> tuple[float, NDArray[np.float64], float, bool] | None:
    """Largest ``sign * x`` of the mesh (gripper frame) inside the prism, the patch centre
    (y, z), the patch diagonal, and whether the touch is trustworthy; None if it misses."""
    T = V[F]  # (f, 3, 3)
    ty, tz = T[..., 1], T[..., 2]
    near = (ty.max(1) >= y0) & (ty.min(1) <= y1) & (tz.max(1) >= z0) & (tz.min(1) <= z1)
    if not near.any():
        return None
    T, fn = T[near], FN[near]
    nf = len(T)
    pts = [T.reshape(-1, 3)]  # vertices (filtered below)
    owner = [np.repeat(np.arange(nf), 3)]  # the face each candidate lies on
    A, B = T, np.roll(T, -1, axis=1)  # the three edges of every triangle
    A, B = A.reshape(-1, 3), B.reshape(-1, 3)
    for axis, value in ((1, y0), (1, y1), (2, z0), (2, z1)):
        da, db = A[:, axis] - value, B[:, axis] - value
        cross = (da * db < 0)
        t = da[cross] / (da[cross] - db[cross])
        pts.append(A[cross] + t[:, None] * (B[cross] - A[cross]))
        owner.append(np.flatnonzero(cross) // 3)
    corners = np.array([[y0, z0], [y0, z1], [y1, z0], [y1, z1]])
    # barycentric coordinates of each corner in each triangle's (y, z) projection
    p0, e1, e2 = T[:, 0, 1:], T[:, 1, 1:] - T[:, 0, 1:], T[:, 2, 1:] - T[:, 0, 1:]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-300
    det = np.where(ok, det, 1.0)
    for c in corners:
        d = c - p0
        u = (d[:, 0] * e2[:, 1] - d[:, 1] * e2[:, 0]) / det
        v = (e1[:, 0] * d[:, 1] - e1[:, 1] * d[:, 0]) / det
        inside = ok & (u >= 0) & (v >= 0) & (u + v <= 1)
        x = T[inside, 0, 0] + u[inside] * (T[inside, 1, 0] - T[inside, 0, 0]) + v[inside] * (
            T[inside, 2, 0] - T[inside, 0, 0])
        pts.append(np.column_stack([x, np.full(len(x), c[0]), np.full(len(x), c[1])]))
        owner.append(np.flatnonzero(inside))
    P = np.concatenate(pts)
    K = np.concatenate(owner)
    eps = 1e-12 * max(1.0, float(np.abs(V).max()))
    inside = (P[:, 1] >= y0 - eps) & (P[:, 1] <= y1 + eps) & (P[:, 2] >= z0 - eps) & (
        P[:, 2] <= z1 + eps)
    P, K = P[inside], K[inside]
    if not len(P):
        return None
    sx = sign * P[:, 0]
    top = sx.max()
    touch = sx >= top - tol
    Q = P[touch]
    lo, hi = Q[:, 1:].min(0), Q[:, 1:].max(0)
    # trustworthy: a touching point strictly inside the rectangle (a part vertex or edge
    # pressed into the pad, or a patch), or a touched face parallel to the pad
    interior = (Q[:, 1] > y0 + tol) & (Q[:, 1] < y1 - tol) & (Q[:, 2] > z0 + tol) & (
        Q[:, 2] < z1 - tol)
    facing = sign * fn[:, 0] >= _PARALLEL_COS  # outward normal towards the pad
    good = bool(interior.any() or facing[K[touch]].any())
    return float(sign * top), (lo + hi) / 2.0, float(np.linalg.norm(hi - lo)), good


def close_jaws(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    face_normals: NDArray[np.float64],
    poses: NDArray[np.float64],
    gripper: Gripper,
    touch_tol: float,
) -> JawContacts:
    """Close the jaws of each pose on the mesh; see the module for the rules.

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
    face_normals : (f, 3) float
        Outward unit normals.
    poses : (B, 4, 4) float
        Gripper frame to part frame; only the pose's x position is changed.
    gripper : Gripper
        In the part's unit.
    touch_tol : float
        Distance along x within which pad and part count as touching (a patch).

    Returns
    -------
    JawContacts
    """
    Vp = np.asarray(vertices, float)
    F = np.asarray(faces, np.int64)
    FN = np.asarray(face_normals, float)
    B = len(poses)
    out_pose = np.array(poses, dtype=float, copy=True)
    width = np.full(B, np.nan)
    points = np.full((B, 2, 3), np.nan)
    normals = np.full((B, 2, 3), np.nan)
    patch = np.zeros((B, 2))
    status = np.full(B, MISSES, np.int64)
    (py, pz), (pw, ph) = gripper.pad_center, gripper.pad_size
    rounds = 1 if np.ptp(gripper.finger_z[:, 1]) == 0 else 3  # pads that do not rise: one
    for b in range(B):
        R, t = out_pose[b, :3, :3].copy(), out_pose[b, :3, 3].copy()
        V = (Vp - t) @ R  # the part in the gripper frame
        Fg = FN @ R
        w = gripper.max_opening
        hit = None
        for _ in range(rounds):
            zc = pz + float(gripper.rise(w))
            plus = _extreme(V, F, Fg, py - pw / 2, py + pw / 2, zc - ph / 2, zc + ph / 2,
                            1.0, touch_tol)
            # the -x pad is the half-turn of the +x one: y mirrored
            minus = _extreme(V, F, Fg, -py - pw / 2, -py + pw / 2, zc - ph / 2, zc + ph / 2,
                             -1.0, touch_tol)
            if plus is None or minus is None:
                hit = None
                break
            new_w = plus[0] - minus[0]
            hit = (plus, minus, zc)
            if abs(new_w - w) <= touch_tol:
                break
            w = new_w
        if hit is None:
            continue
        plus, minus, _ = hit
        w = plus[0] - minus[0]
        if w <= 0:
            continue
        if w > gripper.max_opening:
            status[b] = TOO_WIDE
            width[b] = w
            continue
        if not (plus[3] and minus[3]):
            status[b] = EDGE_TOUCH
            continue
        shift = 0.5 * (plus[0] + minus[0])
        out_pose[b, :3, 3] = t + R[:, 0] * shift
        cg = np.array([[plus[0], *plus[1]], [minus[0], *minus[1]]])
        points[b] = cg @ R.T + t
        normals[b] = np.array([-R[:, 0], R[:, 0]])
        patch[b] = plus[2], minus[2]
        width[b] = w
        status[b] = LANDED
    return JawContacts(out_pose, width, points, normals, patch, status)
