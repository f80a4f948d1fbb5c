"""Mesh repairs: slivers removed without opening the mesh, duplicate faces, and the
precision of stored coordinates."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth import load_part
from synth.part import repair
from synth.part.bodies import solid_moments
from synth.part.repair import (
    close,
    drop_duplicate_faces,
    fix_degenerate,
    fix_winding,
    orient,
    weld,
)
from synth.part.tolerances import coordinate_precision


def _cube_with_cap(t: float = 0.5) -> trimesh.Trimesh:
    """A closed unit cube where one edge (a, b) carries an extra vertex m = a + t (b - a): the
    face on one side is split at m and a zero-area sliver (a, b, m) closes the other side
    (its directed edge a -> b meets b -> a of the face across). t = 0.5 makes a cap, a tiny
    t a needle."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    v, f = box.vertices.tolist(), box.faces.tolist()
    a, b, c = f[0]
    m = len(v)
    v.append((np.array(v[a]) + t * (np.array(v[b]) - np.array(v[a]))).tolist())
    f[0:1] = [[a, m, c], [m, b, c], [a, b, m]]
    return trimesh.Trimesh(v, f, process=False)


def test_cap_is_flipped_away_and_the_cube_stays_closed() -> None:
    mesh = _cube_with_cap()
    assert mesh.is_watertight and (mesh.area_faces < 1e-12).sum() == 1
    out, fixed, dropped, kept = fix_degenerate(mesh, 1e-9)
    assert (fixed, dropped) == (1, 0)
    assert out.is_watertight and out.volume == pytest.approx(1.0)
    assert out.area_faces.min() > 1e-3 and len(out.faces) == len(mesh.faces)
    # the two faces of the flip cover the neighbour and both come from it, not from the cap
    counts = np.bincount(kept, minlength=len(mesh.faces))
    assert counts[2] == 0 and sorted(counts.tolist()) == [0] + [1] * 12 + [2]  # cap: face 2
    twice = int(np.argmax(counts))
    assert np.allclose(out.face_normals[kept == twice], mesh.face_normals[twice])


def test_needle_corners_are_merged_and_the_cube_stays_closed() -> None:
    mesh = _cube_with_cap(1e-8)
    assert mesh.is_watertight
    out, fixed, dropped, _ = fix_degenerate(mesh, 1e-9)
    assert (fixed, dropped) == (1, 0)
    assert out.is_watertight and out.volume == pytest.approx(1.0) and len(out.faces) == 12
    assert trimesh.triangles.normals(out.triangles)[1].all()


def test_needle_farther_than_max_move_is_flipped_not_merged() -> None:
    """A merge moves the surface around the merged corner by the distance the corner
    travels; past ``max_move`` the needle is flipped: no face lost, the cube still closed."""
    mesh = _cube_with_cap(1e-8)
    out, fixed, dropped, _ = fix_degenerate(mesh, 1e-9, max_move=1e-9)
    assert (fixed, dropped) == (1, 0)
    assert len(out.faces) == len(mesh.faces) and len(out.vertices) == len(mesh.vertices)
    assert out.is_watertight and out.volume == pytest.approx(1.0)
    out, _, _, _ = fix_degenerate(mesh, 1e-9, max_move=2e-8)
    assert len(out.faces) == 12


def test_a_body_that_stays_open_comes_back_as_it_came() -> None:
    """trimesh fills the triangular hole but not the pentagonal one: the faces it added are
    not kept (they would be surface the file does not have), nor reported."""
    sphere = trimesh.creation.icosphere(subdivisions=1)
    ring = np.flatnonzero((sphere.faces == 0).any(axis=1))[:3]  # 3 of the 5 faces at vertex 0
    far = int(np.argmin(sphere.triangles_center @ sphere.vertices[0]))  # one face opposite
    keep = np.setdiff1d(np.arange(len(sphere.faces)), np.r_[ring, far])
    mesh = trimesh.Trimesh(sphere.vertices, sphere.faces[keep], process=False)
    filled = mesh.copy()
    trimesh.repair.fill_holes(filled)
    assert len(filled.faces) == len(mesh.faces) + 1 and not filled.is_watertight
    out, what = close(mesh.copy())
    assert what is None and np.array_equal(out.faces, mesh.faces)
    assert np.array_equal(out.vertices, mesh.vertices)


