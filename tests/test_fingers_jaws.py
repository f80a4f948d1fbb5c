"""Closing the jaws: where the pads land on hand-made parts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.fingers.gripper import load_gripper
from synth.fingers.jaws import EDGE_TOUCH, LANDED, TOO_WIDE, close_jaws
from tests.gripper_check import check_grasp, point_triangle_distance

FRANKA = load_gripper("franka")  # metres
TCP = FRANKA.tcp
HW, PH = FRANKA.pad_size[0] / 2, FRANKA.pad_size[1]  # the pad's half-width (8.73 mm), height


def _pose(centre, shift=(0.0, 0.0, 0.0)):
    """The gripper's frame axes-aligned, its TCP at ``centre`` + ``shift``."""
    T = np.eye(4)
    T[:3, 3] = np.asarray(centre, float) + shift - TCP
    return T


def _close(mesh, poses, tol=1e-9):
    return close_jaws(np.asarray(mesh.vertices), np.asarray(mesh.faces),
                      np.asarray(mesh.face_normals), np.asarray(poses), FRANKA, tol)


def _tilted_box(degrees):
    """A 40 x 60 x 60 mm box whose +x face is turned by ``degrees`` about z: the plane
    ``x + tan(a) y = 0.02``, outward normal ``(cos a, sin a, 0)``; the -x face at x = -0.02."""
    k = np.tan(np.radians(degrees))
    V = [[-0.02, y, z] for y in (-0.03, 0.03) for z in (-0.03, 0.03)]
    V += [[0.02 - k * y, y, z] for y in (-0.03, 0.03) for z in (-0.03, 0.03)]
    return trimesh.convex.convex_hull(np.array(V))


def test_a_box_pinched_lands_on_its_faces():
    box = trimesh.creation.box(extents=(0.04, 0.06, 0.06))
    res = _close(box, [_pose([0, 0, 0], (0.007, 0.003, -0.004))])  # off centre along x too
    assert res.status.tolist() == [LANDED]
    assert res.width[0] == pytest.approx(0.04)
    assert res.poses[0, 0, 3] == pytest.approx(0.0, abs=1e-12)  # recentred on the part
    assert np.allclose(res.points[0, :, 0], [0.02, -0.02])
    # the pad (17.5 x 17.6 mm) lies inside the face: the patch is the pad itself, its centre
    # the pad's centre (0.05 mm below the TCP on the Franka Hand)
    pad_z = -0.004 + FRANKA.pad_center[1] - TCP[2]
    assert np.allclose(res.points[0, :, 1:], [[0.003, pad_z]] * 2, atol=1e-12)
    assert np.allclose(res.normals[0], [[-1, 0, 0], [1, 0, 0]])
    assert res.patch[0] == pytest.approx(np.hypot(2 * HW, PH), rel=1e-9)


def test_a_patch_of_two_ridges_keeps_its_contact_on_the_part():
    ridges = trimesh.util.concatenate([
        trimesh.creation.box(extents=(0.03, 0.004, 0.06), transform=trimesh.transformations
                             .translation_matrix([0, y, 0])) for y in (-0.006, 0.006)])
    res = _close(ridges, [_pose([0, 0, 0])])
    assert res.status.tolist() == [LANDED]
    T = ridges.triangles
    for p in res.points[0]:
        assert point_triangle_distance(p, T).min() < 1e-12  # not the gap's middle
    assert abs(res.points[0, 0, 1]) == pytest.approx(0.004)  # the ridge's inner side


def test_an_apex_in_the_pad_is_a_point_contact_with_the_pads_normal():
    cone = trimesh.creation.cone(radius=0.01, height=0.02, sections=16)
    cone.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    both = trimesh.util.concatenate([cone, cone.copy().apply_transform(
        trimesh.transformations.rotation_matrix(np.pi, [0, 0, 1]))])  # apexes at x = +-0.02
    res = _close(both, [_pose([0, 0, 0])])
    assert res.status.tolist() == [LANDED]
    assert res.width[0] == pytest.approx(0.04)
    assert res.patch[0].tolist() == [0.0, 0.0]
    assert np.allclose(res.points[0], [[0.02, 0, 0], [-0.02, 0, 0]], atol=1e-12)


