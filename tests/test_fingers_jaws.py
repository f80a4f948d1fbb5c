"""Closing the jaws: where the pads land on hand-made parts."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from synth.fingers.gripper import load_gripper
from synth.fingers.jaws import LANDED, TOO_WIDE, close_jaws
from tests.gripper_check import point_triangle_distance

FRANKA = load_gripper("franka")  # metres
TCP = FRANKA.tcp


def _pose(centre, shift=(0.0, 0.0, 0.0)):
    """The gripper's frame axes-aligned, its TCP at ``centre`` + ``shift``."""
    T = np.eye(4)
    T[:3, 3] = np.asarray(centre, float) + shift - TCP
    return T


def _close(mesh, poses):
    return close_jaws(np.asarray(mesh.vertices), np.asarray(mesh.faces),
                      np.asarray(mesh.face_normals), np.asarray(poses), FRANKA, 1e-9)


def test_a_box_pinched_lands_on_its_faces():
    box = trimesh.creation.box(extents=(0.04, 0.06, 0.06))
    res = _close(box, [_pose([0, 0, 0], (0.007, 0.003, -0.004))])  # off centre along x too
    assert res.status.tolist() == [LANDED]
    assert res.width[0] == pytest.approx(0.04)
    assert res.poses[0, 0, 3] == pytest.approx(0.0, abs=1e-12)  # recentred on the part
    assert np.allclose(res.points[0, :, 0], [0.02, -0.02])
    # the pad (17 x 17.5 mm) lies inside the face: the patch is the pad itself, its centre
    # the pad's centre (0.05 mm below the TCP on the Franka Hand)
    pad_z = -0.004 + FRANKA.pad_center[1] - TCP[2]
    assert np.allclose(res.points[0, :, 1:], [[0.003, pad_z]] * 2, atol=1e-12)
    assert np.allclose(res.normals[0], [[-1, 0, 0], [1, 0, 0]])
    assert res.patch[0] == pytest.approx(np.hypot(0.017, 0.0175), rel=1e-9)


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
