"""Parts of several bodies: convex decompositions, overlapping bodies, objects far apart,
open pieces; the exposed surface against independent inside tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth import check_fingers, default_fingers, load_part, sample_contacts
from synth.cli import main
from tests.independent_check import Pieces

CORPUS = Path(__file__).resolve().parent.parent / "meshes" / "corpus"


def _obj(path: Path, meshes: dict[str, trimesh.Trimesh]) -> Path:
    """An OBJ with one object per mesh (as collision meshes store convex pieces)."""
    lines, base = [], 1
    for name, m in meshes.items():
        lines.append(f"o {name}")
        lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in m.vertices.tolist()]
        lines += [f"f {a + base} {b + base} {c + base}" for a, b, c in m.faces.tolist()]
        base += len(m.vertices)
    path.write_text("\n".join(lines) + "\n")
    return path


def _box(extents, at) -> trimesh.Trimesh:
    b = trimesh.creation.box(extents)
    return b.apply_translation(at)


def test_touching_pieces_are_one_part_and_their_facing_sides_hidden(tmp_path: Path) -> None:
    gap = 1e-4
    path = _obj(tmp_path / "pair.obj", {"a": _box((1, 1, 1), (0, 0, 0)),
                                        "b": _box((1, 1, 1), (1 + gap, 0, 0))})
    part = load_part(path)
    assert [b.name for b in part.bodies] == ["a", "b"] and part.dropped == ()
    assert all(b.closed and b.convex for b in part.bodies)
    assert part.volume == pytest.approx(2.0)
    assert np.allclose(part.center_mass, [0.5 + gap / 2, 0, 0])
    c = part.mesh.triangles_center
    facing = (np.abs(c[:, 0] - 0.5) < 1e-9) | (np.abs(c[:, 0] - 0.5 - gap) < 1e-9)
    assert facing.sum() == 4
    assert (part.face_exposure[facing] == 0).all() and (part.face_exposure[~facing] == 2).all()
    assert [b.exposed_area for b in part.bodies] == pytest.approx([5.0, 5.0])
    pts = sample_contacts(part, 4000, seed=0).points
    # nothing sampled on the facing sides: a point there is 0.5 in from the outer faces
    inner = (np.abs(pts[:, 0] - 0.5 - gap / 2) < 2 * gap) & (np.abs(pts[:, 1:]) < 0.5 - 1e-6).all(1)
    assert not inner.any()
    # the exposed area is sampled uniformly: the two ends hold 1 / 10 of it each
    assert np.mean(pts[:, 0] < -0.5 + 1e-9) == pytest.approx(0.1, abs=0.02)


def test_overlapping_closed_bodies_are_united(tmp_path: Path) -> None:
    path = _obj(tmp_path / "cross.obj", {"a": _box((1, 1, 1), (0, 0, 0)),
                                         "b": _box((1, 1, 1), (0.5, 0.5, 0))})
    part = load_part(path)
    assert len(part.bodies) == 1 and part.bodies[0].closed and not part.bodies[0].convex
    assert part.volume == pytest.approx(1.75)
    # centre of mass of the union: two unit cubes minus the doubly counted quarter
    expect = (np.array([0, 0, 0]) + np.array([0.5, 0.5, 0]) - 0.25 * np.array([0.25, 0.25, 0]))
    assert np.allclose(part.center_mass, expect / 1.75)
    assert any("united 2 overlapping bodies" in r for r in part.repairs)
    assert (part.face_exposure == 2).all()
    # the seam of the union is a crease: its two inside corners are concave edges
    assert len(part.features.edges_of_kind("concave")) >= 2


def test_a_void_that_overlapping_bodies_enclose_is_filled(tmp_path: Path) -> None:
    # six walls of a box, each overlapping its neighbours: their union is a shell around a
    # void, which manifold3d gives as a piece of its own, of negative volume; as a body of
    # its own it was an open sheet (two bodies, the second not closed)
    t = 0.1
    walls = {f"w{i}": _box(np.where(np.arange(3) == i % 3, t, 1.0),
                           np.where(np.arange(3) == i % 3, (0.5 - t / 2) * (1 - 2 * (i // 3)),
                                    0.0)) for i in range(6)}
    part = load_part(_obj(tmp_path / "hollow.obj", walls))
    assert len(part.bodies) == 1 and part.bodies[0].closed and part.bodies[0].convex
    # a unit cube (as before: the outer wall counted the void as material already)
    assert part.volume == pytest.approx(1.0)
    assert any("filled 1 void it enclosed (volume 0.512)" in r for r in part.repairs)
    raw = trimesh.load(tmp_path / "hollow.obj", force="mesh")
    assert np.allclose(part.mesh.bounds, raw.bounds)


def test_objects_far_apart_plan_one_and_say_which(tmp_path: Path, capsys) -> None:
    path = _obj(tmp_path / "two.obj", {"big": _box((1, 1, 1), (0, 0, 0)),
                                       "small": _box((0.2, 0.2, 0.2), (10, 0, 0))})
    part = load_part(path)
    assert part.volume == pytest.approx(1.0) and len(part.dropped) == 1
    assert "small" in part.dropped[0] and "--body" in part.dropped[0]
    assert load_part(path, body="small").volume == pytest.approx(0.008)
    assert load_part(path, body=1).volume == pytest.approx(0.008)
    both = load_part(path, body="all")
    assert len(both.bodies) == 2 and both.dropped == ()
    code = main(["plan", str(path), "--quiet", "--no-files", "--evals", "2000"])
    err = capsys.readouterr().err
    assert code == 0 and err.count("dropped object") == 1 and "small" in err


def test_bodies_are_grouped_as_by_their_exact_gap(monkeypatch) -> None:
    """The vertex shortcut of the grouping (two bodies with vertices within the gap are one
    object) groups as FCL's exact gap alone does: boxes whose corners are within the gap,
    boxes with a gap smaller than the threshold but no vertices that close (face to face,
    corners offset), boxes apart; and the corpus's compounds."""
    from synth.part import compound

    thr_rtol = 0.05
    cases = {  # diagonal of all bodies about 2.3-3.5: threshold about 0.12-0.17
        "corners close": [_box((1, 1, 1), (0, 0, 0)), _box((1, 1, 1), (1.05, 0, 0))],
        "faces close, corners not": [_box((1, 1, 1), (0, 0, 0)),
                                     _box((0.3, 0.3, 1), (0.65, 0, 0.0))],
        "apart": [_box((1, 1, 1), (0, 0, 0)), _box((1, 1, 1), (1.5, 0, 0))],
    }
    for name in ("pybullet_teddy_vhacd.obj", "pybullet_random_blob086_100hulls.obj",
                 "pybullet_mug.obj"):
        scene = trimesh.load(CORPUS / name, group_material=False, split_object=True)
        meshes = [g for g in scene.geometry.values()] if hasattr(scene, "geometry") else \
            scene.split(only_watertight=False)
        cases[name] = list(meshes)
    shortcut = compound._close_corners
    used = []
    for name, meshes in cases.items():
        closed = [m.is_watertight for m in meshes]
        monkeypatch.setattr(compound, "_close_corners", lambda *a: used.append(shortcut(*a))
                            or used[-1])
        fast = compound.group_bodies(meshes, closed, thr_rtol)
        monkeypatch.setattr(compound, "_close_corners", lambda *a: False)
        exact = compound.group_bodies(meshes, closed, thr_rtol)
        assert fast == exact, name
    assert any(used) and not all(used)  # it decided some pairs, and left some to FCL