def test_a_part_wider_than_the_opening():
    box = trimesh.creation.box(extents=(0.1, 0.03, 0.03))
    res = _close(box, [_pose([0, 0, 0])])
    assert res.status.tolist() == [TOO_WIDE] and res.width[0] == pytest.approx(0.1)


def test_a_pad_closes_on_the_near_wall_not_on_the_part_behind_the_other_pad():
    # a mug's rim in section: the wall grasped (4 mm thick, at x = 0) and the far wall 60 mm
    # away, beyond the -x pad's open position (40 mm): the pads close on the near wall
    near = trimesh.creation.box(extents=(0.004, 0.05, 0.06))
    far = trimesh.creation.box(extents=(0.004, 0.05, 0.06))
    far.apply_translation([-0.06, 0, 0])
    res = _close(trimesh.util.concatenate([near, far]), [_pose([0, 0, 0])])
    assert res.status.tolist() == [LANDED]
    assert res.width[0] == pytest.approx(0.004, abs=1e-12)
    assert np.allclose(res.points[0, :, 0], [0.002, -0.002], atol=1e-12)


def test_a_ridge_across_the_pad_is_a_contact():
    # a square bar turned 45 degrees about z: its vertical edges cross each pad from bottom to
    # top (every candidate point of the touch lies on the pad's rim, the middle does not)
    bar = trimesh.creation.box(extents=(0.03, 0.03, 0.1))
    bar.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 4, [0, 0, 1]))
    half = 0.015 * np.sqrt(2.0)
    res = _close(bar, [_pose([0, 0, 0])])
    assert res.status.tolist() == [LANDED]
    assert res.width[0] == pytest.approx(2 * half, rel=1e-12)
    assert np.allclose(res.points[0, :, :2], [[half, 0.0], [-half, 0.0]], atol=1e-12)


def test_a_pad_rim_on_a_face_tilted_10_degrees_is_a_contact_with_the_faces_normal():
    # the +x face falls away along +y, so inside the +x pad (y in +-HW, 8.73 mm) it reaches
    # furthest along x on the pad's rim side y = -HW, all along it: the contact is the
    # middle of that side, x = 0.02 + HW tan(10 deg), with the face's inward normal
    a = np.radians(10.0)
    res = _close(_tilted_box(10.0), [_pose([0, 0, 0])])
    assert res.status.tolist() == [LANDED]
    pad_z = FRANKA.pad_center[1] - TCP[2]
    x_rim = 0.02 + HW * np.tan(a)
    assert res.width[0] == pytest.approx(x_rim + 0.02, rel=1e-12)
    assert np.allclose(res.points[0, 0], [x_rim, -HW, pad_z], atol=1e-12)
    assert np.allclose(res.normals[0, 0], [-np.cos(a), -np.sin(a), 0.0], atol=1e-12)
    assert res.patch[0, 0] == pytest.approx(PH, rel=1e-9)  # the rim side's length
    # the -x pad lies flat on its face: the pad's normal, where it faces the rim contact (a
    # patch presses anywhere within it, so the squeeze passes along the closing axis)
    assert np.allclose(res.points[0, 1], [-0.02, -HW, pad_z], atol=1e-12)
    assert np.allclose(res.normals[0, 1], [1.0, 0.0, 0.0], atol=1e-12)


def test_a_face_tilted_under_one_degree_is_flush_a_patch_with_the_pads_normal():
    # 0.5 degrees: across the pad's 17.5 mm the face drops 0.152 mm, within the touch tolerance
    # of 0.2 mm, so the whole pad touches: a patch centred on the pad, the pad's normal
    res = _close(_tilted_box(0.5), [_pose([0, 0, 0])], tol=2e-4)
    assert res.status.tolist() == [LANDED]
    pad_z = FRANKA.pad_center[1] - TCP[2]
    x_rim = 0.02 + HW * np.tan(np.radians(0.5))
    assert res.width[0] == pytest.approx(x_rim + 0.02, rel=1e-12)
    # in the pad's plane (the touch's extreme), within the tolerance of the face
    assert np.allclose(res.points[0, 0], [x_rim, 0.0, pad_z], atol=1e-12)
    assert np.allclose(res.normals[0], [[-1, 0, 0], [1, 0, 0]], atol=1e-12)
    assert res.patch[0, 0] == pytest.approx(np.hypot(2 * HW, PH), rel=1e-9)


