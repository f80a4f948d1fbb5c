"""Bodies: whether a closed body is convex, judged against qhull (a body is convex when its
convex hull holds no more volume than the body itself, up to round-off)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull

from synth import load_part
from synth.part.bodies import body_labels, is_convex, mesh_moments
from synth.part.tolerances import coordinate_precision, surface_tolerance


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
    assert not part.bodies[0].convex and not part.convex_inputs
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


def test_a_far_object_in_the_file_does_not_make_the_part_convex() -> None:
    """review: the loader judged the file's bodies with the tolerance of the whole file, 100x
    the part's when another object lies far away, and kept the dented body as a convex piece
    for the simulator while the part called it non-convex."""
    far = trimesh.creation.box((1.0, 1.0, 1.0)).apply_translation((300.0, 0.0, 0.0))
    part = load_part(trimesh.util.concatenate([_hourglass(0.02, rings=200), far]))
    assert [b.convex for b in part.bodies] == [False]
    assert not part.convex_inputs


def _fine_box(edge: float) -> trimesh.Trimesh:
    v, f = trimesh.remesh.subdivide_to_size(trimesh.creation.box().vertices,
                                            trimesh.creation.box().faces, max_edge=edge)
    return trimesh.Trimesh(v, f)


def test_a_small_dent_only_the_edge_test_sees_makes_a_body_not_convex() -> None:
    """A box of 3,072 faces with its top's centre pushed in by 2% of the side: no vertex is
    above the plane of any face but the six about the dent, so the verdict comes from the
    test across edges unless one of those six is among the planes tested."""
    mesh = _fine_box(0.1)
    top = int(np.flatnonzero(np.all(np.isclose(mesh.vertices, (0.0, 0.0, 0.5)), axis=1))[0])
    v = mesh.vertices.copy()
    v[top, 2] -= 0.02
    dented = trimesh.Trimesh(v, mesh.faces, process=False)
    near = np.any(dented.faces == top, axis=1)
    assert near.sum() == 6
    others = np.flatnonzero(~near)
    n = dented.face_normals[others]
    above = dented.vertices @ n.T - np.einsum("ij,ij->i", dented.vertices[dented.faces[others, 0]],
                                              n)
    assert above.max() < 1e-12
    assert _hull_excess(dented) > 0  # qhull: not convex
    assert not is_convex(dented, 1e-6 * float(np.linalg.norm(dented.extents)))


@pytest.mark.parametrize("offset", [0.0, 100.0])
def test_round_off_that_tilts_small_faces_does_not_refute_a_convex_body(offset: float) -> None:
    """A finely cut box (20k faces), turned so that no coordinate is a round number, stored in
    float32 100 sizes from the origin: a small face's plane is tilted by the rounding, so far
    vertices of the same side lie above it by several times the surface tolerance (the
    allowance's tilt term is what keeps the box convex), yet the box is convex."""
    mesh = _fine_box(0.05)
    turn = trimesh.transformations.random_rotation_matrix(np.random.default_rng(1).random(3))
    v = (mesh.vertices @ turn[:3, :3].T + offset).astype(np.float32).astype(float)
    box = trimesh.Trimesh(v, mesh.faces, process=False)
    tolerance = surface_tolerance(float(np.linalg.norm(box.extents)), coordinate_precision(v))
    assert _hull_excess(box) < tolerance  # qhull: convex, up to the round-off
    if offset:  # the round-off shows: some vertex lies above some face's plane
        rows = np.random.default_rng(2).choice(len(box.faces), 200, replace=False)
        n = box.face_normals[rows]
        above = box.vertices @ n.T - np.einsum("ij,ij->i", box.vertices[box.faces[rows, 0]], n)
        assert above.max() > 2.0 * tolerance
    assert is_convex(box, tolerance)
    assert [b.convex for b in load_part(box).bodies] == [True]


def test_what_the_mesh_cache_keeps_goes_when_the_mesh_changes() -> None:
    box = trimesh.creation.box()
    assert mesh_moments(box)[0] == pytest.approx(1.0)
    box.vertices *= 2.0  # in place
    assert mesh_moments(box)[0] == pytest.approx(8.0)
    box.invert()
    assert mesh_moments(box)[0] == pytest.approx(-8.0)

    glass = _hourglass(0.02, rings=200)
    assert not is_convex(glass, 1e-6)
    r = np.linalg.norm(glass.vertices[:, :2], axis=1)
    side = r > 1e-9
    v = glass.vertices.copy()
    v[side, :2] /= r[side, None]  # every ring back to radius 1: a cylinder
    glass.vertices = v
    assert is_convex(glass, 1e-6)

    two = trimesh.util.concatenate([trimesh.creation.box(),
                                    trimesh.creation.box().apply_translation((3.0, 0, 0))])
    assert body_labels(two).max() == 1
    two.faces = two.faces[:12]
    assert body_labels(two).tolist() == [0] * 12


def _trimesh_labels(mesh: trimesh.Trimesh) -> np.ndarray:
    """Components of trimesh's face adjacency, numbered in order of first face."""
    n = len(mesh.faces)
    adj = np.asarray(mesh.face_adjacency, np.int64).reshape(-1, 2)
    lab = connected_components(coo_matrix((np.ones(len(adj)), (adj[:, 0], adj[:, 1])),
                                          shape=(n, n)), directed=False)[1]
    _, first = np.unique(lab, return_index=True)
    return np.argsort(np.argsort(first))[lab]


def test_body_labels_are_the_components_of_trimeshs_face_adjacency() -> None:
    """Two boxes touching at a corner (two bodies), three faces on one edge (a fin: trimesh
    joins no face across an edge of three), a V-HACD decomposition and an open scan."""
    corner = trimesh.util.concatenate([trimesh.creation.box(),
                                       trimesh.creation.box().apply_translation((1, 1, 1))])
    corner.merge_vertices()
    fin = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]],
                          [[0, 1, 2], [1, 0, 3], [0, 1, 4]], process=False)
    root = Path(__file__).resolve().parents[1] / "meshes" / "corpus"
    files = [root / "pybullet_duck_vhacd.obj", root / "pybullet_bunny.obj"]
    meshes = [corner, fin] + [trimesh.load(f, force="mesh") for f in files if f.exists()]
    assert len(meshes) == 4
    for mesh in meshes:
        ours = body_labels(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False))
        np.testing.assert_array_equal(ours, _trimesh_labels(mesh))
    assert body_labels(corner).max() == 1 and body_labels(fin).tolist() == [0, 1, 2]
