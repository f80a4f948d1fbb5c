"""Finger checks against independent computations: trimesh signed distance, FCL, brute force."""

from __future__ import annotations

import math

import fcl
import numpy as np
import pytest
import trimesh

from synth.fingers import Fingers, check_fingers, tip_centers
from synth.fingers.collide import OK, OVERLAP, TIP_PENETRATES
from synth.fingers.geometry import (
    approach_directions,
    point_segment_distance,
    quaternions_to,
    segment_segment_distance,
)


def _bracket() -> trimesh.Trimesh:
    move = trimesh.transformations.translation_matrix
    floor = trimesh.creation.box((4, 2, 1), transform=move((2, 1, 0.5)))
    upright = trimesh.creation.box((1, 2, 4), transform=move((0.5, 1, 2)))
    mesh = trimesh.boolean.union([floor, upright], engine="manifold")
    assert mesh.is_watertight and mesh.volume == pytest.approx(4 * 2 + 3 * 2)
    return mesh


MESHES = {
    "box": lambda: trimesh.creation.box((2.0, 3.0, 1.0)),
    "cylinder": lambda: trimesh.creation.cylinder(radius=1.0, height=2.0, sections=32),
    "icosphere": lambda: trimesh.creation.icosphere(subdivisions=3, radius=1.5),
    "bracket": _bracket,
}


