"""Gripper grasps simulated as the scorer scored them: the least squeeze against gravity
predicts when MuJoCo's part stays between the two soft fingertips."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from synth.part import load_part  # noqa: E402
from synth.plan.gripper import GripperParams, plan_gripper  # noqa: E402
from synth.scores.gravity import least_squeeze_batch  # noqa: E402
from synth.sim import SimSettings  # noqa: E402
from synth.sim.jaws import simulate_jaw_document  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name, units", [("cube.stl", "cm"), ("prism.stl", "cm")])
def test_least_squeeze_predicts_the_gravity_stage(name, units):
    mesh = ROOT / "meshes" / name
    part = load_part(mesh, units=units)
    plan = plan_gripper(part, GripperParams(top=2, samples=60, torsion=0.05 * part.length))
    assert plan.grasps
    doc = plan.to_json()
    st = SimSettings()
    weight = st.density * part.volume * (st.size / part.length) ** 3 * 9.81
    for k, g in enumerate(plan.grasps):
        need = float(least_squeeze_batch(g.points[None], g.normals[None], 0.5,
                                         doc["model"]["torsion"], part.center_mass,
                                         part.length, [[0, 0, -1.0]])[0, 0])
        one = dict(doc, grasps=[doc["grasps"][k]])
        weak = simulate_jaw_document(one, part, mesh, SimSettings(grip=0.7 * need * weight,
                                                                  shake=0.0))
        strong = simulate_jaw_document(one, part, mesh, SimSettings(grip=1.5 * need * weight,
                                                                    shake=0.0))
        assert weak["grasps"][0]["sim"]["failed_at"] == "gravity"
        assert strong["grasps"][0]["sim"]["failed_at"] != "gravity"


def test_a_soft_pinch_has_no_predicted_escape_and_a_point_pinch_turns_about_its_line():
    # two opposed contacts on x: point contacts leave the turn about x free, soft ones
    # (torsion) resist it, so the simulation has no escape to compare the motion with
    from synth.sim.label import predicted_escape

    P = np.array([[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]])
    N = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    esc = predicted_escape(P, N, 0.5, np.zeros(3), 1.0)
    assert np.allclose(np.abs(esc.twist), [0, 0, 0, 1, 0, 0], atol=1e-6)
    assert predicted_escape(P, N, 0.5, np.zeros(3), 1.0, torsion=0.05) is None