def test_open_piece_is_kept_as_a_surface_fingers_collide_with(tmp_path: Path) -> None:
    sheet = trimesh.Trimesh([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]],
                            [[0, 1, 2], [0, 2, 3]])
    sheet.apply_translation((0, 0, 0.5 + 1e-3))  # a single-sided surface just above the lid
    path = _obj(tmp_path / "lid.obj", {"box": _box((1, 1, 1), (0, 0, 0)), "sheet": sheet})
    part = load_part(path)
    kinds = {b.name: b.closed for b in part.bodies}
    assert kinds == {"box": True, "sheet": False}
    assert any("open surfaces" in w and "sheet" in w for w in part.warnings)
    assert part.volume == pytest.approx(1.0) and np.allclose(part.center_mass, 0)
    fingers = default_fingers(part)
    under = check_fingers(part, [[0.0, 0.0, 0.5]], [[0.0, 0.0, -1.0]], fingers)
    beside = check_fingers(part, [[0.0, -0.5, 0.0]], [[0.0, 1.0, 0.0]], fingers)
    assert not under.mask[0] and beside.mask[0]


@pytest.mark.parametrize("solid", ["sphere", "box"])
def test_exposure_of_fine_bodies_by_trees_and_balls(solid: str, tmp_path: Path,
                                                    monkeypatch) -> None:
    """A convex solid that a fine open strip crosses: a sphere of 5,120 faces (tested by its
    tree rather than 5,120 planes) or a box (by its 12 faces' planes). The strip's points
    inside the solid are hidden, as trimesh's own inside test says; and the faces decided
    at once by a ball round their samples get the exposure that their samples one by one
    give."""
    from synth.part import bodies as bodies_mod

    sphere = (trimesh.creation.icosphere(subdivisions=4) if solid == "sphere"
              else trimesh.creation.box((1.6, 1.6, 1.6)))
    x = np.linspace(-1.2, 1.2, 17) + 0.0012  # a strip of 16 squares through the solid
    strip = trimesh.Trimesh(
        np.column_stack([np.repeat(x, 2), np.tile([-0.075, 0.075], 17), np.full(34, 0.1)]),
        [f for i in range(16) for f in ([2 * i, 2 * i + 2, 2 * i + 3], [2 * i, 2 * i + 3,
                                                                      2 * i + 1])])
    for _ in range(5):
        strip = strip.subdivide()  # 32,768 faces, smaller than the exposure step
    path = _obj(tmp_path / "crossed.obj", {"ball": sphere, "strip": strip})
    part = load_part(path)
    assert len(part.bodies) == 2
    assert (len(sphere.faces) > bodies_mod._PLANES_MAX) == (solid == "sphere")
    pieces = Pieces(path)
    rng = np.random.default_rng(2)
    pts, faces = trimesh.sample.sample_surface(part.mesh, 3000, seed=rng)
    inward = -part.mesh.face_normals[faces]
    mine = part.exposed(pts, inward)
    depth = pieces.inside_depth(pts - 2e-3 * part.length * inward)
    sure = np.abs(depth) > 1e-3 * part.length
    assert sure.mean() > 0.9 and (~mine[sure]).sum() > 40  # 61 of 3,000: the strip is small
    assert np.array_equal(mine[sure], depth[sure] < 0)
    # the same exposure with no face decided by its ball
    decided = []
    clear = bodies_mod.Solids.clear
    monkeypatch.setattr(bodies_mod.Solids, "clear", lambda self, *a: decided.append(
        clear(self, *a)) or decided[-1])
    load_part(path)
    assert np.concatenate(decided).sum() > 5_000  # 5,586 of the strip's faces, outside it
    monkeypatch.setattr(bodies_mod.Solids, "clear", lambda self, p, *a: np.zeros(len(p), bool))
    one_by_one = load_part(path)
    assert np.array_equal(one_by_one.face_exposure, part.face_exposure)
    assert [b.exposed_area for b in one_by_one.bodies] == [b.exposed_area for b in part.bodies]


