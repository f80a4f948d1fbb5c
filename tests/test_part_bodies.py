"""Bodies: whether a closed body is convex, judged against qhull (a body is convex when its
convex hull holds no more volume than the body itself, up to round-off)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from synth import load_part
from synth.part.bodies import is_convex


def _hourglass(depth: float, rings: int = 400, sections: int = 64) -> trimesh.Trimesh:
    """A closed cylinder of radius 1 and height 2 whose side narrows to ``1 - depth`` at its
    middle along a parabola, finely cut along its axis: a non-convex solid whose every edge
    bends by so little that trimesh's local test calls it convex."""
    z = np.linspace(-1.0, 1.0, rings)
    r = 1.0 - depth * (1.0 - z ** 2)
    profile = np.vstack([[0.0, -1.0], np.column_stack([r, z]), [0.0, 1.0]])
    return trimesh.creation.revolve(profile, sections=sections)


def _hull_excess(mesh: trimesh.Trimesh) -> float:
    """How much thicker than the body its convex hull is: the hull's extra volume per area."""
    return (ConvexHull(mesh.vertices).volume - mesh.volume) / mesh.area


def test_a_fine_non_convex_body_is_not_convex_though_every_edge_bends_little() -> None:
    mesh = _hourglass(0.05)
    assert mesh.is_watertight and mesh.volume > 0
    assert mesh.is_convex  # trimesh's local test: the case needs the global one
    assert _hull_excess(mesh) > 0.1 * 0.05  # qhull: not convex
    part = load_part(mesh)
    assert len(part.bodies) == 1 and part.bodies[0].closed
    assert not part.bodies[0].convex
    # so its inside test is the body's, not its hull's: points about the waist, inside the
    # hull, are inside the body exactly when trimesh's signed distance says so
    rng = np.random.default_rng(3)
    r = rng.uniform(0.9, 1.0, 400)
    a = rng.uniform(0.0, 2.0 * np.pi, 400)
    pts = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(-0.3, 0.3, 400)])
    depth = trimesh.proximity.signed_distance(mesh, pts)  # > 0 inside
    far = np.abs(depth) > 1e-3
    assert far.sum() > 300 and (depth[far] < 0).sum() > 100
    hidden = part._solids.hidden(pts, 0.0, 1.0)
    np.testing.assert_array_equal(hidden[far], depth[far] > 0)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
@pytest.mark.parametrize("offset", [0.0, 1e3])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_convex_bodies_stay_convex_at_any_size_place_and_precision(scale, offset, dtype) -> None:
    """A fine sphere and a straight cylinder, rounded to float32 or not, from 1 mm to 1 km
    and 1,000 sizes off the origin: qhull finds their hulls no bigger than them, and neither
    is refuted by the plane test's allowance for round-off."""
    for mesh in (trimesh.creation.icosphere(subdivisions=5), _hourglass(0.0)):
        v = (np.asarray(mesh.vertices) * scale + offset * scale).astype(dtype)
        m = trimesh.Trimesh(v.astype(float), mesh.faces, process=False)
        m.merge_vertices()
        assert _hull_excess(m) < 1e-6 * np.linalg.norm(m.extents)
        part = load_part(m)
        assert [b.convex for b in part.bodies] == [True]


@pytest.mark.parametrize("depth", [0.002, 0.02, 0.2])
def test_the_verdict_agrees_with_qhull_on_dents_of_any_depth(depth: float) -> None:
    mesh = _hourglass(depth, rings=200)
    tolerance = 1e-6 * float(np.linalg.norm(mesh.extents))
    assert _hull_excess(mesh) > 0.1 * depth  # qhull: not convex
    assert not is_convex(mesh, tolerance)
