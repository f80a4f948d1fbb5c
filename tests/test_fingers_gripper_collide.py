"""The gripper's collision check (synth/fingers/gripper_collide.py): a hand wholly inside a
closed body, touching none of its triangles, is a hit; checked against trimesh's containment."""

from __future__ import annotations

import numpy as np
import trimesh

from synth.fingers.gripper import load_gripper
from synth.fingers.gripper_collide import APPROACH_HITS, CLEAR, GripperChecker
from synth.part import load_part


def test_a_hand_inside_a_closed_body_is_a_hit_and_outside_it_is_clear():
    part = load_part(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), units="m")
    g = load_gripper("franka")
    checker = GripperChecker(part, g, 0.1, 1e-3)
    inside, outside = np.eye(4), np.eye(4)
    inside[:3, 3] = [0.0, 0.0, -0.1]  # the hand and its 0.1 m approach well within the cube
    outside[:3, 3] = [0.0, 0.0, 0.7]  # above the cube, approaching away from it
    status = checker.check(np.stack([inside, outside]), np.array([0.04, 0.04]))
    assert status.tolist() == [APPROACH_HITS, CLEAR]
    # independently: every vertex of the posed hand inside the cube, none crossing its faces
    V = np.vstack([v for v, _ in g.meshes_at(0.04)]) + inside[:3, 3]
    assert part.mesh.contains(V).all() and np.abs(V).max() < 0.5


def test_a_mesh_object_fcl_would_crash_on_is_refused_by_name():
    """An empty face list or vertex list crashed the process inside FCL (a segfault); an index
    out of range was handed on. Each is an InputError now, and mesh_hits names a wrong obj."""
    import pytest

    from synth.errors import InputError
    from synth.fingers import checker_for

    checker = checker_for(load_part("meshes/cube.stl"))
    V, F = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]), np.array([[0, 1, 2]])
    for vertices, faces, message in ((V, np.zeros((0, 3), int), "no faces"),
                                     (np.zeros((0, 3)), F, "refers to vertex 0, but there are 0"),
                                     (V, [[0, 1, 99]], "refers to vertex 99"),
                                     (V * np.nan, F, "NaN or infinite")):
        with pytest.raises(InputError, match=f"^mesh_object: .*{message}"):
            checker.mesh_object(vertices, faces)
    assert checker.mesh_hits(checker.mesh_object(V, F), np.eye(3), [0.0, 0.0, 0.0])
    with pytest.raises(InputError, match="^mesh_hits: obj must come from mesh_object"):
        checker.mesh_hits(None, np.eye(3), [0.0, 0.0, 0.0])
