"""Face regions and corner normals (synth.part.regions): a face without a normal of its own."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from synth import PlanParams, load_part, plan_part

CORPUS = Path(__file__).resolve().parent.parent / "meshes" / "corpus"
#: The turn ``scripts/bench_db.py --corpus`` gave the robosuite stator's second copy.
TURN = np.array([[-0.8989350018420899, -0.0009758299943550541, -0.43808094025988387, 0.0],
                 [-0.3238350569326611, -0.6719920396474992, 0.6660011670799189, 0.0],
                 [-0.29503680849104574, 0.7405577265859942, 0.603761157436616, 0.0],
                 [0.0, 0.0, 0.0, 1.0]])


def test_a_sliver_without_a_normal_takes_its_neighbours(tmp_path):
    """Turned and stored as float32 PLY, the stator keeps a sliver (area 2.6e-14 on a 0.3
    part) that trimesh gives no normal; its one-face region drew contacts whose smooth
    normal was 0 / 0, and every plan of the part stopped with an internal error."""
    mesh = trimesh.load(CORPUS / "robosuite_bd_gripper_stator_collision.obj", force="mesh")
    mesh.apply_transform(TURN)
    mesh.export(tmp_path / "turned.ply")
    part = load_part(tmp_path / "turned.ply")
    none = np.flatnonzero(~(np.abs(part.mesh.face_normals).max(axis=1) > 0))
    assert len(none) == 1  # the case at hand: trimesh has no normal for one face
    corner = part._regions.corner_normals
    assert np.allclose(np.linalg.norm(corner, axis=2), 1.0)  # every corner has a unit normal
    # the sliver's: the mean inward normal of the faces across its edges
    f = int(none[0])
    ef = part.features.edge_faces[part.features.face_edges[f]]
    across = np.where(ef[:, 0] == f, ef[:, 1], ef[:, 0])
    mean = -np.asarray(part.mesh.face_normals, float)[across].sum(axis=0)
    assert np.allclose(corner[f], mean / np.linalg.norm(mean))
    plan = plan_part(part, PlanParams(seed=0, evals=2000))
    assert plan.grasps and all(np.isfinite(g.normals).all() for g in plan.grasps)