def test_face_exposure_agrees_with_exposed_when_the_margin_exceeds_the_step(
        tmp_path: Path) -> None:
    """Two boxes of 1-2 cm written in metres with 4 decimals: the coordinates' rounding
    makes the exposure margin (4 x 5e-5) larger than its step (8e-5), and a convex body
    then hides even the points stepped off its own faces; the faces' exposure must say what
    ``Part.exposed`` says at their centres (a convex body skipping its own faces did not)."""
    lines, off = [], 0
    for name, size, z in (("big", 0.02, 0.0), ("small", 0.01, 0.0151)):
        box = trimesh.creation.box((size, size, size)).apply_translation((0.0, 0.0, z))
        lines.append(f"o {name}")
        lines += [f"v {x:.4f} {y:.4f} {w:.4f}" for x, y, w in box.vertices]
        lines += [f"f {i + 1 + off} {j + 1 + off} {k + 1 + off}" for i, j, k in box.faces]
        off += len(box.vertices)
    path = tmp_path / "coarse.obj"
    path.write_text("\n".join(lines) + "\n")
    part = load_part(path)
    step, margin, _ = part._exposure_step()
    assert len(part.bodies) == 2 and all(b.convex for b in part.bodies) and margin > step
    at_centres = part.exposed(part.mesh.triangles_center, -part.mesh.face_normals)
    assert np.array_equal(part.face_exposure == 2, at_centres)


@pytest.mark.parametrize("name", ["coacd_robosuite_bread.obj", "pybullet_mug_collision.obj",
                                  "robosuite_bd_gripper_stator_collision.obj"])