def test_a_sliver_laden_file_loads_closed_with_real_normals(tmp_path: Path) -> None:
    path = tmp_path / "cap.stl"
    _cube_with_cap().export(path)
    part = load_part(path)
    assert part.watertight and part.volume == pytest.approx(1.0)
    assert np.allclose(np.linalg.norm(part.mesh.face_normals, axis=1), 1.0)
    assert any("sliver" in r for r in part.repairs)


@pytest.mark.parametrize("collide", [False, True])
def test_duplicate_faces_of_one_orientation_are_dropped_opposite_ones_kept(
        collide: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """The first of each repeated face (in any rotation of its corners) stays; with every
    row key made equal, the fallback finds the same."""
    if collide:
        monkeypatch.setattr(repair, "_KEY_MULT", np.zeros(3, np.uint64))
    tri = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2], [1, 2, 0], [0, 2, 1]],
                          process=False)
    out, n = drop_duplicate_faces(tri)
    assert n == 1 and out.faces.tolist() == [[0, 1, 2], [0, 2, 1]]
    rng = np.random.default_rng(4)
    f = rng.integers(0, 50, size=(3000, 3))
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    mesh = trimesh.Trimesh(rng.normal(size=(50, 3)), np.r_[f, np.roll(f[:500], 1, axis=1)],
                           process=False)
    out, n = drop_duplicate_faces(mesh)
    rolled = np.array([np.roll(r, -int(np.argmin(r))) for r in mesh.faces])
    first = sorted({tuple(r): i for i, r in reversed(list(enumerate(rolled.tolist())))}.values())
    assert out.faces.tolist() == mesh.faces[first].tolist() and n == len(mesh.faces) - len(first)


def test_coordinate_precision_follows_the_stored_values() -> None:
    f32 = np.array([[1000.0, -3.25, 0.1]], np.float32).astype(float)
    assert coordinate_precision(f32) == pytest.approx(1000.0 * 2.0**-24)
    decimals = np.array([[0.123456, 1.5, -2.000001]])
    assert coordinate_precision(decimals) == pytest.approx(5e-7)
    rng = np.random.default_rng(0)
    f64 = rng.normal(size=(100, 3)) * 7.0
    assert coordinate_precision(f64) == pytest.approx(np.abs(f64).max() * 2.0**-53)


def test_float32_part_far_away_keeps_its_planar_facets(tmp_path: Path) -> None:
    """A 4 cm box 40 m from the origin in a float32 STL: its faces' normals carry errors of
    ~1e-4 rad, above the plain coplanarity threshold; the precision term keeps each side one
    planar facet."""
    box = trimesh.creation.box((0.04, 0.03, 0.02)).subdivide().subdivide()
    box.apply_translation((40.0, -25.0, 12.0))
    path = tmp_path / "far.stl"
    box.export(path)
    part = load_part(path, units="m")
    assert part.precision == pytest.approx(40.0 * 2.0**-24, rel=0.1)
    assert len(part.regions) == 6 and all(r.planar for r in part.regions)


