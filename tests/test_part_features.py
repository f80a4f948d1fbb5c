"""Edge and vertex classes and face regions of the sample parts (known answers)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.part import Part, load_part
from synth.part.features import edge_closure, edge_table

MESHES = Path(__file__).resolve().parent.parent / "meshes"


@pytest.fixture(scope="module")
def parts() -> dict[str, Part]:
    names = ["cube", "prism", "bracket", "tee", "nut", "cylinder", "sphere", "torus"]
    return {n: load_part(MESHES / f"{n}.stl", units="decimeters") for n in names}


def _kinds(part: Part) -> tuple[np.ndarray, np.ndarray]:
    f = part.features
    return np.bincount(f.edge_kind, minlength=4), np.bincount(f.vertex_kind, minlength=6)


def test_cube_features_and_regions(parts: dict[str, Part]) -> None:
    cube = parts["cube"]
    ek, vk = _kinds(cube)
    assert tuple(ek) == (6, 12, 0, 0)  # 6 face diagonals smooth, 12 convex edges
    assert tuple(vk) == (0, 0, 8, 0, 0, 0)  # 8 convex corners
    assert np.allclose(cube.features.edge_angle[cube.features.edges_of_kind("convex")],
                       np.pi / 2)
    assert len(cube.regions) == 6
    normals = np.array([r.normal for r in cube.regions])
    assert all(r.planar and r.area == pytest.approx(1.0) for r in cube.regions)
    # inward: the normal of each facet points from the facet towards the centre
    centres = np.array([cube.mesh.triangles_center[r.faces].mean(axis=0) for r in cube.regions])
    assert np.allclose(normals, -2.0 * centres, atol=1e-9)
    for r in cube.regions:
        assert len(r.boundary_edges) == 4 and len(r.outline) == 1 and len(r.outline[0]) == 4
        assert np.isin(r.boundary_edges, cube.features.edges_of_kind("convex")).all()


def test_bracket_and_tee_concave_edges(parts: dict[str, Part]) -> None:
    b = parts["bracket"]
    f = b.features
    v = np.asarray(b.mesh.vertices)
    concave = f.edges_of_kind("concave")
    # three grooves meeting at the inside corner: x = z = 0.25 (y 0.25..1),
    # y = z = 0.25 (x 0.25..1), x = y = 0.25 (z 0.25..1); and two short ones where the side
    # wall meets the base (x = 1, z = 0.25) and the upright (x = 0.25, z = 1), y 0..0.25
    assert f.edge_length[concave].sum() == pytest.approx(0.75 * 3 + 0.25 * 2)
    mids = v[f.edges[concave]].mean(axis=1)
    in_grooves = np.sum(np.isclose(mids, 0.25), axis=1) == 2
    assert f.edge_length[concave[in_grooves]].sum() == pytest.approx(2.25)
    corner = f.vertices_of_kind("concave_corner")
    assert len(corner) == 1 and np.allclose(v[corner[0]], 0.25)
    assert b.vertex_kind(int(corner[0])) == "concave_corner"
    saddles = v[f.vertices_of_kind("saddle")]
    assert {tuple(np.round(s, 6)) for s in saddles} >= {(0.25, 1.0, 0.25), (1.0, 0.25, 0.25),
                                                        (0.25, 0.25, 1.0)}
    t = parts["tee"]
    assert len(t.features.edges_of_kind("concave")) == 2


def test_curved_parts_are_smooth_patches(parts: dict[str, Part]) -> None:
    for name in ("sphere", "torus"):
        p = parts[name]
        ek, vk = _kinds(p)
        assert ek[1] == ek[2] == 0 and vk[0] == len(p.mesh.vertices), name
        assert not any(r.planar for r in p.regions)
        assert all(0 < r.half_angle <= np.radians(45) for r in p.regions)
        assert sum(r.area for r in p.regions) == pytest.approx(p.mesh.area)
    cyl = parts["cylinder"]
    planar = [r for r in cyl.regions if r.planar]
    assert len(planar) == 2  # the caps
    assert sorted(r.normal[2] for r in planar) == pytest.approx([-1.0, 1.0])
    area64 = 0.5 * 64 * 0.25 * np.sin(2 * np.pi / 64)
    assert all(r.area == pytest.approx(area64) for r in planar)
    # the rims are sharp convex edges whose vertices are 'edge' vertices, not corners
    assert len(cyl.features.edges_of_kind("convex")) == 128
    assert (cyl.features.vertex_kind == 1).all()


def test_nut_hole_is_smooth_and_hex_is_sharp(parts: dict[str, Part]) -> None:
    nut = parts["nut"]
    f = nut.features
    angles = f.edge_angle[f.edges_of_kind("convex")]
    assert np.isclose(angles, np.pi / 3).sum() == 6  # vertical edges of the hexagon
    assert (f.vertex_kind == 2).sum() == 12  # hexagon corners top and bottom
    v = np.asarray(nut.mesh.vertices)
    r = np.linalg.norm(v[:, :2], axis=1)
    hole = np.isclose(r, 0.25, atol=1e-6)
    assert (f.vertex_kind[hole] == 1).all()  # on the hole rims


def test_sharp_angle_is_settable() -> None:
    coarse = load_part(MESHES / "cylinder.stl", sharp_angle=np.radians(3.0))
    # 64 segments: 5.6 deg between side facets, now sharp
    assert len(coarse.features.edges_of_kind("convex")) == 128 + 64
    assert all(r.planar for r in coarse.regions)


#: Edge-table cases: scans, convex decompositions, closed parts, an open sheet, a fin of three
#: faces on one edge, faces turned or repeated, and meshes without faces.
_EDGE_CASES = ["corpus/pybullet_bunny.obj", "corpus/pybullet_lego_vhacd.obj", "nut.stl",
               "torus.stl", "open", "nonmanifold"]


def _edge_case(name: str) -> trimesh.Trimesh:
    """The mesh of an edge-table case (a sample or corpus file, or one built here)."""
    rng = np.random.default_rng(3)
    if name == "open":
        mesh = trimesh.creation.icosphere(2)
        mesh.update_faces(np.arange(len(mesh.faces)) % 5 != 0)
        return mesh
    if name == "nonmanifold":
        v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
        return trimesh.Trimesh(v, [[0, 1, 2], [1, 0, 3], [0, 1, 4]], process=False)
    if name == "turned":
        mesh = trimesh.creation.icosphere(3)
        f = mesh.faces.copy()
        turn = rng.random(len(f)) < 0.05
        f[turn] = f[turn, ::-1]
        return trimesh.Trimesh(mesh.vertices, f, process=False)
    if name == "doubled":
        box = trimesh.creation.box()
        return trimesh.Trimesh(box.vertices, np.concatenate([box.faces, box.faces[:2],
                                                             box.faces[4:5, ::-1]]),
                               process=False)
    if name == "empty":
        return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
    if name == "no faces":  # vertices only: trimesh calls it watertight and wound
        return trimesh.Trimesh(rng.random((5, 3)), np.zeros((0, 3), np.int64), process=False)
    return trimesh.load(MESHES / name, force="mesh")


@pytest.mark.parametrize("name", _EDGE_CASES)
def test_edge_table_numbers_edges_as_trimesh_does(name: str) -> None:
    """The one-sort edge table gives trimesh's unique edges, their order, each face's edges
    and each edge's first two faces (``edges_face`` through the inverse), on scans, convex
    decompositions, closed parts, an open sheet and a fin of three faces on one edge."""
    mesh = _edge_case(name)
    faces = np.asarray(mesh.faces, np.int64)
    edges, face_edges, order, starts = edge_table(faces, len(mesh.vertices))
    assert np.array_equal(edges, mesh.edges_unique)
    assert np.array_equal(face_edges, mesh.faces_unique_edges)
    inverse = np.asarray(mesh.edges_unique_inverse)
    assert np.array_equal(inverse[order], np.repeat(np.arange(len(edges)), np.diff(
        np.append(starts, len(order)))))
    first = np.full(len(edges), len(order))
    np.minimum.at(first, inverse, np.arange(len(order)))
    assert np.array_equal(order[starts], first)
    assert np.array_equal(order[starts] // 3, mesh.edges_face[first])


@pytest.mark.parametrize("name", _EDGE_CASES + ["turned", "doubled", "empty", "no faces"])
def test_edge_closure_answers_as_trimesh_does(name: str) -> None:
    """Watertightness and consistent winding from the edge table equal trimesh's own on
    closed, open and non-manifold meshes, with faces turned or repeated (a face repeated
    the same way round, or turned, puts three or four faces on its edges), on an empty mesh
    and on vertices without faces; and trimesh's properties then read the same answers."""
    mesh = _edge_case(name)
    reference = trimesh.Trimesh(mesh.vertices.copy(), mesh.faces.copy(), process=False)
    expected = (reference.is_watertight, reference.is_winding_consistent)
    assert edge_closure(mesh) == expected
    assert (mesh.is_watertight, mesh.is_winding_consistent) == expected
