"""The PNG of a plan, point fingers and grippers alike: each grasp from the sides that show
its contacts, hidden parts of the hand drawn as hidden, a scale bar in the part's units.

For every grasp shown, the views are chosen among 26 directions (the corners, edges and faces
of a cube around the part, corners first: they show three sides at once) by casting a ray
from each contact toward the viewer (:meth:`synth.Part.first_hits`): the first view
shows the most contacts, the second the most of those the first hides, and a third is added
when contacts are still hidden from both. Each view is rasterised (:mod:`synth.plan.raster`):
the part in grey with its outlines, the hand in colour where it is in front of the part, and
faded with a dashed outline where the part hides it; a contact in view is a filled dot, a
hidden one a hollow dashed ring.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.plan.raster import Depth, View, edges, rasterize, shade, view_along

__all__ = ["Hand", "GraspPicture", "VIEW_DIRECTIONS", "contact_visibility", "choose_views",
           "draw_grasps", "unit_symbol"]

#: Directions a grasp may be seen from: the 26 corners, edges and faces of a cube (unit).
VIEW_DIRECTIONS: NDArray[np.float64] = np.array(
    [d for d in itertools.product((-1.0, 0.0, 1.0), repeat=3) if any(d)])
VIEW_DIRECTIONS = VIEW_DIRECTIONS / np.linalg.norm(VIEW_DIRECTIONS, axis=1, keepdims=True)
#: Preference among views that show as many contacts: corners (three sides at once) from
#: above, corners from below, edges, faces.
_PREFERENCE = (np.count_nonzero(np.abs(VIEW_DIRECTIONS) > 1e-9, axis=1) * 2
               + (VIEW_DIRECTIONS[:, 2] > 0)).astype(float)
#: A contact faces a view when its outward normal is at most about 80 degrees from it.
_FACING = 0.15
#: Pixels across one view.
PIXELS = 360
_PART_RGB = np.array([0.80, 0.82, 0.86])
_EDGE_RGB = np.array([0.18, 0.20, 0.24])
#: How much of a hidden hand shows through the part.
_GHOST = 0.30


@dataclass(frozen=True)
class Hand:
    """The hand of one grasp, as triangles in the part's frame, and its contacts.

    Attributes
    ----------
    triangles : (f, 3, 3) float
    colours : (f, 3) float
        RGB of each triangle.
    points : (k, 3) float
        Contact points.
    normals : (k, 3) float
        Unit normals into the part.
    point_colours : (k, 3) float
    opacity : float
        How much of the part the hand in front of it hides (1: all; a gripper's palm would
        otherwise cover the part it holds).
    """

    triangles: NDArray[np.float64]
    colours: NDArray[np.float64]
    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    point_colours: NDArray[np.float64]
    opacity: float = 1.0


@dataclass(frozen=True)
class GraspPicture:
    """One row of the picture: a grasp's hand, the line of measures above its views, the
    points of the hand every view must show (besides the part), shape (p, 3), and how much
    each of :data:`VIEW_DIRECTIONS` is preferred among views that show as many contacts
    (m,) (None: no preference but the corners'). ``face_on``: a view shows a contact when
    its surface faces the viewer; else when the part does not hide it (a gripper's contacts
    are then seen edge-on in the jaws' profile, the view that shows a pinch best)."""

    hand: Hand
    title: str
    frame: NDArray[np.float64]
    prefer: NDArray[np.float64] | None = None
    face_on: bool = True


def unit_symbol(units: str | None) -> str:
    """The short name of a trimesh length unit (``"decimeters"`` -> ``"dm"``); ``"units"``
    (the mesh file's own numbers) when unknown."""
    if units is None:
        return "units"
    from synth.part.load import UNIT_ALIASES

    short = [k for k, v in UNIT_ALIASES.items() if v == units and k.isascii()]
    return min(short, key=len) if short else units


def contact_visibility(part: Any, points: NDArray[np.float64], normals: NDArray[np.float64],
                       directions: NDArray[np.float64] = VIEW_DIRECTIONS
                       ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Which contacts the part leaves in view from each direction.

    Parameters
    ----------
    part : synth.Part
    points, normals : (k, 3) float
        Contacts and their unit normals into the part.
    directions : (m, 3) float
        Unit directions toward the viewer.

    Returns
    -------
    free : (k, m) bool
        True where a ray from just outside the contact toward the viewer meets no face: the
        contact is not behind the part.
    facing : (k, m) bool
        ``free``, and its surface faces the viewer (not seen edge-on): the views are chosen by
        these.
    """
    P = np.asarray(points, float) - 1e-4 * part.length * np.asarray(normals, float)
    k, m = len(P), len(directions)
    origins = np.repeat(P, m, axis=0)
    dirs = np.tile(np.asarray(directions, float), (k, 1))
    face, _ = part.first_hits(origins, dirs)
    free = (face < 0).reshape(k, m)
    outward = -np.asarray(normals, float) @ np.asarray(directions, float).T
    return free, free & (outward > _FACING)


def choose_views(visible: NDArray[np.bool_], most: int = 3,
                 prefer: NDArray[np.float64] | None = None) -> list[int]:
    """Two or three views (indices of :data:`VIEW_DIRECTIONS`) that show the contacts: the
    first the most, the next the most of those still hidden (then the most, then the
    farthest from the views chosen), a third only if some are hidden from the first two.
    Among views that show as many, the one ``prefer`` (m,) rates highest wins, then a corner.

    Examples
    --------
    >>> seen = np.zeros((2, len(VIEW_DIRECTIONS)), bool)
    >>> seen[0, 0] = seen[1, 25] = True
    >>> choose_views(seen)
    [0, 25]
    """
    count = visible.sum(axis=0)
    want = np.zeros(len(count)) if prefer is None else np.round(prefer, 6)
    first = int(np.lexsort((_PREFERENCE, want, count))[-1])
    chosen = [first]
    hidden = ~visible[:, first]
    while len(chosen) < most and (len(chosen) < 2 or hidden.any()):
        gain = (visible & hidden[:, None]).sum(axis=0)
        apart = -np.max(VIEW_DIRECTIONS @ VIEW_DIRECTIONS[chosen].T, axis=1)
        score = np.lexsort((_PREFERENCE, np.round(apart, 6), want, count, gain))
        nxt = int(next(j for j in score[::-1] if j not in chosen))
        chosen.append(nxt)
        hidden &= ~visible[:, nxt]
    return chosen


def _direction_name(d: NDArray[np.float64]) -> str:
    return "".join(f"{'+' if c > 0 else '-'}{a}" for a, c in zip("xyz", d, strict=True)
                   if abs(c) > 1e-9)


def _image(view: View, part: Any, hand: Hand) -> NDArray[np.float64]:
    """The RGB picture of one view: the part with its outlines, the hand in front of it,
    and the hand the part hides, faded with a dashed outline."""
    mesh = part.mesh
    pn = np.asarray(mesh.face_normals, float)
    tri = np.asarray(mesh.triangles, float)
    if all(b.closed for b in part.bodies):  # a closed surface hides its back faces
        tri = np.where((pn @ view.direction > 0)[:, None, None], tri, np.nan)
    zp = rasterize(view, tri)
    th = hand.triangles
    hn = np.cross(th[:, 1] - th[:, 0], th[:, 2] - th[:, 0]) if len(th) else np.zeros((0, 3))
    hn = hn / np.maximum(np.linalg.norm(hn, axis=1, keepdims=True), 1e-300)
    zh = rasterize(view, th)
    tol = 1e-3 * part.length
    front = zh.covered & (zh.depth > zp.depth - tol)
    ghost = zh.covered & ~front
    img = np.ones((view.size, view.size, 3))
    pc = zp.covered
    img[pc] = _PART_RGB * shade(pn, view)[zp.face[pc], None]
    img[front] = ((1 - hand.opacity) * img[front] + hand.opacity
                  * hand.colours[zh.face[front]] * shade(hn, view)[zh.face[front], None])
    img[ghost] = (1 - _GHOST) * img[ghost] + _GHOST * hand.colours[zh.face[ghost]]
    # outlines of what is seen: the part's and, in front of it, the hand's
    seen_face = np.where(front, zh.face + len(pn), zp.face)
    seen_depth = np.where(front, zh.depth, zp.depth)
    outline = edges(Depth(seen_depth, seen_face), np.vstack([pn, hn]), 0.02 * part.length)
    img[outline] = _EDGE_RGB
    # the dashed outline of the hidden hand
    ring = edges(Depth(np.where(ghost, zh.depth, -np.inf), np.where(ghost, zh.face, -1)),
                 hn, math.inf) & ghost
    yy, xx = np.mgrid[0:view.size, 0:view.size]
    dashed = ring & (((xx + yy) // 5) % 2 == 0)
    img[dashed] = 0.5 * img[dashed] + 0.5 * hand.colours[zh.face[dashed]] * 0.6
    return img


def _bar_length(view: View) -> tuple[float, float]:
    """The scale bar's length, a round number about a fifth of the view, in the part's units
    and in pixels."""
    target = 0.2 * view.width
    exp = math.floor(math.log10(target))
    length = max((m * 10.0 ** exp for m in (1, 2, 5) if m * 10.0 ** exp <= target),
                 default=10.0 ** exp)
    return length, length / view.pixel


def _scale_bar(ax: Any, px: float, label: str, start: NDArray[np.float64]) -> None:
    """The scale bar, ``px`` pixels long, its line's left end at pixel ``start`` of the
    figure, under ``label``, its length and unit (:func:`_corners` places it)."""
    x0, y0 = start
    ax.plot([x0, x0 + px], [y0, y0], color="black", linewidth=3, solid_capstyle="butt")
    ax.plot([x0, x0, np.nan, x0 + px, x0 + px], [y0 - 5, y0 + 5, np.nan, y0 - 5, y0 + 5],
            color="black", linewidth=1)
    # on a light box: a finger drawn across the corner must not hide the length
    ax.text(x0 + px / 2, y0 - 8, label, ha="center", va="bottom", fontsize=8,
            bbox={"facecolor": "white", "alpha": 0.75, "edgecolor": "none", "pad": 1.0})


#: The view's corners, as fractions of it: lower left, upper left, upper right, lower right.
#: For each, where the scale bar's line is (its left end's x, or with a negative x its right
#: end at -x from the right side, and its y), and where the axes' origin is.
_BAR_AT = ((0.05, 0.94), (0.05, 0.12), (-0.05, 0.12), (-0.05, 0.94))
_TRIAD_AT = ((0.12, 0.88), (0.12, 0.12), (0.88, 0.12), (0.88, 0.88))
#: Each corner's rank for the bar and for the axes where corners hide as much: the bar lower
#: left, the axes lower right, as drawn before any corner was chosen.
_BAR_RANK, _TRIAD_RANK = (0, 1, 2, 3), (2, 3, 1, 0)
#: Pixels around the bar and its label (above it) that the choice of corner counts, the width
#: of one of the label's 8-point characters (at most), and the half-width of the axes' box
#: as a fraction of the view (arrows of 0.07, their letters at 1.35 times that).
_BAR_ABOVE, _BAR_BELOW, _BAR_SIDE, _LABEL_CHAR, _TRIAD_REACH = 26, 7, 4, 6.5, 0.11


def _corners(image: NDArray[np.float64], px: float, label: float
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where the scale bar (``px`` pixels long, under a label ``label`` pixels wide) and the
    axes go in a view's ``image`` (size, size, 3; white where nothing is drawn): two distinct
    corners whose boxes, about the bar and its label and about the axes, cover the fewest
    drawn pixels between them (ties: by ``_BAR_RANK`` and ``_TRIAD_RANK``). Returns the bar
    line's left end and the axes' origin (x, y), in pixels of the view."""
    size = image.shape[0]
    drawn: NDArray[np.bool_] = np.asarray((image < 0.98).any(axis=2))

    def covered(x0: float, x1: float, y0: float, y1: float) -> int:
        return int(drawn[max(0, int(y0)):max(0, int(y1)), max(0, int(x0)):max(0, int(x1))].sum())

    half = max(px, label) / 2 + _BAR_SIDE
    bars = []
    for fx, fy in _BAR_AT:
        x0 = fx * size if fx >= 0 else (1 + fx) * size - px
        y0 = fy * size
        mid = x0 + px / 2
        bars.append((np.array([x0, y0]),
                     covered(mid - half, mid + half, y0 - _BAR_ABOVE, y0 + _BAR_BELOW)))
    reach = _TRIAD_REACH * size
    triads = [(np.array([fx, fy]) * size,
               covered(fx * size - reach, fx * size + reach, fy * size - reach,
                       fy * size + reach)) for fx, fy in _TRIAD_AT]
    b, t = min(((b, t) for b in range(4) for t in range(4) if b != t),
               key=lambda bt: (bars[bt[0]][1] + triads[bt[1]][1],
                               _BAR_RANK[bt[0]] + _TRIAD_RANK[bt[1]], _BAR_RANK[bt[0]]))
    return bars[b][0], triads[t][0]


def _axes_triad(ax: Any, view: View, origin: NDArray[np.float64]) -> None:
    """The part's x, y and z axes as seen, from pixel ``origin`` of the figure."""
    for axis, name, colour in zip(np.eye(3), "xyz", ("#c0392b", "#27ae60", "#2e6fd0"),
                                  strict=True):
        d = np.array([axis @ view.right, -(axis @ view.up)]) * 0.07 * view.size
        if np.hypot(*d) > 1e-9:
            ax.annotate("", origin + d, origin, arrowprops={"arrowstyle": "-|>",
                                                            "color": colour, "lw": 1.2})
        ax.text(*(origin + 1.35 * d), name, color=colour, fontsize=8, ha="center",
                va="center")


def _contacts(ax: Any, xy: NDArray[np.float64], colours: NDArray[np.float64],
              seen: NDArray[np.bool_]) -> None:
    """Contacts in view as filled dots; hidden ones as hollow dashed rings."""
    from matplotlib.patches import Circle

    for (x, y), colour, ok in zip(xy, colours, seen, strict=True):
        if ok:
            ax.plot(x, y, "o", color=colour, markersize=7, markeredgecolor="black",
                    markeredgewidth=0.8)
        else:
            ax.add_patch(Circle((x, y), 6.0, fill=False, edgecolor=colour, alpha=0.8,
                                linestyle=(0, (2, 2)), linewidth=1.3))


def _framing(part: Any, frame: NDArray[np.float64], direction: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], float]:
    """The centre of a view from ``direction`` that shows the part and ``frame``, and the
    width it needs."""
    probe = view_along(direction, np.zeros(3), 1.0, 1)
    pts = np.vstack([np.asarray(part.mesh.vertices, float), np.reshape(frame, (-1, 3))])
    s = np.stack([pts @ probe.right, pts @ probe.up], axis=1)
    lo, hi = s.min(axis=0), s.max(axis=0)
    mid = (lo + hi) / 2
    middle = np.asarray(part.mesh.bounds, float).mean(axis=0)
    depth = float(middle @ probe.direction)
    return mid[0] * probe.right + mid[1] * probe.up + depth * probe.direction, float(
        (hi - lo).max())


#: Pixels of the figure: the gap between views, the lines above each row and each view,
#: the heading.
_GAP, _ROW_TITLE, _VIEW_TITLE, _HEAD = 16, 26, 18, 52


def draw_grasps(part: Any, rows: list[GraspPicture], title: str, empty: str = "") -> Any:
    """The figure: one row per grasp, each from the two or three views that show its
    contacts.

    The views are drawn into one image, placed pixel for pixel (``figimage``, so that
    drawing stays fast), with the contacts, scale bars, axes and titles over it on one
    matplotlib axes in the same pixel coordinates.

    Parameters
    ----------
    part : synth.Part
    rows : list of GraspPicture
        Best first; empty: the part alone, with ``empty`` (why there is no grasp).
    title : str
        The figure's title (the mesh, the run).
    empty : str

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    unit = unit_symbol(part.units)
    if rows:
        plans = []
        for row in rows:
            seen, facing = contact_visibility(part, row.hand.points, row.hand.normals)
            plans.append((row, choose_views(facing if row.face_on else seen,
                                            prefer=row.prefer), seen))
    else:  # the part alone, from two opposite corners
        nothing = Hand(np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                       np.zeros((0, 3)), np.zeros((0, 3)))
        plans = [(GraspPicture(nothing, empty, np.zeros((0, 3))), [25, 0],
                  np.zeros((0, 26), bool))]
    # every view centred on what it must show, all at one scale: the widest, with a margin
    frames = [[_framing(part, row.frame, VIEW_DIRECTIONS[j]) for j in views]
              for row, views, _ in plans]
    width = 1.15 * max(w for f in frames for _, w in f)
    cols = max(len(v) for _, v, _ in plans)
    size = PIXELS
    W = cols * size + (cols + 1) * _GAP
    # 9-point characters, capitals and digits included (a no-grasp message is long)
    titles = [_wrap(row.title, W // 9) for row, _, _ in plans]
    heights = [_ROW_TITLE + 14 * t.count("\n") + _VIEW_TITLE + size + _GAP for t in titles]
    scale = unit if part.units else "the file's units (unknown)"
    head = _wrap(title, W // 11) + (  # 10-point characters, capitals and digits included
        f"\nsolid: in view; faded, dashed: behind the part; scale bar in {scale}")
    head_height = _HEAD + 16 * (head.count("\n") - 1)
    H = head_height + sum(heights)
    canvas = np.ones((H, W, 3))
    dpi = 110
    fig = plt.figure(figsize=(W / dpi, H / dpi), dpi=dpi)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.patch.set_alpha(0.0)  # the views, drawn under the axes, show through
    ax.set_zorder(1)
    texts = []
    for r, (row, views, seen) in enumerate(plans):
        top = head_height + sum(heights[:r])
        lines = titles[r].count("\n")
        texts.append((W / 2, top + (_ROW_TITLE + 14 * lines) / 2, titles[r], 9))
        for c, j in enumerate(views):
            at = np.array([_GAP + c * (size + _GAP),
                           top + _ROW_TITLE + 14 * lines + _VIEW_TITLE])
            view = view_along(VIEW_DIRECTIONS[j], frames[r][c][0], width, size)
            image = _image(view, part, row.hand)
            canvas[at[1]:at[1] + size, at[0]:at[0] + size] = image
            xy, _ = view.project(row.hand.points)
            _contacts(ax, xy + at, row.hand.point_colours, seen[:, j])
            length, px = _bar_length(view)
            label = f"{length:g} {unit}"
            bar, origin = _corners(image, px, _LABEL_CHAR * len(label))
            _scale_bar(ax, px, label, at + bar)
            _axes_triad(ax, view, at + origin)
            count = (f": {int(seen[:, j].sum())} of {len(seen)} contacts in view"
                     if len(seen) else "")
            texts.append((at[0] + size / 2, at[1] - _VIEW_TITLE / 2,
                          f"from {_direction_name(VIEW_DIRECTIONS[j])}{count}", 8))
    fig.figimage(canvas, origin="upper", zorder=0)  # pixel for pixel: no resampling
    for x, y, text, font in texts:
        ax.text(x, y, text, ha="center", va="center", fontsize=font)
    ax.text(W / 2, head_height / 2, head, ha="center", va="center", fontsize=10)
    ax.set_xlim(0, W)
    ax.set_ylim(H, 0)
    ax.set_axis_off()
    return fig


def _wrap(text: str, width: int = 90) -> str:
    """``text`` in lines of at most ``width`` characters (its own line breaks kept)."""
    import textwrap

    return "\n".join(line for part in text.split("\n")
                     for line in textwrap.wrap(part, width, break_on_hyphens=False))