@pytest.mark.parametrize("scale, offset", [(1e-3, 0.0), (1.0, 0.0), (1e3, 5e3)])
def test_solid_moments_agree_with_trimesh_and_with_hand_values(scale: float,
                                                              offset: float) -> None:
    # a box of 2 x 3 x 4 has volume 24 and its centre at its middle; a torus is checked
    # against trimesh's full mass properties (second moments included)
    box = trimesh.creation.box(extents=(2.0, 3.0, 4.0))
    box.apply_translation((1.0, -2.0, 0.5))
    box.apply_scale(scale)
    box.apply_translation((offset, 0.0, -offset))
    volume, center = solid_moments(box.triangles)
    assert volume == pytest.approx(24.0 * scale**3, rel=1e-12)
    assert np.allclose(center, np.array([1.0, -2.0, 0.5]) * scale + (offset, 0.0, -offset),
                       rtol=0, atol=1e-12 * (scale + offset))
    torus = trimesh.creation.torus(1.0, 0.3)
    torus.apply_scale(scale)
    volume, center = solid_moments(torus.triangles)
    props = trimesh.triangles.mass_properties(torus.triangles)
    assert volume == pytest.approx(props.volume, rel=1e-12)
    assert np.allclose(center, props.center_mass, rtol=0, atol=1e-12 * scale)
    inverted = torus.copy()
    inverted.invert()
    assert solid_moments(inverted.triangles)[0] == pytest.approx(-volume, rel=1e-12)


def _one_piece_meshes() -> dict[str, trimesh.Trimesh]:
    ico = trimesh.creation.icosphere(4)
    cap = trimesh.Trimesh(ico.vertices, ico.faces[ico.triangles_center[:, 2] > 0.2])
    return {"box": trimesh.creation.box(), "icosphere": ico,
            "torus": trimesh.creation.torus(1.0, 0.3, major_sections=96, minor_sections=24),
            "open cap": cap}


@pytest.mark.parametrize("name", ["box", "icosphere", "torus", "open cap"])
@pytest.mark.parametrize("share", [0.0, 0.01, 0.5, 1.0])
def test_fix_winding_winds_a_piece_as_trimesh_does(name: str, share: float) -> None:
    """The same faces as trimesh's fix_winding (its breadth-first walk, one face pair at a
    time) after a random share of the faces is turned, closed or open."""
    mesh = _one_piece_meshes()[name]
    f = np.asarray(mesh.faces).copy()
    turned = np.random.default_rng(7).random(len(f)) < share
    f[turned] = f[turned, ::-1]
    theirs = trimesh.Trimesh(mesh.vertices, f, process=False)
    trimesh.repair.fix_winding(theirs)
    ours = trimesh.Trimesh(mesh.vertices, f.copy(), process=False)
    fix_winding(ours)
    assert ours.is_winding_consistent
    np.testing.assert_array_equal(ours.faces, theirs.faces)


def test_orient_turns_an_inside_out_piece_outward_and_counts_its_faces() -> None:
    box = trimesh.creation.box()
    inside_out = trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)
    fixed, flipped = orient(inside_out)
    assert flipped == 12
    assert fixed.volume == pytest.approx(1.0)
    again, flipped = orient(fixed)
    assert flipped == 0 and again.volume == pytest.approx(1.0)
    # one face wound the wrong way is turned back, and only that one
    f = box.faces.copy()
    f[3] = f[3, ::-1]
    fixed, flipped = orient(trimesh.Trimesh(box.vertices, f, process=False))
    assert flipped == 1 and fixed.is_winding_consistent and fixed.volume == pytest.approx(1.0)


@pytest.mark.parametrize("shape", ["box", "icosphere"])
def test_an_inside_out_triangle_soup_loads_with_outward_normals(shape: str,
                                                                 tmp_path: Path) -> None:
    """review: an inside-out OBJ whose corners are stored per triangle (welded, so its normals
    were read before orienting) kept trimesh's cached inward normals after the turn."""
    src = trimesh.creation.box() if shape == "box" else trimesh.creation.icosphere(3)
    tri = np.asarray(src.triangles)[:, ::-1]  # every face wound inward
    path = tmp_path / "soup.obj"
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in tri.reshape(-1, 3).tolist())
                    + "".join(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n"
                              for i in range(len(tri))))
    part = load_part(path)
    mesh = part.mesh
    assert any(r.startswith("re-oriented") for r in part.repairs)
    # the normals are those of the faces' own corners, and they point away from the centre
    geometric, valid = trimesh.triangles.normals(np.asarray(mesh.triangles))
    assert valid.all()
    np.testing.assert_allclose(mesh.face_normals, geometric, atol=1e-12)
    outward = np.einsum("ij,ij->i", mesh.triangles_center - part.center_mass, mesh.face_normals)
    assert (outward > 0).all()
    assert part.volume == pytest.approx(abs(src.volume), rel=1e-9)
    assert [b.convex for b in part.bodies] == [True]