@pytest.mark.parametrize("name", sorted(MESHES))
def test_tip_against_part_agrees_with_trimesh_signed_distance(name):
    """Tip check == (trimesh's signed distance of the tip centre < r - tol), shifted contacts."""
    mesh = MESHES[name]()
    rng = np.random.default_rng(7)
    n = 300
    points, faces = trimesh.sample.sample_surface(mesh, n, seed=11)
    normals = -mesh.face_normals[faces]
    r = 0.08 if name != "bracket" else 0.3
    fingers = Fingers(tip_radius=r, body_length=4 * r, body_radius=0.5 * r)
    # a third on the surface, a third shifted inward, a third outward, by up to half a radius
    shift = rng.uniform(0.0, 0.5 * r, n) * np.repeat([0.0, 1.0, -1.0], n // 3)
    shifted = points + shift[:, None] * normals
    res = check_fingers(mesh, shifted[:, None], normals[:, None], fingers)
    centre = shifted - r * normals
    np.testing.assert_allclose(res.tip_centers[:, 0], centre)
    clearance = -trimesh.proximity.signed_distance(mesh, centre)  # trimesh: positive inside
    depth = r - clearance
    tol = fingers.penetration_tol
    decided = np.abs(depth - tol) > 1e-9
    expected = depth > tol
    got = res.status[:, 0] == TIP_PENETRATES
    assert np.array_equal(got[decided], expected[decided])
    assert expected.sum() >= 50 and (~expected).sum() >= 50  # both outcomes are exercised
    # Straight-out approaches are free on these shapes (the bracket's too: every outward
    # normal ray leaves it), so a grasp is accepted exactly when its tip does not penetrate.
    assert np.array_equal(res.mask[decided], ~expected[decided])
    assert np.all(res.status[res.mask, 0] == OK)


def _finger_object(c, a, radius, length, kind):
    if kind == "tip":
        return fcl.CollisionObject(fcl.Sphere(radius), fcl.Transform(c))
    q = quaternions_to(a[None])[0]
    return fcl.CollisionObject(fcl.Capsule(radius, length), fcl.Transform(q, c + 0.5 * length * a))


def test_finger_overlaps_agree_with_fcl():
    """Numpy tip/body distances decide overlaps exactly like FCL on the same shapes."""
    rng = np.random.default_rng(3)
    far_part = trimesh.creation.box((0.1, 0.1, 0.1))  # far below, never in the way
    far_part.apply_translation((0.0, 0.0, -100.0))
    r, rb, length = 0.3, 0.2, 2.0
    fingers = Fingers(tip_radius=r, body_length=length, body_radius=rb)
    tol = fingers.penetration_tol
    B = 400
    points = rng.uniform(-1.0, 1.0, (B, 2, 3))
    up = rng.normal(size=(B, 2, 3))
    up[..., 2] = np.abs(up[..., 2]) + 0.3  # approach directions away from the part below
    up /= np.linalg.norm(up, axis=-1, keepdims=True)
    res = check_fingers(far_part, points, -up, fingers)
    expected = np.zeros(B, dtype=bool)
    for b in range(B):
        c, a = res.tip_centers[b], res.approach[b] if res.mask[b] else up[b]
        # shrink every shape by tol / 2: overlap deeper than tol <=> the shrunk shapes collide
        shapes = [
            [
                _finger_object(c[i], a[i], r - tol / 2, 0.0, "tip"),
                _finger_object(c[i], a[i], rb - tol / 2, length, "body"),
            ]
            for i in range(2)
        ]
        expected[b] = any(
            fcl.collide(s, t, fcl.CollisionRequest(), fcl.CollisionResult())
            for s in shapes[0]
            for t in shapes[1]
        )
    assert np.array_equal(res.status[:, 0] == OVERLAP, expected)
    assert np.array_equal(res.mask, ~expected)
    assert 50 <= expected.sum() <= B - 50


def test_shared_tip_centres_solve_the_corner():
    """Contacts generated from a known tip centre in a groove or a corner give it back."""
    rng = np.random.default_rng(5)
    r = 0.4
    for m in (1, 2, 3):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        normals = q[:, :m].T  # m orthonormal inward normals
        tilt = rng.normal(size=(m, 3)) * 0.2  # and non-orthogonal ones
        normals = normals + tilt
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        centre = rng.normal(size=3)
        points = centre + r * normals
        ids = np.zeros(m, dtype=int)
        c, present, misfit, _ = tip_centers(points[None], normals[None], r, ids[None])
        assert present[0].tolist() == [True] + [False] * (m - 1)
        if m == 3:
            np.testing.assert_allclose(c[0, 0], centre, atol=1e-10)
        # along the free directions the least-norm solution still touches every plane
        planes = np.einsum("ij,ij->i", normals, points) - r  # n_j . c = n_j . p_j - r
        np.testing.assert_allclose(normals @ c[0, 0], planes, atol=1e-10)
        assert misfit[0, 0] < 1e-10


def test_segment_distances_agree_with_dense_sampling():
    rng = np.random.default_rng(9)
    p1, q1, p2, q2 = rng.normal(size=(4, 200, 3))
    q2[:20] = p2[:20]  # degenerate segments
    q1[20:30] = p1[20:30]
    p2[30:40] = p1[30:40] + 0.5 * (q1[30:40] - p1[30:40])  # touching
    q2[40:50] = p2[40:50] + (q1[40:50] - p1[40:50])  # parallel
    d = segment_segment_distance(p1, q1, p2, q2)
    t = np.linspace(0.0, 1.0, 801)
    a = p1[:, None] + t[None, :, None] * (q1 - p1)[:, None]  # (200, 801, 3)
    brute = np.array([
        point_segment_distance(a[i], np.broadcast_to(p2[i], a[i].shape),
                               np.broadcast_to(q2[i], a[i].shape)).min()
        for i in range(200)
    ])
    assert np.all(d <= brute + 1e-12)
    assert np.all(brute - d <= 2e-3 * np.linalg.norm(q1 - p1, axis=1) + 1e-12)


def test_approach_directions_lie_in_the_cone():
    rng = np.random.default_rng(2)
    axis = rng.normal(size=(50, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    axis[0] = (0.0, 0.0, -1.0)
    cone = math.radians(35)
    dirs = approach_directions(axis, cone)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=-1), 1.0)
    angles = np.arccos(np.clip(np.einsum("nmx,nx->nm", dirs, axis), -1, 1))
    np.testing.assert_allclose(angles[:, 0], 0.0, atol=1e-7)
    assert dirs.shape == (50, 13, 3)  # the axis, then two rings of six
    np.testing.assert_allclose(angles[:, 1:7], cone / 2, atol=1e-7)
    np.testing.assert_allclose(angles[:, 7:], cone, atol=1e-7)
    # deterministic
    np.testing.assert_array_equal(dirs, approach_directions(axis, cone))
    # quaternions turn +z onto each direction
    q = quaternions_to(dirs.reshape(-1, 3))
    w, v = q[:, :1], q[:, 1:]
    z = np.array([0.0, 0.0, 1.0])
    rotated = z + 2 * w * np.cross(v, z) + 2 * np.cross(v, np.cross(v, z))
    np.testing.assert_allclose(rotated, dirs.reshape(-1, 3), atol=1e-12)
