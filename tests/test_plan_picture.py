"""The pictures of a plan (:mod:`synth.plan.raster`, :mod:`synth.plan.picture`): a z-buffer
that agrees with a brute-force one, views that show every contact some view can show, and a
hand behind the part drawn hidden, never over it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.part import load_part
from synth.plan.picture import (
    VIEW_DIRECTIONS,
    GraspPicture,
    Hand,
    _corners,
    _image,
    choose_views,
    contact_visibility,
    draw_grasps,
    unit_symbol,
)
from synth.plan.raster import rasterize, view_along

MESHES = Path(__file__).resolve().parents[1] / "meshes"


@pytest.fixture(scope="module")
def cube():
    return load_part(MESHES / "cube.stl", units="mm")


def _brute(view, tri):
    """Depth of the nearest triangle at every pixel centre, triangle by triangle."""
    yy, xx = np.mgrid[0:view.size, 0:view.size] + 0.5
    xy, z = view.project(tri.reshape(-1, 3))
    best = np.full((view.size, view.size), -np.inf)
    for (a, b, c), (za, zb, zc) in zip(xy.reshape(-1, 3, 2), z.reshape(-1, 3), strict=True):
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(area) < 1e-12:
            continue
        w0 = ((c[0] - b[0]) * (yy - b[1]) - (c[1] - b[1]) * (xx - b[0])) / area
        w1 = ((a[0] - c[0]) * (yy - c[1]) - (a[1] - c[1]) * (xx - c[0])) / area
        w2 = 1 - w0 - w1
        inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        best = np.where(inside, np.maximum(best, w0 * za + w1 * zb + w2 * zc), best)
    return best


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_z_buffer_agrees_with_brute_force(seed):
    rng = np.random.default_rng(seed)
    tri = rng.normal(size=(150, 3, 3))
    tri[:20] *= 4.0  # large triangles, some running off the picture
    view = view_along(rng.normal(size=3), rng.normal(size=3) * 0.2, 5.0, 64)
    got = rasterize(view, tri)
    want = _brute(view, tri)
    assert np.array_equal(np.isfinite(got.depth), np.isfinite(want))
    both = np.isfinite(want)
    assert np.allclose(got.depth[both], want[both], atol=1e-9)
    assert (got.face[both] >= 0).all() and (got.face[~both] == -1).all()
    # the face recorded at a pixel gives that depth there
    xy, z = view.project(tri.reshape(-1, 3))
    xy, z = xy.reshape(-1, 3, 2), z.reshape(-1, 3)
    py, px = np.nonzero(both)
    f = got.face[both]
    a, b, c = xy[f, 0], xy[f, 1], xy[f, 2]
    p = np.stack([px + 0.5, py + 0.5], axis=1)

    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]

    area = cross(b - a, c - a)
    w0, w1 = cross(c - b, p - b) / area, cross(a - c, p - c) / area
    at = w0 * z[f, 0] + w1 * z[f, 1] + (1 - w0 - w1) * z[f, 2]
    assert np.allclose(at, got.depth[both], atol=1e-9)
    assert len(np.unique(f)) > 10


def test_views_show_every_contact_some_view_shows():
    rng = np.random.default_rng(3)
    for _ in range(200):
        seen = rng.random((int(rng.integers(1, 9)), len(VIEW_DIRECTIONS))) < rng.random()
        views = choose_views(seen)
        assert 2 <= len(views) <= 3 and len(set(views)) == len(views)
        if seen.any(axis=1).all() and len(views) < 3:  # a third view only when needed
            assert seen[:, views].any(axis=1).all()
        # the first view shows as many contacts as any
        assert seen[:, views[0]].sum() == seen.sum(axis=0).max()


def test_a_contact_is_in_view_from_its_side_only(cube):
    # a contact on the +x face of the unit cube (mm), normal into the part
    free, facing = contact_visibility(cube, np.array([[0.5, 0.1, 0.1]]),
                                      np.array([[-1.0, 0.0, 0.0]]))
    d = VIEW_DIRECTIONS
    assert free[0, d[:, 0] > 0].all() and not free[0, d[:, 0] < 0].any()
    assert not facing[0, d[:, 0] <= 0].any() and facing[0, np.argmax(d[:, 0])]


def _box(center, size):
    m = trimesh.creation.box((size, size, size))
    m.apply_translation(center)
    return np.asarray(m.triangles)


def test_a_hand_behind_the_part_is_drawn_hidden_and_in_front_solid(cube):
    """Seen from +x: a box behind the cube shows only faded through it; a box in front is
    drawn in its own colour."""
    red = np.array([1.0, 0.0, 0.0])
    behind, front = _box([-1.0, 0.0, 0.0], 0.3), _box([1.0, 0.0, 0.45], 0.4)
    hand = Hand(np.concatenate([behind, front]), np.tile(red, (24, 1)), np.zeros((0, 3)),
                np.zeros((0, 3)), np.zeros((0, 3)))
    view = view_along(np.array([1.0, 0.0, 0.0]), np.zeros(3), 2.0, 80)
    img = _image(view, cube, hand)
    def inner(mask):  # away from the outlines
        return mask & np.roll(mask, 2, 0) & np.roll(mask, -2, 0) & np.roll(mask, 2, 1) & \
            np.roll(mask, -2, 1)

    hidden = inner(rasterize(view, behind).covered & ~rasterize(view, front).covered)
    assert hidden.sum() > 50
    ghost = img[hidden]
    # faded: mostly the part's grey, a little red; never the solid red of a visible hand
    assert (ghost[:, 0] - ghost[:, 1] > 0.1).all() and (ghost[:, 1] > 0.4).all()
    solid = inner(rasterize(view, front).covered)
    assert solid.sum() > 50
    assert (img[solid][:, 1] < 0.05).all() and (img[solid][:, 0] > 0.3).all()  # red


def test_units_are_named_short():
    assert unit_symbol("decimeters") == "dm" and unit_symbol("meters") == "m"
    assert unit_symbol(None) == "units"  # the file's own numbers


def test_the_figure_has_a_row_per_grasp_and_at_least_two_views(cube):
    """Two grasp rows of one fingertip each: each row draws its views, the title says how
    many contacts each view shows."""
    tip = trimesh.creation.icosphere(subdivisions=1, radius=0.05)
    rows = []
    for x in (0.55, -0.55):
        t = tip.copy()
        t.apply_translation([x, 0.0, 0.0])
        rows.append(GraspPicture(Hand(np.asarray(t.triangles), np.tile([0.2, 0.4, 0.8],
                                                                      (len(t.faces), 1)),
                                      np.array([[np.sign(x) * 0.5, 0, 0]]),
                                      np.array([[-np.sign(x), 0, 0]]), np.array([[1, 0, 0]])),
                                 f"grasp {x}", np.asarray(t.vertices)))
    fig = draw_grasps(cube, rows, "cube")
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert "grasp 0.55" in texts and "grasp -0.55" in texts
    views = [t for t in texts if t.startswith("from ")]
    assert len(views) >= 4 and all("1 of 1 contacts in view" in t for t in views[:1])
    assert any(t.endswith(" mm") for t in texts)  # the scale bar, in the part's unit
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_a_long_title_stays_inside_the_figure(cube):
    """A gripper plan's title (mesh name, hand, run id) is wider than one view: it wraps, the
    run id stays whole on one line, and every line's drawn extent is within the figure."""
    run = "run\u00a020261126T043215Z-2ce0a0c4"
    title = ("synth: A_LONG_MESH_NAME_IN_CAPITALS_MMMWWW_0123456789.STL: Franka Hand (Franka "
             "Emika Panda) grasps   " + run)  # capitals and digits: the widest characters
    # and a no-grasp message as long as a gripper plan's, in capitals and digits
    why = ("NO GRASP: THE PART IS TOO LARGE FOR THE FRANKA HAND (FRANKA EMIKA PANDA)'S 80 MM "
           "OPENING (THE NARROWEST WIDTH FOUND IS 97 MM) 0123456789")
    fig = draw_grasps(cube, [], title, why)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    head = next(t for t in fig.axes[0].texts if "Franka" in t.get_text())
    assert head.get_text().count("\n") >= 2 and run in head.get_text()
    width = fig.get_size_inches()[0] * fig.dpi
    message = next(t for t in fig.axes[0].texts if "NO GRASP" in t.get_text())
    assert message.get_text().count("\n") >= 1
    for text in (head, message):
        box = text.get_window_extent(renderer)
        assert 0 <= box.x0 and box.x1 <= width, text.get_text()
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_the_scale_bar_and_the_axes_go_to_the_corners_that_hide_the_least():
    """On an empty view the bar is lower left and the axes lower right; a finger drawn across
    the lower left moves the bar to the upper left; one across the lower right moves the axes
    up; with the right half drawn over, both go left, to distinct corners; a wide label counts
    beside a short bar."""
    size, px, label = 360, 50.0, 40.0
    white = np.ones((size, size, 3))
    lower_left_bar = np.array([0.05, 0.94]) * size
    lower_right_axes = np.array([0.88, 0.88]) * size
    bar, axes = _corners(white, px, label)
    assert np.allclose(bar, lower_left_bar) and np.allclose(axes, lower_right_axes)
    img = white.copy()
    img[300:, :120] = 0.3  # a dark finger over the lower left
    bar, axes = _corners(img, px, label)
    assert np.allclose(bar, [0.05 * size, 0.12 * size]) and np.allclose(axes, lower_right_axes)
    img = white.copy()
    img[260:, 240:] = 0.3  # over the lower right: the axes go to the upper right
    bar, axes = _corners(img, px, label)
    assert np.allclose(bar, lower_left_bar) and np.allclose(axes, [0.88 * size, 0.12 * size])
    img = white.copy()
    img[:, 200:] = 0.3  # the whole right half: the bar and the axes share the left
    bar, axes = _corners(img, px, label)
    assert bar[0] < size / 2 and axes[0] < size / 2 and abs(bar[1] - axes[1]) > size / 2
    # the axes' box, drawn over by a bar-sized stroke, is never under the bar's
    for _ in range(20):
        rng = np.random.default_rng(_)
        img = white.copy()
        y, x = rng.integers(0, size - 60, 2)
        img[y:y + 60, x:x + 60] = 0.3
        bar, axes = _corners(img, px, label)
        assert np.linalg.norm(bar - axes) > 0.4 * size
    # a wide label counts: drawn pixels beside a short bar, under its label, move it
    img = white.copy()
    x0 = lower_left_bar[0]
    img[320:345, int(x0 + 5 + 30):int(x0 + 5 + 40)] = 0.3
    assert np.allclose(_corners(img, 5.0, 10.0)[0], lower_left_bar)
    assert not np.allclose(_corners(img, 5.0, 100.0)[0], lower_left_bar)