def _roof(t, k):
    """A box 40 mm deep whose +x side is a roof ``x = 0.02 - t y - k |z - z_r|`` with its
    ridge at the pad's height ``z_r``; the -x face at x = -0.02."""
    zr = FRANKA.pad_center[1] - TCP[2]
    V = [[-0.02, y, z] for y in (-0.03, 0.03) for z in (-0.03, 0.03)]
    V += [[0.02 - t * y - k * abs(z - zr), y, z] for y in (-0.03, 0.03) for z in (-0.03, zr, 0.03)]
    return trimesh.convex.convex_hull(np.array(V))


def test_a_pad_rim_across_a_ridge_is_a_contact_normal_to_rim_and_ridge():
    # along the +x pad's rim side y = -HW the roof peaks on its ridge, z = z_r: the
    # contact; its faces' normals (1, t, +-k) combine, with nothing along the rim (z), into
    # (1, t, 0): perpendicular to the rim and to the ridge (-t, 1, 0), between the faces'
    t, k = np.tan(np.radians(10.0)), 0.5
    res = _close(_roof(t, k), [_pose([0, 0, 0])])
    assert res.status.tolist() == [LANDED]
    zr = FRANKA.pad_center[1] - TCP[2]
    x_rim = 0.02 + HW * t
    assert res.width[0] == pytest.approx(x_rim + 0.02, rel=1e-12)
    assert np.allclose(res.points[0, 0], [x_rim, -HW, zr], atol=1e-12)
    assert np.allclose(res.normals[0, 0], -np.array([1.0, t, 0.0]) / np.hypot(1.0, t),
                       atol=1e-12)


def test_rim_contacts_pass_the_independent_check_and_a_wrong_normal_fails_it(tmp_path):
    # the check (tests/gripper_check.py) reads the mesh file and the gripper's description
    t, k = np.tan(np.radians(10.0)), 0.5
    path = tmp_path / "roof.stl"
    _roof(t, k).export(path)
    tilted = tmp_path / "tilted.stl"
    _tilted_box(10.0).export(tilted)
    desc = Path(__file__).parents[1] / "synth" / "fingers" / "grippers" / "franka.json"
    for mesh in (path, tilted):
        part = trimesh.load(mesh)
        res = _close(part, [_pose([0, 0, 0])])
        g = {"pose": res.poses[0].tolist(), "width": float(res.width[0]),
             "contacts": [{"point": p.tolist(), "normal": n.tolist()}
                          for p, n in zip(res.points[0], res.normals[0])]}
        assert check_grasp(g, mesh, desc, 1.0, 0.5, 1e-4) == []
        bad = [dict(c) for c in g["contacts"]]
        n = np.array(bad[0]["normal"]) + [0.0, 0.0, 0.1]  # off the plane normal to the rim
        bad[0]["normal"] = (n / np.linalg.norm(n)).tolist()
        assert any("neither its pad's" in e for e in check_grasp(dict(g, contacts=bad), mesh,
                                                                 desc, 1.0, 0.5, 1e-4))


def test_a_pad_rim_buried_in_a_slope_is_no_contact():
    # 70 degrees: inside the +x pad the face runs from x = 0.02 + HW tan(70) = 0.043,
    # behind the open pad (half the opening, 0.04), down to -0.003 on the other rim side,
    # the only part of it between the open pads: the pad is buried in the slope there
    res = _close(_tilted_box(70.0), [_pose([0, 0, 0])])
    assert res.status.tolist() == [EDGE_TOUCH]


def _groove(slope):
    """A box 40 mm deep whose +x face has a groove along z, x = 0.02 + slope |y|."""
    y = np.array([-0.03, 0.0, 0.03])
    outline = np.column_stack([np.r_[-0.02, 0.02 + slope * np.abs(y), -0.02],
                               np.r_[-0.03, y, 0.03]])
    n = len(outline)
    V = np.vstack([np.column_stack([outline, np.full(n, z)]) for z in (-0.03, 0.03)])
    F = [[0, i + 1, i] for i in range(1, n - 1)] + [[n, n + i, n + i + 1] for i in range(1, n - 1)]
    F += [f for i in range(n) for f in ([i, (i + 1) % n, n + (i + 1) % n],
                                         [i, n + (i + 1) % n, n + i])]
    groove = trimesh.Trimesh(V, F)
    groove.fix_normals()
    assert groove.is_watertight and groove.volume > 0
    return groove