def test_orient_turns_each_inside_out_piece_of_a_mesh_of_several() -> None:
    # review: a large box beside a small inside-out one; the total volume is positive, so a
    # sign test of the whole mesh would leave the small box inside out
    big = trimesh.creation.box((2.0, 2.0, 2.0))
    small = trimesh.creation.box((1.0, 1.0, 1.0))
    small.apply_translation((4.0, 0.0, 0.0))
    small = trimesh.Trimesh(small.vertices, small.faces[:, ::-1], process=False)
    both = trimesh.util.concatenate([big, small])
    fixed, flipped = orient(both)
    assert flipped == 12
    assert fixed.volume == pytest.approx(9.0)


def _trimesh_weld(mesh: trimesh.Trimesh, tol: float) -> trimesh.Trimesh:
    out = trimesh.Trimesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces),
                          process=False, validate=False)
    out.merge_vertices(merge_tex=True, merge_norm=True,
                       digits_vertex=max(0, int(np.ceil(-np.log10(tol)))))
    return out


@pytest.mark.parametrize(("scale", "offset"), [(1e-3, 0.0), (1.0, 0.0), (1e3, 0.0),
                                               (1.0, 1e3)])
@pytest.mark.parametrize("collide", [False, True])
def test_weld_merges_exactly_what_trimesh_merges(scale: float, offset: float, collide: bool,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """The same vertices, in the same order, and the same faces as trimesh's merge_vertices
    at the weld's digits: a soup with copies of vertices moved below and above the
    tolerance, exact copies, and vertices no face uses; with every row key made equal (a
    collision on every pair), the weld falls back to trimesh and still agrees."""
    if collide:
        monkeypatch.setattr(repair, "_KEY_MULT", np.zeros(3, np.uint64))
    rng = np.random.default_rng(3)
    v = rng.normal(size=(2000, 3))
    v = np.r_[v, v[:500] + rng.normal(size=(500, 3)) * 1e-9, v[500:900],
              v[:300] + rng.normal(size=(300, 3)) * 1e-3, rng.normal(size=(40, 3))]
    f = rng.integers(0, len(v) - 40, size=(4000, 3))
    mesh = trimesh.Trimesh(v * scale + offset, f, process=False)
    for tol in (1e-7 * scale, 1e-5 * scale):
        ours, removed = weld(mesh, tol)
        theirs = _trimesh_weld(mesh, tol)
        assert np.array_equal(ours.vertices, theirs.vertices)
        assert np.array_equal(ours.faces, theirs.faces)
        assert removed == len(v) - len(theirs.vertices)
        assert 40 + 400 <= removed < len(v) - 2000  # unused ones and exact copies at least



def test_heights_are_twice_the_area_over_the_longest_side() -> None:
    """Each face's smallest height, a coordinate at a time, against trimesh's areas and the
    sides' lengths from numpy's norm (relative 1e-12), over sizes from 1e-3 to 1e3 and off
    the origin; a face trimesh cannot give a normal (three corners on a line) has height 0."""
    from synth.part.repair import _heights

    rng = np.random.default_rng(7)
    for scale, offset in ((1e-3, 0.0), (1.0, 0.0), (1e3, 5e3)):
        v = rng.normal(size=(3000, 3)) * scale + offset
        f = np.arange(3000).reshape(-1, 3)
        tri = v[f]
        longest = np.linalg.norm(tri - np.roll(tri, -1, axis=1), axis=2).max(axis=1)
        expected = 2.0 * trimesh.triangles.area(tri) / longest
        assert np.allclose(_heights(v, f), expected, rtol=1e-12, atol=0.0)
    line = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    assert _heights(line, np.array([[0, 1, 2]]))[0] == 0.0
