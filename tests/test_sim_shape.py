"""The part as MuJoCo collides it: the planned part's convex bodies exactly, the file's convex
bodies for a body the loader united from them, and the facets of any other body near the hand
as thin slabs (grouped into convex patches); OBJ files whose vertices are split along normal
or texture seams give the same shape as a welded copy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

pytest.importorskip("mujoco")

from synth.part import load_part  # noqa: E402
from synth.sim import part_shape  # noqa: E402
from synth.sim.shape import SLAB_RTOL, _solid, within  # noqa: E402
from tests.sim_support import write_cube, write_split_obj  # noqa: E402

BRACKET = Path(__file__).resolve().parent.parent / "meshes" / "bracket.stl"


def test_a_convex_body_is_one_exact_piece(tmp_path):
    s = part_shape(load_part(write_cube(tmp_path)))
    assert len(s.pieces) == 1 and s.faceted == 0 and len(s.triangles) == 0
    assert s.volume == pytest.approx(1.0)
    assert np.allclose(s.inertia, np.eye(3) / 6)  # a unit cube of unit density


BREAD = BRACKET.parent / "corpus" / "robosuite_bread.stl"  # coarse: facets 100 degrees apart


@pytest.mark.parametrize("mesh, units", [(BRACKET, "dm"), (BREAD, "m")])
def test_a_non_convex_body_is_its_facets_near_the_hand(mesh, units):
    part = load_part(mesh, units=units)
    s = part_shape(part)
    assert s.faceted == 1 and len(s.pieces) == 0 and len(s.triangles) == len(part.mesh.faces)
    assert s.slab == pytest.approx(SLAB_RTOL * part.length)
    assert s.volume == pytest.approx(part.volume)
    everything, depths = s.near(lambda tri: np.ones(len(tri), bool))
    assert len(depths) == len(everything) and np.all((depths > 0) & (depths <= s.slab))
    # convex patches: fewer slabs than facets, every facet in one, each slab a solid
    assert len(everything) < len(part.mesh.faces) and all(_solid(v) for v in everything)
    # each slab's outer face is the mesh's: its corners are the mesh's vertices, and the
    # rest lie one slab depth inside, along their facet's inward normal
    outer = np.concatenate([v[: len(v) // 2] for v in everything])
    d = trimesh.proximity.closest_point(part.mesh, outer)[1]
    assert d.max() <= 1e-9 * part.length
    inner = np.concatenate([v[len(v) // 2:] for v in everything])
    depth = trimesh.proximity.signed_distance(part.mesh, inner)  # positive inside
    assert depth.min() >= -1e-9 * part.length  # inside, or on the surface at a corner
    # and no slab stands out of the part: the middle of every face of every slab's hull
    # (what MuJoCo collides) is inside or on the surface
    mids = np.concatenate([trimesh.convex.convex_hull(v).triangles_center for v in everything])
    assert trimesh.proximity.signed_distance(part.mesh, mids).min() >= -1e-6 * part.length
    # near a point, only the facets within reach
    c = part.mesh.vertices[0]
    few, _ = s.near(within(c[None], 0.05 * part.length))
    assert 0 < len(few) < len(everything)


def test_no_slab_of_a_thin_curved_wall_stands_out_of_its_far_side(tmp_path):
    # a ring 2% thick: convex patches of its outside grown round the bend (up to 60 degrees
    # of arc) had hulls whose chord passed through the inside wall, where a finger pressing
    # the inside met them (on the puck goal's nets, by 40% of a fingertip's radius)
    ring = trimesh.creation.annulus(r_min=0.98, r_max=1.0, height=0.5, sections=64)
    path = tmp_path / "ring.stl"
    ring.export(path)
    part = load_part(path, units="m")
    s = part_shape(part)
    assert s.faceted == 1 and len(s.triangles) == len(part.mesh.faces)
    everything, _ = s.near(lambda tri: np.ones(len(tri), bool))
    assert len(everything) < len(part.mesh.faces)  # still patches, where they stay inside
    mids = np.concatenate([trimesh.convex.convex_hull(v).triangles_center for v in everything])
    assert trimesh.proximity.signed_distance(part.mesh, mids).min() >= -1e-6 * part.length


def test_slabs_follow_thin_walls_at_any_scale(tmp_path):
    """A ring whose wall (0.02) is thinner than a slab over WALL_SHARE: its facets' slabs
    are WALL_SHARE of the wall deep, the same relative to its size in millimetres, metres
    or kilometres of file units (the wall was measured only in parts of more than one unit,
    when the rays counted the facet they started from as a hit 1e-6 behind them)."""
    from synth.sim.shape import WALL_SHARE

    ring = trimesh.creation.annulus(r_min=0.98, r_max=1.0, height=0.5, sections=64)
    relative = []
    for scale in (1e-3, 1.0, 1e3):
        path = tmp_path / f"ring{scale}.stl"
        ring.copy().apply_scale(scale).export(path)
        part = load_part(path, units="m")
        s = part_shape(part)
        tri = s.triangles
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        depth = s._depths(tri, n, s.body)
        sides = np.abs(n[:, 2]) < 0.5  # the inner and outer walls, not the rims
        assert WALL_SHARE * 0.02 * scale < s.slab
        assert depth[sides] == pytest.approx(WALL_SHARE * 0.02 * scale, rel=0.01)
        relative.append(depth / scale)
    assert np.allclose(relative[0], relative[1], rtol=1e-5)
    assert np.allclose(relative[2], relative[1], rtol=1e-5)


@pytest.mark.parametrize("split", ["normal", "uv"])
def test_split_vertex_obj_files_give_the_welded_part_s_shape(tmp_path, split):
    # a cube written with its vertices split per face (by normal) or along a texture seam:
    # read raw, it is six open sheets (or two); the planned part is one closed convex body
    raw = trimesh.load(write_split_obj(tmp_path, split), process=False, force="mesh")
    assert not raw.is_watertight
    s = part_shape(load_part(write_split_obj(tmp_path, split)))
    assert len(s.pieces) == 1 and s.faceted == 0 and s.volume == pytest.approx(1.0)


def test_a_flat_piece_has_no_volume():
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    assert not _solid(flat) and not _solid(flat[:3])
    assert _solid(np.vstack([flat, [[0, 0, 1.0]]]))


def test_a_body_united_from_convex_pieces_is_simulated_as_those_pieces(tmp_path):
    # two overlapping boxes stored as two objects of a collision mesh: the loader unites them
    # into one (non-convex) body; its pieces for MuJoCo are the two boxes, exactly
    a = trimesh.creation.box((1.0, 1.0, 1.0))
    b = trimesh.creation.box((2.0, 0.5, 0.5))
    b.apply_translation([0.8, 0.0, 0.0])
    scene = trimesh.Scene()
    scene.add_geometry(a, "a")
    scene.add_geometry(b, "b")
    path = tmp_path / "two.obj"
    scene.export(path)
    part = load_part(path)
    assert len(part.bodies) == 1 and not part.bodies[0].convex
    s = part_shape(part)
    assert s.faceted == 0 and len(s.pieces) == 2
    got = sorted(float(np.ptp(v[:, 0])) for v in s.pieces)
    assert got == pytest.approx([1.0, 2.0])


def test_no_slab_of_a_sliver_facet_is_left_for_mujoco_to_refuse():
    """A float32 CAD file (the held-out iiwa link 3) has facets about 1e-8 of the part thin:
    the slab of such a facet alone is flat, and MuJoCo refused the whole scene ('coplanar
    vertices', a grasp not simulated). Near those facets every piece is a solid, and MuJoCo
    compiles them all (a scene written here, with MuJoCo's own mesh geoms)."""
    import mujoco

    part = load_part(BRACKET.parent / "corpus" / "robosuite_iiwa_link3_collision.stl",
                     units="m")
    s = part_shape(part)
    tri = s.triangles
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    sliver = (area2 > 0) & (area2 / longest < 1e-4 * s.slab)  # heights: slivers
    assert sliver.sum() >= 2
    pieces, depths = s.near(within(tri[sliver].mean(axis=1), 0.02 * part.length))
    assert len(pieces) > 10 and all(_solid(v) for v in pieces)
    # and no hole where a sliver was: its corners and centre lie in a piece that is kept
    from scipy.spatial import ConvexHull

    planes = [ConvexHull(v).equations for v in pieces]
    tol = 1e-9 * part.length
    for t in tri[sliver]:
        for x in np.vstack([t, t.mean(axis=0)]):
            assert any((eq[:, :3] @ x + eq[:, 3]).max() <= tol for eq in planes)
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="part")
    for i, v in enumerate(pieces):
        spec.add_mesh(name=f"m{i}", uservert=(v - part.center_mass).ravel().tolist())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"m{i}")
    spec.compile()  # raises on a flat mesh