def test_a_pad_across_a_shallow_groove_rests_on_both_sides():
    # x = 0.02 + 0.2 |y|: both rim sides of the +x pad (y = +-HW) touch at once, at
    # x = 0.0217, and the groove's middle lies 0.2 HW = 1.7 mm behind the pad, a rise of
    # 0.2 of half the span (at most GROOVE_RISE = 0.25): the pad rests on both sides and
    # presses along its own normal; the contact is the groove's bottom under the pad's middle
    res = _close(_groove(0.2), [_pose([0, 0, 0])], tol=1e-5)
    assert res.status.tolist() == [LANDED]
    pad_z = FRANKA.pad_center[1] - TCP[2]
    assert res.width[0] == pytest.approx(0.02 + 0.2 * HW + 0.02, rel=1e-12)
    assert np.allclose(res.points[0, 0], [0.02, 0.0, pad_z], atol=1e-12)
    assert np.allclose(res.normals[0], [[-1, 0, 0], [1, 0, 0]], atol=1e-12)
    # x = 0.02 + 0.3 |y| rises 0.3 of half the span: the pad does not rest in it
    res = _close(_groove(0.3), [_pose([0, 0, 0])], tol=1e-5)
    assert res.status.tolist() == [EDGE_TOUCH]


def test_a_groove_contact_passes_the_independent_check_and_a_deep_one_fails_it(tmp_path):
    desc = Path(__file__).parents[1] / "synth" / "fingers" / "grippers" / "franka.json"
    path = tmp_path / "groove.stl"
    _groove(0.2).export(path)
    res = _close(trimesh.load(path), [_pose([0, 0, 0])], tol=1e-5)
    g = {"pose": res.poses[0].tolist(), "width": float(res.width[0]),
         "contacts": [{"point": p.tolist(), "normal": n.tolist()}
                      for p, n in zip(res.points[0], res.normals[0])]}
    assert check_grasp(g, path, desc, 1.0, 0.5, 1e-4) == []
    # the same contact in a groove twice as steep lies twice as deep behind the pad: the pad
    # cannot rest across it (0.4 of half the span), so the check refuses the point
    steep = tmp_path / "steep.stl"
    _groove(0.4).export(steep)
    x_rim = 0.02 + 0.4 * HW  # the pads at the steep groove's rims and at x = -0.02
    deep = dict(g, pose=_pose([(x_rim - 0.02) / 2, 0, 0]).tolist(), width=x_rim + 0.02)
    errors = check_grasp(deep, steep, desc, 1.0, 0.5, 1e-4)
    assert any("contact 0 is not on its pad" in e for e in errors)


@pytest.mark.parametrize("scale, offset", [(1e-3, 0.0), (1e3, 0.0), (1.0, 30.0)])
def test_landing_does_not_depend_on_the_parts_size_or_place(scale, offset):
    # a tessellated cylinder under 800 random poses near it: scaled (the gripper and the
    # touch tolerance with it) or moved far from the origin, every pose lands the same way
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(5)
    R = Rotation.random(800, random_state=rng).as_matrix()
    c = rng.normal(size=(800, 3)) * 0.012
    base = trimesh.creation.cylinder(0.025, 0.08, sections=24)
    out = []
    for s, o in ((1.0, 0.0), (scale, offset)):
        m = base.copy()
        m.apply_scale(s)
        m.apply_translation([o, -o, o])
        T = np.tile(np.eye(4), (800, 1, 1))
        T[:, :3, :3] = R
        T[:, :3, 3] = c * s + [o, -o, o] - R @ (TCP * s)
        out.append(close_jaws(m.vertices, m.faces, m.face_normals, T, FRANKA.scaled(s),
                              1e-4 * s))
    a, b = out
    assert np.array_equal(a.status, b.status)
    assert np.isin([LANDED, EDGE_TOUCH], a.status).all()  # both outcomes occur
    ok = a.status == LANDED
    assert np.allclose(a.normals[ok], b.normals[ok], atol=1e-6)
    assert np.allclose(a.width[ok] * scale, b.width[ok], rtol=1e-6)
