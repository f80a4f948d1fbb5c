"""Distances from points to the part's sharp edges within a radius (synth.part.clearance),
against brute force over every sharp edge and a distance worked out by hand."""

import numpy as np
import pytest
import trimesh

from synth import load_part
from synth.part.clearance import sharp_clearance


def _prism(profile):
    """The 2-D profile (m, 2), counter-clockwise, extruded along z from 0 to 1, as a closed
    mesh (the side walls split into triangles, the two caps fanned from their centroids)."""
    p = np.asarray(profile, float)
    m = len(p)
    c = p.mean(axis=0)
    v = np.vstack([np.c_[p, np.zeros(m)], np.c_[p, np.ones(m)], [[c[0], c[1], 0.0]],
                   [[c[0], c[1], 1.0]]])
    faces = []
    for i in range(m):
        j = (i + 1) % m
        faces += [[i, j, m + j], [i, m + j, m + i]]
        faces += [[2 * m, j, i], [2 * m + 1, m + i, m + j]]
    mesh = trimesh.Trimesh(v, np.array(faces), process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    return mesh


# a block whose top (y = 1) ends in a strip 0.01 wide that slopes 3 degrees down to the right
# wall: the strip's edge with the top is smooth, its edge with the wall sharp
_SLOPE = np.tan(np.radians(3.0))
_STRIP = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0 - 0.01 * _SLOPE), (1.99, 1.0), (0.0, 1.0)]


def _brute(part, q):
    """Distance from each point to the nearest sharp edge of the whole part (segments)."""
    f = part.features
    e = f.edges[f.edge_kind != 0]
    a, b = part.mesh.vertices[e[:, 0]], part.mesh.vertices[e[:, 1]]
    ab = b - a
    rel = q[:, None, :] - a[None]
    t = np.clip(np.einsum("nek,ek->ne", rel, ab) / np.einsum("ek,ek->e", ab, ab), 0, 1)
    return np.linalg.norm(rel - t[..., None] * ab[None], axis=2).min(axis=1)


def test_the_sharp_edge_past_a_narrow_strip_counts():
    part = load_part(_prism(_STRIP))
    kinds = part.features.edge_kind
    assert (kinds == 0).any() and (kinds == 1).any()  # the smooth and the sharp edges
    # points on the top face, 0.001 to 0.3 before the strip, halfway along the prism
    x = 1.99 - np.array([0.001, 0.01, 0.05, 0.3])
    c = part.resolve(np.c_[x, np.ones(4), np.full(4, 0.5)])
    assert (c.features == "face").all()  # the strip's edge with the top is smooth
    # by hand: the wall's top edge at (2, 1 - 0.01 tan 3deg) is the nearest sharp edge
    wall = np.hypot(2.0 - x, 0.01 * _SLOPE)
    got = sharp_clearance(part, c.points, 1.0)
    assert got == pytest.approx(wall, rel=1e-12)
    # beyond the radius: inf
    short = sharp_clearance(part, c.points, 0.05)
    assert np.array_equal(np.isinf(short), wall > 0.05)
    assert short[~np.isinf(short)] == pytest.approx(wall[wall <= 0.05], rel=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_it_is_the_distance_to_the_nearest_sharp_edge_by_brute_force(seed):
    rng = np.random.default_rng(seed)
    shape = trimesh.convex.convex_hull(rng.normal(size=(30, 3)) * [1.0, 2.0, 3.0])
    shape = shape.subdivide()  # faces inside the facets: smooth edges among sharp ones
    shape.apply_translation([1e3, -2e3, 5e2])  # off the origin
    part = load_part(shape)
    f = rng.integers(0, len(part.mesh.faces), 3000)
    w = rng.dirichlet([1, 1, 1], len(f))
    q = np.einsum("nk,nkx->nx", w, part.mesh.vertices[part.mesh.faces[f]])
    brute = _brute(part, q)
    for radius in (0.01, 0.1, 1.0):
        got = sharp_clearance(part, q, radius)
        within = brute <= radius
        assert within.sum() > 10
        assert np.array_equal(np.isfinite(got), within)
        assert got[within] == pytest.approx(brute[within], rel=1e-9, abs=1e-12)


def test_no_sharp_edge_is_inf_and_no_points_is_empty():
    part = load_part(trimesh.creation.icosphere(subdivisions=3))
    assert (part.features.edge_kind == 0).all()
    assert np.isinf(sharp_clearance(part, part.mesh.vertices[:5], 10.0)).all()
    assert sharp_clearance(part, np.zeros((0, 3)), 1.0).shape == (0,)


def test_two_parts_of_one_mesh_keep_their_own_sharp_edges():
    from synth.part.model import Part

    mesh = trimesh.creation.cylinder(radius=1.0, height=2.0, sections=24)  # 15 deg between sides
    fine = Part(mesh, sharp_angle=np.radians(10.0))  # the sides' edges are sharp
    coarse = Part(mesh, sharp_angle=np.radians(40.0))  # only the rims are
    q = np.array([[np.cos(np.radians(7.5)), np.sin(np.radians(7.5)), 0.0]])  # mid-side
    q *= np.cos(np.radians(7.5))  # on the side's plane, halfway between two side edges
    near = sharp_clearance(fine, q, 2.0)
    far = sharp_clearance(coarse, q, 2.0)
    assert near[0] == pytest.approx(np.sin(np.radians(7.5)), rel=1e-9)
    assert far[0] == pytest.approx(1.0, rel=1e-9)  # to the rims, 1 above and below
    assert sharp_clearance(fine, q, 2.0)[0] == near[0]
