"""A small software renderer for the pictures of a plan: triangles into a depth buffer.

matplotlib's 3-D axes sort whole polygons by their centres, so a finger behind a part is
drawn over it (it seems to pierce the part) and a large face hides what lies in front of
it. The pictures instead rasterise every triangle into a z-buffer (an orthographic view,
numpy only), so each pixel shows the surface nearest the viewer, and a hand behind the part
can be drawn as hidden.

A :class:`View` looks along one direction at a square of the scene; :func:`rasterize` gives
each pixel's nearest depth and triangle; :func:`shade` turns a buffer into grey or coloured
pixels lit from the viewer's upper left, and :func:`edges` finds the outlines (silhouettes,
creases, steps in depth) that make flat-shaded faces readable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["View", "view_along", "Depth", "rasterize", "shade", "edges"]

#: Pixels of rows handled at once (memory: about 100 bytes each).
_CHUNK = 2_000_000
#: Faces meeting at more than this angle (cosine) show an edge between them.
_CREASE_COS = np.cos(np.radians(25.0))


@dataclass(frozen=True)
class View:
    """An orthographic camera.

    Attributes
    ----------
    direction : (3,) float
        Unit vector from the scene toward the viewer.
    right, up : (3,) float
        Unit screen axes (right-handed with ``direction``).
    center : (3,) float
        The scene point at the middle of the picture.
    width : float
        Scene units across the picture.
    size : int
        Pixels across (the picture is square).
    """

    direction: NDArray[np.float64]
    right: NDArray[np.float64]
    up: NDArray[np.float64]
    center: NDArray[np.float64]
    width: float
    size: int

    @property
    def pixel(self) -> float:
        """Scene units per pixel."""
        return self.width / self.size

    def project(self, points: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Pixel coordinates (n, 2) (x to the right, y down, from the top-left corner) and
        depth (n,) (larger is nearer the viewer) of scene points (n, 3)."""
        q = np.asarray(points, float) - self.center
        x = q @ self.right / self.pixel + self.size / 2
        y = self.size / 2 - q @ self.up / self.pixel
        return np.stack([x, y], axis=-1), q @ self.direction


def view_along(direction: NDArray[np.float64], center: NDArray[np.float64], width: float,
               size: int) -> View:
    """The view from ``direction`` (toward the viewer), z up on screen where it can be.

    Examples
    --------
    >>> v = view_along(np.array([1.0, 1.0, 1.0]), np.zeros(3), 2.0, 100)
    >>> v.project(np.zeros((1, 3)))[0]
    array([[50., 50.]])
    """
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    world_up = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.99 else np.array([0.0, 1.0, 0.0])
    right = np.cross(world_up, d)
    right /= np.linalg.norm(right)
    return View(d, right, np.cross(d, right), np.asarray(center, float), float(width),
                int(size))


@dataclass(frozen=True)
class Depth:
    """What a view sees of a set of triangles.

    Attributes
    ----------
    depth : (size, size) float
        Depth of the nearest triangle at each pixel's centre; ``-inf`` where none covers it.
    face : (size, size) int
        Index of that triangle; -1 where none.
    """

    depth: NDArray[np.float64]
    face: NDArray[np.int64]

    @property
    def covered(self) -> NDArray[np.bool_]:
        """Pixels some triangle covers."""
        return self.face >= 0


def rasterize(view: View, triangles: NDArray[np.float64]) -> Depth:
    """The nearest triangle at every pixel of ``view`` (a z-buffer).

    Each triangle is cut into the rows of pixels it crosses, each row into the pixels whose
    centres lie inside it (no bounding-box waste), and its depth there is read off its plane.
    Triangles with a non-finite corner (a back face left out by the caller) are skipped.

    Parameters
    ----------
    view : View
    triangles : (f, 3, 3) float

    Returns
    -------
    Depth
    """
    n = view.size
    depth = np.full(n * n, -np.inf)
    face = np.full(n * n, -1, np.int64)
    tri = np.asarray(triangles, float)
    if len(tri):
        xy, z = view.project(tri.reshape(-1, 3))
        xy, z = xy.reshape(-1, 3, 2), z.reshape(-1, 3)
        P = xy  # corners a, b, c; edge i runs from corner i + 1 to i + 2, opposite corner i
        Q0, Q1 = np.roll(P, -1, axis=1), np.roll(P, -2, axis=1)
        d = Q1 - Q0  # (f, 3, 2)
        area = d[:, 0, 0] * (P[:, 0, 1] - Q0[:, 0, 1]) - d[:, 0, 1] * (P[:, 0, 0] - Q0[:, 0, 0])
        ok = np.isfinite(xy).all(axis=(1, 2)) & (np.abs(area) > 1e-12)
        with np.errstate(invalid="ignore"):
            y0 = np.ceil(xy[..., 1].min(axis=1) - 0.5).clip(0, n)
            y1 = np.floor(xy[..., 1].max(axis=1) - 0.5).clip(-1, n - 1)
        ok &= y1 >= y0
        ids = np.flatnonzero(ok)
        if len(ids):
            _fill(depth, face, n, ids, y0[ids].astype(np.int64), y1[ids].astype(np.int64),
                  Q0[ids], d[ids], area[ids], z[ids])
    return Depth(depth.reshape(n, n), face.reshape(n, n))