def test_exposure_agrees_with_an_independent_inside_test(name: str) -> None:
    path = CORPUS / name
    part = load_part(path)
    pieces = Pieces(path)  # the file's own pieces, never united, trimesh's inside test
    rng = np.random.default_rng(4)
    pts, faces = trimesh.sample.sample_surface(part.mesh, 3000, seed=rng)
    inward = -part.mesh.face_normals[faces]
    mine = part.exposed(pts, inward)
    step = 2e-3 * part.length
    depth = pieces.inside_depth(pts - step * inward)
    sure = np.abs(depth) > 1e-3 * part.length  # away from the boundary of a piece
    assert sure.mean() > 0.9
    assert np.array_equal(mine[sure], depth[sure] < 0)
    assert (~mine).sum() > 20  # the test saw hidden points


def test_convex_decomposition_mass_properties_are_those_of_the_whole() -> None:
    part = load_part(CORPUS / "coacd_robosuite_bread.obj", units="m")
    loaded = trimesh.load(CORPUS / "coacd_robosuite_bread.obj", split_objects=True,
                          group_material=False)
    pieces = list(loaded.geometry.values())
    vol = np.array([p.volume for p in pieces])
    centre = (vol[:, None] * np.array([p.center_mass for p in pieces])).sum(0) / vol.sum()
    assert part.volume == pytest.approx(vol.sum(), rel=1e-9)
    assert np.allclose(part.center_mass, centre, rtol=0, atol=1e-9 * part.length)
    assert len(part.bodies) == len(pieces)


def test_union_seam_through_a_vertex_is_not_smoothed_over() -> None:
    """The BD gripper mover's three overlapping bodies are united; at this point of the
    exposed surface the seam passes through a corner of the face, and its two sides connect
    elsewhere. The normal there is interpolated from the faces on this side of the seam only,
    so it lies in the independent check's cone of the faces touched and their neighbours (it
    leaned 3 degrees into the other body's faces when corner normals spanned the whole smooth
    group: 12 of 4,000 sampled normals of this part fell outside that cone)."""
    from tests.independent_check import _in_cone

    path = Path(__file__).resolve().parent.parent / "meshes" / "corpus" / (
        "robosuite_bd_gripper_mover_collision.obj")
    part = load_part(path, units="m")
    p = np.array([0.026753869698922676, 0.0411834455903789, 0.015534694462452862])
    c = part.resolve(p[None])
    assert c.features.tolist() == ["face"]
    pieces = Pieces(path)
    faces = pieces.touched(p)
    assert len(faces) and _in_cone(c.normals[0], pieces.normal_cone(faces))


@pytest.mark.parametrize("name", ["robosuite_bd_gripper_stator_collision.obj",
                                  "robosuite_bd_gripper_mover_collision.obj",
                                  "gymrobotics_fetch_shoulder_lift_collision.stl"])
def test_faces_a_repair_tilted_keep_the_normals_of_the_file_triangles(name: str) -> None:
    """Merging a sliver's corners moves them by up to the coordinates' precision, which
    tilted small faces of the gripper's stator (after its union) and mover (in its pieces,
    before) by up to 1e-3 rad: a contact there had a d* 7e-5 off the one the file's own
    normals give (the corpus check found it). Every face of the part whose centre lies inside
    exactly one of the file's triangles (trimesh's own reading of the file, away from the
    triangle's edges) has that triangle's normal; on the STL, the one its corners give, not
    the one the file stores (float32, up to 4e-4 rad off). Faces under 1,000 times the
    coordinates' precision high are left out: their corners do not fix their normals."""
    part = load_part(CORPUS / name)
    pieces = Pieces(CORPUS / name)
    tri = np.asarray(part.mesh.triangles, float)
    centre = tri.mean(axis=1)
    inner = (0.5 * centre[:, None] + 0.25 * tri[:, [1, 2, 0]] + 0.25 * tri[:, [2, 0, 1]])
    normals = np.asarray(part.mesh.face_normals, float)
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    height = 2.0 * np.asarray(part.mesh.area_faces) / longest
    checked = worst = 0
    for f in range(len(tri)):
        if height[f] < 1e3 * part.precision:
            continue  # its corners' rounding leaves its normal open by over 1e-3 rad
        touched = [pieces.touched(p) for p in (centre[f], *inner[f])]
        if any(len(t) != 1 for t in touched) or len({int(t[0]) for t in touched}) != 1:
            continue  # near a file edge, or on two coplanar triangles
        checked += 1
        worst = max(worst, float(np.linalg.norm(normals[f] - pieces.normals[touched[0][0]])))
    assert checked > 0.5 * len(tri)
    assert worst < 1e-9
