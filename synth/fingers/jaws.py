"""Closing a parallel-jaw gripper on a part: where its pads land, and the contacts they make.

In the gripper frame (approach +z, closing along x) each pad is a rectangle of the plane
perpendicular to x: the +x pad spans ``y`` in ``pad_y +- width / 2`` and ``z`` in
``pad_z + rise +- height / 2``, and the -x pad is its half-turn about z. Closing from the open
width ``W``, the +x pad moving along -x first touches the part where the part reaches furthest
along +x inside the pad's prism (the rectangle swept along x) between the open pads
(``x <= W / 2``; what lies beyond an open pad is behind it, where the collision check finds
the finger in the part); the -x pad where it reaches furthest along -x (``x >= -W / 2``).
So a pad can close on a wall with more of the part behind the other pad, such as a mug's rim.
That extreme is exact on a triangle mesh: it is the largest ``x`` among

* the mesh vertices inside the rectangle,
* the points where mesh edges cross the rectangle's four sides, and
* the points where the rectangle's four corner lines (parallel to x) pierce triangles.

The jaws close symmetrically about the hand, so the pose is moved along its x axis until both
pads touch at once (the arm places the hand; the part does not move): the grasp width is the
distance between the two extremes. A pad lying flat on a face touches a patch (every candidate
within ``touch_tol`` of the extreme): the contact is the centre of the patch's bounding box
when that lies on the touched surface, else (a patch of several pieces, such as two ridges)
the touching point nearest to it; its normal is the pad's. At a part's edge or vertex pressed
into the pad the normal is the pad's too. A pad pressed on an edge or ridge of the part that
crosses its rectangle (a tessellated cylinder's edge, a mug's rim) touches a segment whose
middle lies inside the rectangle and on the part: that is a contact, although its candidate
points lie on the rim. A pad whose touch lies only on the rim of its rectangle (the pad's own
edge on a slope, as when the pads rest tilted on a curved part) makes a contact with the
part's normal there: on a face (the triangles under the contact within 1 degree of one
plane), the face's; where a rim side crosses an edge of the part (two planes), the normal
perpendicular to both the rim and the edge, which lies between the two faces' normals when
the part peaks along the rim on that edge. The touch must be one piece, and the part must fall
away from the rim into the rectangle (else it rises behind the open pad: the pad is buried in
a slope). A pad touching with its rim in two places (across a groove), buried in a slope, or
at a pad's corner on an edge or on a vertex of the part (no single normal) makes no contact:
such poses are reported as ``EDGE_TOUCH`` and dropped. A
Robotiq pad rises as the jaws close (``finger_z``): its rectangle is placed at the rise of the
width found, and the search is repeated until the width no longer changes (three rounds at
most). Poses are processed in chunks, every pose of a chunk at once in numpy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from synth.fingers.gripper import Gripper

__all__ = ["JawContacts", "close_jaws", "pad_touch", "LANDED", "MISSES", "TOO_WIDE",
           "EDGE_TOUCH", "JAW_STATUS"]

LANDED, MISSES, TOO_WIDE, EDGE_TOUCH = 0, 1, 2, 3
#: Words for :attr:`JawContacts.status`.
JAW_STATUS: dict[int, str] = {LANDED: "landed", MISSES: "a pad misses the part",
                              TOO_WIDE: "wider than the opening",
                              EDGE_TOUCH: "a pad touches with its rim where it cannot "
                                          "rest (in two places, buried in a slope, or "
                                          "on an edge or vertex at no single normal)"}
#: A touched face counts as parallel to the pad when its normal is this close to x (1 degree).
_PARALLEL_COS = float(np.cos(np.radians(1.0)))
#: A pad touching a concave surface on two opposite sides of its rectangle rests on it (a
#: contact with the pad's normal) when the surface under its middle lies at most this
#: fraction of half the span behind the pad: the groove's sides rise at most 1 in 4 on
#: average (27 degrees at the rims of a circular groove).
GROOVE_RISE: float = 0.25
#: Poses per chunk times faces: a chunk's face centres in its poses' frames take about 16
#: bytes times this, and only the triangles near a pad are transformed whole.
_CHUNK_ENTRIES = 400_000


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

    def take(self, rows: NDArray[np.int64]) -> JawContacts:
        """The poses ``rows``."""
        return JawContacts(self.poses[rows], self.width[rows], self.points[rows],
                           self.normals[rows], self.patch[rows], self.status[rows])

    @staticmethod
    def concatenate(parts: list[JawContacts]) -> JawContacts:
        """The poses of several results, in order."""
        return JawContacts(*(np.concatenate([getattr(j, f) for j in parts])
                             for f in ("poses", "width", "points", "normals", "patch",
                                       "status")))


def pad_touch(pose: NDArray[np.float64], normals: NDArray[np.float64]) -> tuple[str, str]:
    """How each pad of a jaw grasp touches: ``"pad"`` when the contact's normal is the pad's
    closing direction (its face on the part, or an edge or vertex of the part pressed into
    it), ``"rim"`` when only the pad's rim rests on a slope (the part's normal).

    Parameters
    ----------
    pose : (4, 4) float
        The gripper's base frame (closing along its x axis).
    normals : (2, 3) float
        The inward normals of the contacts, the +x pad's first.

    Examples
    --------
    >>> pad_touch(np.eye(4), np.array([[-1.0, 0, 0], [0.6, 0.8, 0]]))
    ('pad', 'rim')
    """
    x = np.asarray(pose, float)[:3, 0]
    return tuple("pad" if np.allclose(n, -sign * x, atol=1e-9) else "rim"  # type: ignore
                 for n, sign in zip(np.asarray(normals, float), (1.0, -1.0)))


def _rotate(D: NDArray[np.float64], R: NDArray[np.float64]) -> NDArray[np.float64]:
    """``D @ R`` row by row for ``D`` (..., 3) and rotations ``R`` (..., 3, 3) broadcast
    against it, summed in the order ``einsum`` sums (twice as fast on many small arrays)."""
    out = np.empty(np.broadcast_shapes(D.shape, R.shape[:-1]))
    for j in range(3):
        out[..., j] = D[..., 0] * R[..., 0, j] + D[..., 1] * R[..., 1, j] + D[..., 2] * R[..., 2, j]
    return out


def _lo(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least of the three columns of ``a`` (K, 3) (faster than a reduction over 3)."""
    return np.minimum(np.minimum(a[:, 0], a[:, 1]), a[:, 2])