def _fill(depth: NDArray[np.float64], face: NDArray[np.int64], n: int, ids: NDArray[np.int64],
          y0: NDArray[np.int64], y1: NDArray[np.int64], Q0: NDArray[np.float64],
          d: NDArray[np.float64], area: NDArray[np.float64], z: NDArray[np.float64]) -> None:
    """Draw triangles ``ids`` row by row into the buffers, keeping the nearest."""
    # a pixel centre (x, y) is inside when every edge function over the area is >= 0:
    # k x + m >= 0 with k = -dy / area and m = (dx (y - Q0y) + dy Q0x) / area
    k = -d[..., 1] / area[:, None]
    # the plane of depths: z = alpha x + beta y + gamma (barycentric weights are the edge
    # functions over the area, linear in x and y)
    alpha = (z * k).sum(axis=1)
    beta = (z * d[..., 0] / area[:, None]).sum(axis=1)
    gamma = (z * (d[..., 1] * Q0[..., 0] - d[..., 0] * Q0[..., 1]) / area[:, None]).sum(axis=1)
    rows = y1 - y0 + 1
    for start in range(0, len(ids), _CHUNK // max(n, 1)):
        sl = slice(start, start + _CHUNK // max(n, 1))
        r = rows[sl]
        t = np.repeat(np.arange(sl.start, sl.start + len(r)), r)  # local triangle of each row
        y = y0[t] + np.arange(len(t)) - np.repeat(np.cumsum(r) - r, r)
        cy = y + 0.5
        m = (d[t, :, 0] * (cy[:, None] - Q0[t, :, 1]) + d[t, :, 1] * Q0[t, :, 0]) / area[t, None]
        kt = k[t]
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -m / kt
        lo = np.where(kt > 0, bound, -np.inf).max(axis=1)
        hi = np.where(kt < 0, bound, np.inf).min(axis=1)
        flat = (kt == 0) & (m < 0)  # an edge along the row, the row outside it
        lo[flat.any(axis=1)] = np.inf
        x0 = np.ceil(np.maximum(lo, 0.5) - 0.5).astype(np.int64)
        x1 = np.floor(np.minimum(hi, n - 0.5) - 0.5).astype(np.int64)
        count = np.maximum(x1 - x0 + 1, 0)
        tp = np.repeat(t, count)
        x = np.repeat(x0, count) + np.arange(int(count.sum())) - np.repeat(
            np.cumsum(count) - count, count)
        yp = np.repeat(y, count)
        dp = alpha[tp] * (x + 0.5) + beta[tp] * (yp + 0.5) + gamma[tp]
        lin = yp * n + x
        np.maximum.at(depth, lin, dp)
        won = dp >= depth[lin]
        face[lin[won]] = ids[tp[won]]


def shade(normals: NDArray[np.float64], view: View) -> NDArray[np.float64]:
    """Brightness in [0.35, 1] of faces with these unit normals (f, 3), lit from the viewer's
    upper left; two-sided, so an open surface seen from behind is lit too."""
    light = view.direction + 0.6 * view.up - 0.4 * view.right
    light = light / np.linalg.norm(light)
    return 0.35 + 0.65 * np.abs(np.asarray(normals, float) @ light)


def edges(depth: Depth, normals: NDArray[np.float64], step: float) -> NDArray[np.bool_]:
    """Pixels on an outline: the silhouette, a crease (neighbouring faces more than 25
    degrees apart) or a step in depth larger than ``step`` (scene units).

    Parameters
    ----------
    depth : Depth
    normals : (f, 3) float
        Unit normals of the triangles the buffer indexes.
    step : float

    Returns
    -------
    (size, size) bool
    """
    f, z = depth.face, depth.depth
    covered = f >= 0
    n = np.zeros(f.shape + (3,))
    n[covered] = np.asarray(normals, float)[f[covered]]
    out = np.zeros(f.shape, bool)
    for axis in (0, 1):
        a = [slice(None), slice(None)]
        b = [slice(None), slice(None)]
        a[axis], b[axis] = slice(1, None), slice(None, -1)
        ca, cb = covered[tuple(a)], covered[tuple(b)]
        both = ca & cb
        with np.errstate(invalid="ignore"):
            crease = np.abs((n[tuple(a)] * n[tuple(b)]).sum(axis=-1)) < _CREASE_COS
            jump = np.abs(z[tuple(a)] - z[tuple(b)]) > step
        hit = (ca != cb) | (both & (crease | jump))
        out[tuple(a)] |= hit
        out[tuple(b)] |= hit & cb
    return out