def _hi(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Largest of the three columns of ``a`` (K, 3)."""
    return np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])


def _heights(Tg: NDArray[np.float64], at: NDArray[np.float64]
             ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Whether each triangle of ``Tg`` (K, 3, 3), in its pad's frame, covers the point ``at``
    (K, 2) of the pad plane ``(y, z)``, and its ``x`` there."""
    p0 = Tg[:, 0, 1:]
    e1, e2 = Tg[:, 1, 1:] - p0, Tg[:, 2, 1:] - p0
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-300
    det = np.where(ok, det, 1.0)
    dy, dz = at[:, 0] - p0[:, 0], at[:, 1] - p0[:, 1]
    u = (dy * e2[:, 1] - dz * e2[:, 0]) / det
    v = (e1[:, 0] * dz - e1[:, 1] * dy) / det
    xc = Tg[:, 0, 0] + u * (Tg[:, 1, 0] - Tg[:, 0, 0]) + v * (Tg[:, 2, 0] - Tg[:, 0, 0])
    with np.errstate(invalid="ignore"):
        return ok & (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9), xc


def _on_top(Tg: NDArray[np.float64], kb: NDArray[np.int64], n: int, at: NDArray[np.float64],
            sign: float, top: NDArray[np.float64], tol: float, touching: NDArray[np.bool_]
            ) -> NDArray[np.bool_]:
    """Whether the point ``at[b]`` (n, 2) of the pad plane, ``(y, z)``, lies on the part where
    it touches pose ``b``'s pad: inside the projection of a ``touching`` triangle (``Tg``,
    ``kb`` as for :func:`_extremes`, ``touching`` (K,)) where that triangle reaches the
    extreme ``top[b]`` (``sign * x``) to within ``tol``."""
    covers, xc = _heights(Tg, at[kb])
    with np.errstate(invalid="ignore"):
        on = touching & covers & (sign * xc >= top[kb] - tol)
    out = np.zeros(n, bool)
    np.logical_or.at(out, kb, on)
    return out


def _surface_at(Tg: NDArray[np.float64], kb: NDArray[np.int64], n: int,
                at: NDArray[np.float64], sign: float, half: float) -> NDArray[np.float64]:
    """The highest ``sign * x`` of the part at the point ``at[b]`` (n, 2) of pose ``b``'s pad
    plane, between the open pads (at most ``half``); -inf where no triangle covers it."""
    covers, xc = _heights(Tg, at[kb])
    with np.errstate(invalid="ignore"):
        h = np.where(covers & (sign * xc <= half), sign * xc, -np.inf)
    out = np.full(n, -np.inf)
    np.maximum.at(out, kb, h)
    return out


def _extremes(Tg: NDArray[np.float64], FNg: NDArray[np.float64], kb: NDArray[np.int64],
              n: int, rect: tuple[float, float, float, float], sign: float, tol: float,
              half: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                         NDArray[np.bool_], NDArray[np.bool_], NDArray[np.float64],
                         NDArray[np.float64]]:
    """For ``n`` poses at once: the largest ``sign * x`` of the mesh inside a pad's prism.

    ``Tg`` (K, 3, 3) are triangles in their pose's gripper frame, ``kb`` (K,) their pose,
    ``FNg`` (K, 3) their outward normals there; ``half`` is half the open width (points with
    ``sign * x`` above it are behind the open pad). Returns per pose the extreme ``x`` between
    the open pads (NaN where the pad misses), the touched patch's centre ``(y, z)`` (n, 2) and
    diagonal (n,), whether the touch is a contact with the pad's normal (n,) (a patch or an
    interior touch), whether it is instead the pad's rim on a face (n,), that face's outward
    normal (n, 3) (NaN where there is none), and the extreme over the whole prism (n,), behind
    the open pad included.
    """
    y0, y1, z0, z1 = rect
    A = Tg
    Bv = np.roll(Tg, -1, axis=1)  # the three edges of every triangle: A[:, i] -> Bv[:, i]
    cands = [A]  # (K, 3, 3): vertices
    for axis, value in ((1, y0), (1, y1), (2, z0), (2, z1)):
        da, db = A[..., axis] - value, Bv[..., axis] - value
        cross = da * db < 0
        t = np.where(cross, da / np.where(cross, da - db, 1.0), np.nan)
        cands.append(A + t[..., None] * (Bv - A))  # NaN where the edge does not cross
    p0 = Tg[:, 0, 1:]
    e1, e2 = Tg[:, 1, 1:] - p0, Tg[:, 2, 1:] - p0
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-300
    det = np.where(ok, det, 1.0)
    corners = []
    for cy, cz in ((y0, z0), (y0, z1), (y1, z0), (y1, z1)):
        dy, dz = cy - p0[:, 0], cz - p0[:, 1]
        u = (dy * e2[:, 1] - dz * e2[:, 0]) / det
        v = (e1[:, 0] * dz - e1[:, 1] * dy) / det
        inside = ok & (u >= 0) & (v >= 0) & (u + v <= 1)
        x = Tg[:, 0, 0] + u * (Tg[:, 1, 0] - Tg[:, 0, 0]) + v * (Tg[:, 2, 0] - Tg[:, 0, 0])
        corners.append(np.stack([np.where(inside, x, np.nan), np.full(len(x), cy),
                                 np.full(len(x), cz)], axis=1))
    P = np.concatenate(cands + [np.stack(corners, axis=1)], axis=1)  # (K, 19, 3)
    eps = 1e-12 * max(1.0, float(np.nanmax(np.abs(Tg))) if Tg.size else 1.0)
    valid = np.isfinite(P[..., 0]) & (P[..., 1] >= y0 - eps) & (P[..., 1] <= y1 + eps) & (
        P[..., 2] >= z0 - eps) & (P[..., 2] <= z1 + eps)
    # the extreme between the open pads; where nothing lies there, the extreme beyond them
    # (the part is wider than the opening, or the open pad is inside it)
    sx = np.where(valid, sign * P[..., 0], -np.inf)
    peak = sx.max(axis=1)  # each triangle's extreme inside the prism, behind the open pad too
    top_all = np.full(n, -np.inf)
    np.maximum.at(top_all, kb, peak)
    valid &= sign * P[..., 0] <= half + eps
    sx = np.where(valid, sx, -np.inf)
    top = np.full(n, -np.inf)
    np.maximum.at(top, kb, sx.max(axis=1))
    touch = valid & (sx >= (top[kb] - tol)[:, None])
    big = np.inf
    lo_y, hi_y = np.full(n, big), np.full(n, -big)
    lo_z, hi_z = np.full(n, big), np.full(n, -big)
    Y = np.where(touch, P[..., 1], np.nan)
    Z = np.where(touch, P[..., 2], np.nan)
    has = touch.any(axis=1)
    np.minimum.at(lo_y, kb[has], np.nanmin(Y[has], axis=1))
    np.maximum.at(hi_y, kb[has], np.nanmax(Y[has], axis=1))
    np.minimum.at(lo_z, kb[has], np.nanmin(Z[has], axis=1))
    np.maximum.at(hi_z, kb[has], np.nanmax(Z[has], axis=1))
    interior = touch & (P[..., 1] > y0 + tol) & (P[..., 1] < y1 - tol) & (P[..., 2] > z0 + tol) \
        & (P[..., 2] < z1 - tol)
    facing = (sign * FNg[:, 0] >= _PARALLEL_COS) & has
    good = np.zeros(n, bool)
    np.logical_or.at(good, kb, interior.any(axis=1) | facing)
    hit = np.isfinite(top)
    x = np.where(hit, sign * top, np.nan)
    with np.errstate(invalid="ignore"):  # inf - inf where a pad misses: NaN, unused
        centre = np.stack([(lo_y + hi_y) / 2, (lo_z + hi_z) / 2], axis=1)
        diag = np.hypot(hi_y - lo_y, hi_z - lo_z)
    # the centre must lie on the touched surface: inside a touching triangle's projection,
    # where that triangle reaches the extreme; else (a patch of several pieces) the touching
    # point nearest to it stands for the patch
    c = centre[kb]
    centred = _on_top(Tg, kb, n, centre, sign, top, tol, has)
    # a ridge crossing the pad: the patch's middle is inside the rectangle and on the part
    inner = (centre[:, 0] > y0 + tol) & (centre[:, 0] < y1 - tol) & (centre[:, 1] > z0 + tol) \
        & (centre[:, 1] < z1 - tol)
    good |= centred & inner
    # a pad across a groove (a concave surface, as inside a mug): it touches on two opposite
    # sides of its rectangle only, and the part falls away between them by at most
    # GROOVE_RISE of half the span, so the pad rests on both sides and presses along its own
    # normal; the contact is the part's surface under the middle (``sink`` behind the pad)
    sink = np.zeros(n)
    spans_y = (lo_y <= y0 + tol) & (hi_y >= y1 - tol)
    spans_z = (lo_z <= z0 + tol) & (hi_z >= z1 - tol)
    across = hit & ~good & ~centred & (spans_y | spans_z)
    if across.any():
        with np.errstate(invalid="ignore"):
            depth = top - _surface_at(Tg, kb, n, centre, sign, half + eps)
            span = np.where(spans_y, y1 - y0, z1 - z0)
            groove = across & (depth <= GROOVE_RISE * span / 2)
        good |= groove
        centred |= groove
        sink = np.where(groove, depth, 0.0)
    off = has & ~centred[kb]
    if off.any():
        d2 = np.where(touch, (P[..., 1] - c[:, None, 0]) ** 2 + (P[..., 2] - c[:, None, 1]) ** 2,
                      np.inf)
        rows = np.flatnonzero(off)
        near = d2[rows].argmin(axis=1)
        dist = d2[rows, near]
        best = np.full(n, np.inf)
        np.minimum.at(best, kb[rows], dist)
        first = rows[dist == best[kb[rows]]]
        _, pick = np.unique(kb[first], return_index=True)
        sel = first[pick]
        centre[kb[sel]] = P[sel, d2[sel].argmin(axis=1), 1:]
    # a pad touching with its rim only (every touching point within ``tol`` of the rectangle's
    # border, so the contact point chosen above lies on the rim): the triangles under the
    # contact, at the extreme, give its normal when they lie within 1 degree of one plane
    # facing the pad (the rim on a face); else the rim meets an edge of the part
    rim = hit & ~good
    face_n = np.full((n, 3), np.nan)
    rows = np.flatnonzero(rim[kb] & ok)
    c = centre[kb[rows]]
    q0, f1, f2, d = p0[rows], e1[rows], e2[rows], det[rows]
    dy, dz = c[:, 0] - q0[:, 0], c[:, 1] - q0[:, 1]
    u = (dy * f2[:, 1] - dz * f2[:, 0]) / d
    v = (f1[:, 0] * dz - f1[:, 1] * dy) / d
    T = Tg[rows, :, 0]
    xc = T[:, 0] + u * (T[:, 1] - T[:, 0]) + v * (T[:, 2] - T[:, 0])
    under = (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9) & (
        np.abs(sign * xc - top[kb[rows]]) <= tol)  # at the extreme, not behind it
    rows = rows[under]
    _, pick = np.unique(kb[rows], return_index=True)
    face_n[kb[rows[pick]]] = FNg[rows[pick]]
    dot1 = np.einsum("ij,ij->i", FNg[rows], face_n[kb[rows]])
    agree = np.full(n, np.inf)
    np.minimum.at(agree, kb[rows], dot1)
    flat = agree >= _PARALLEL_COS
    # the rim across an edge of the part (the triangles under the contact in two planes):
    # the contact normal is perpendicular to the rim and to the edge, the combination
    # a n1 + b n2 of the planes' normals with no component along the rim; it lies between
    # them (a, b >= 0) when the part's extreme along the rim is on that edge
    other = rows[dot1 <= agree[kb[rows]]]
    _, pick = np.unique(kb[other], return_index=True)
    n2 = np.full((n, 3), np.nan)
    n2[kb[other[pick]]] = FNg[other[pick]]
    dot2 = np.einsum("ij,ij->i", FNg[rows], n2[kb[rows]])
    two = np.full(n, np.inf)
    np.minimum.at(two, kb[rows], np.maximum(dot1, dot2))
    side_y = (np.abs(centre[:, 0] - y0) <= tol) | (np.abs(centre[:, 0] - y1) <= tol)
    side_z = (np.abs(centre[:, 1] - z0) <= tol) | (np.abs(centre[:, 1] - z1) <= tol)
    r = np.zeros((n, 3))
    r[:, 2] = side_y  # a rim side at fixed y runs along z, and one at fixed z along y
    r[:, 1] = side_z
    a, b = np.einsum("ij,ij->i", n2, r), -np.einsum("ij,ij->i", face_n, r)
    m = (a[:, None] * face_n + b[:, None] * n2) * np.sign(a + b)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        m /= np.linalg.norm(m, axis=1, keepdims=True)
    edge = ~flat & (two >= _PARALLEL_COS) & (side_y ^ side_z) & (a * b >= 0) & (
        np.abs(a) + np.abs(b) > 0)
    # no triangle under the contact rises behind the open pad inside the rectangle: else the
    # rim is only the highest point left between the open pads of a slope the pad is buried
    # in, not one it rests on
    buried = np.zeros(n, bool)
    np.logical_or.at(buried, kb[rows], peak[rows] > top[kb[rows]] + tol)
    face_n = np.where(edge[:, None], m, face_n)
    # one touching piece only (its middle lies on the part): a pad touching in two places,
    # such as across a groove, has no single contact
    rim &= centred & (flat | edge) & ~buried & (sign * face_n[:, 0] > 0)  # False where NaN
    return x, centre, np.where(hit, diag, 0.0), good & hit, rim, face_n, np.where(
        np.isfinite(top_all), sign * top_all, np.nan), np.stack([lo_y, hi_y, lo_z, hi_z],
                                                                axis=1), has, sink


def _aligned(box_a: NDArray[np.float64], box_b: NDArray[np.float64], at_b: NDArray[np.float64],
             patch_b: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Where a pad lying flat on the part (its touched patch's bounding box ``box_a``, (n, 4):
    ``y`` and ``z`` ranges in the pad plane) presses straight across from the other pad:
    the middle of the two patches' overlap when the other also lies flat (``patch_b``, its box
    ``box_b``), else the point of ``box_a`` nearest the other's contact ``at_b`` (n, 2). A
    patch transmits its normal force anywhere within it, so the squeeze passes along the
    closing axis where the pads' contacts face each other."""
    lo = np.stack([box_a[:, 0], box_a[:, 2]], axis=1)
    hi = np.stack([box_a[:, 1], box_a[:, 3]], axis=1)
    both_lo = np.maximum(lo, np.stack([box_b[:, 0], box_b[:, 2]], axis=1))
    both_hi = np.minimum(hi, np.stack([box_b[:, 1], box_b[:, 3]], axis=1))
    with np.errstate(invalid="ignore"):
        overlap = patch_b[:, None] & (both_lo <= both_hi)
        target = np.where(overlap, 0.5 * (both_lo + both_hi), at_b)
    return np.clip(target, lo, hi)


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
    reach = abs(py) + pw / 2
    plus_rect = (py - pw / 2, py + pw / 2, -ph / 2, ph / 2)
    minus_rect = (-py - pw / 2, -py + pw / 2, -ph / 2, ph / 2)  # the half-turn of the +x pad
    tri = Vp[F]
    centre = tri.mean(axis=1)
    # bounding radii, widened by far more than the rounding of the coordinates in the test
    span = float(np.abs(Vp).max(initial=0.0)) + float(np.abs(poses[:, :3, 3]).max(initial=0.0))
    radius = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1) * (1 + 1e-9) + 1e-9 * span
    y_lim = reach + radius
    z_lim = (pz + float(gripper.finger_z[:, 1].min()) - ph / 2 - radius,
             pz + float(gripper.finger_z[:, 1].max()) + ph / 2 + radius)
    step = max(1, _CHUNK_ENTRIES // max(1, len(F)))
    for lo in range(0, B, step):
        idx = np.arange(lo, min(lo + step, B))
        n = len(idx)
        R, t = poses[idx, :3, :3], poses[idx, :3, 3]
        # the (pose, triangle) pairs whose bounding sphere meets a pad's slab (|y| <= reach,
        # z within the pads' travel): the only triangles a pad can touch
        Ryz = R[:, :, 1:]
        yz = (centre @ Ryz.transpose(1, 0, 2).reshape(3, 2 * n)).reshape(-1, n, 2) - np.einsum(
            "ni,nij->nj", t, Ryz)  # (f, n, 2), one matrix product for the chunk
        near = (np.abs(yz[..., 0]) <= y_lim[:, None]) & (yz[..., 1] >= z_lim[0][:, None]) & (
            yz[..., 1] <= z_lim[1][:, None])
        kb0, kf0 = np.nonzero(near.T)
        Rk = R[kb0]
        Tp = _rotate(tri[kf0] - t[kb0][:, None], Rk[:, None])  # (K, 3, 3)
        ty, tz, tx = Tp[..., 1], Tp[..., 2], Tp[..., 0]
        ylo, yhi, zlo, zhi = _lo(ty), _hi(ty), _lo(tz), _hi(tz)
        xlo, xhi = _lo(tx), _hi(tx)
        w = np.full(n, gripper.max_opening)
        half = 0.5 * gripper.max_opening
        for _ in range(rounds):
            zc = pz + gripper.rise(w)
            zk = zc[kb0]
            near = (yhi >= -reach) & (ylo <= reach) & (zhi >= zk - ph / 2) & (zlo <= zk + ph / 2)
            found, pads = [], []
            for rect, sign, far in ((plus_rect, 1.0, xhi), (minus_rect, -1.0, -xlo)):
                # a vertex inside the pad's rectangle bounds the extreme from below: triangles
                # lying wholly behind it cannot reach it
                # (every vertex inside it is a corner of a triangle of the pairs)
                inside = (ty >= rect[0]) & (ty <= rect[1]) & (
                    np.abs(tz - zk[:, None]) <= ph / 2) & (sign * tx <= half)
                floor = np.full(n, -np.inf)
                np.maximum.at(floor, kb0, _hi(np.where(inside, sign * tx, -np.inf)))
                sel = np.flatnonzero(near & (far >= floor[kb0] - touch_tol))
                kb = kb0[sel]
                Tg = Tp[sel] - np.stack([np.zeros(len(kb)), np.zeros(len(kb)), zc[kb]],
                                        axis=1)[:, None, :]  # pad centre at z = 0
                found.append(_extremes(Tg, _rotate(FN[kf0[sel]], Rk[sel]), kb, n, rect, sign,
                                       touch_tol, half))
                pads.append((Tg, kb))
            ((xp, cp, dp, gp, rp, np_, xp_all, bp, hp, sp),
             (xm, cm, dm, gm, rm, nm, xm_all, bm, hm, sm)) = found
            # pads that see no gap between them (both inside a part wider than the opening):
            # the width is the part's, over the whole prisms
            inside = (xp - xm <= 0) & (xp_all - xm_all > 0)
            xp, xm = np.where(inside, xp_all, xp), np.where(inside, xm_all, xm)
            gp, gm, rp, rm = gp & ~inside, gm & ~inside, rp & ~inside, rm & ~inside
            new_w = xp - xm
            done = ~np.isfinite(new_w) | (np.abs(new_w - w) <= touch_tol)
            w = np.where(np.isfinite(new_w), new_w, w)
            if done.all():
                break
        hit = np.isfinite(xp) & np.isfinite(xm) & (xp - xm > 0)
        wide = hit & (w > gripper.max_opening)
        edge = hit & ~wide & ~((gp | rp) & (gm | rm))
        ok = hit & ~wide & ~edge
        # a pad lying flat presses where the other pad's contact faces it (on its patch)
        flat_p, flat_m = ok & gp & (sp == 0), ok & gm & (sm == 0)
        targets = [np.where(flat[:, None], _aligned(box, other_box, at, other), mid)
                   for flat, mid, box, at, other, other_box in (
                       (flat_p, cp, bp, cm, flat_m, bm), (flat_m, cm, bm, cp, flat_p, bp))]
        for mid, want, sign, (Tg, kb), x, has in ((cp, targets[0], 1.0, pads[0], xp, hp),
                                                 (cm, targets[1], -1.0, pads[1], xm, hm)):
            moved = np.any(want != mid, axis=1)
            if moved.any():
                good_at = moved & _on_top(Tg, kb, n, want, sign, sign * x, touch_tol, has)
                mid[good_at] = want[good_at]
        width[idx[hit]] = w[hit]
        status[idx[wide]] = TOO_WIDE
        status[idx[edge]] = EDGE_TOUCH
        width[idx[edge]] = np.nan
        status[idx[ok]] = LANDED
        shift = 0.5 * (xp + xm)
        out_pose[idx[ok], :3, 3] = t[ok] + R[ok, :, 0] * shift[ok, None]
        cg = np.stack([np.column_stack([xp - sp, cp[:, 0], cp[:, 1] + zc]),
                       np.column_stack([xm + sm, cm[:, 0], cm[:, 1] + zc])], axis=1)  # (n, 2, 3)
        points[idx[ok]] = (np.einsum("bij,bkj->bki", R, cg) + t[:, None])[ok]
        # the pad's closing direction, or on a rim contact the face's inward normal
        face = -np.einsum("bij,bkj->bki", R, np.stack([np_, nm], axis=1))
        pad = np.stack([-R[:, :, 0], R[:, :, 0]], axis=1)
        on_rim = np.stack([rp & ~gp, rm & ~gm], axis=1)
        normals[idx[ok]] = np.where(on_rim[..., None], face, pad)[ok]
        patch[idx[ok]] = np.column_stack([dp, dm])[ok]
    return JawContacts(out_pose, width, points, normals, patch, status)
