"""Gripper grasps simulated with the gripper's pads: a box pinched at its centre holds its
weight along the pads' plane by friction alone, up to ``2 mu F`` (both pads, each pressing with
the rated force ``F``), and across the pads by the fingers' coupling, whatever its weight."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

pytest.importorskip("mujoco")

from synth.errors import InputError  # noqa: E402
from synth.fingers.gripper import load_gripper  # noqa: E402
from synth.part import load_part  # noqa: E402
from synth.sim import SimSettings  # noqa: E402
from synth.sim.jaws import simulate_jaw_document  # noqa: E402

MU = 0.5


def _pinch(tmp_path, mass: float, units: str = "m"):
    """A 40 x 50 x 50 mm box between the Franka hand's pads, its centre at theirs, and the
    grasp document of that pinch (the pose is the identity: the mesh is in the hand's
    frame)."""
    franka = load_gripper("franka")
    scale = {"m": 1.0, "mm": 1000.0}[units]
    zc = float(franka.pad_center[1])
    box = trimesh.creation.box((0.04, 0.05, 0.05))
    box.apply_translation([0.0, 0.0, zc])
    box.apply_scale(scale)
    mesh = tmp_path / f"box_{units}.stl"
    box.export(mesh)
    part = load_part(mesh, units=units)
    c = np.array([0.0, 0.0, zc]) * scale
    doc = {
        "format": "synth.gripper_grasps", "version": 1,
        "mesh": {"units": units, "length": float(part.length), "body": "largest",
                 "sharp_angle": 30.0},
        "gripper": {"source": "franka"}, "params": {"gripper": "franka"},
        "model": {"mu": MU, "torsion": 0.005 * scale, "mass": mass},
        "grasps": [{"pose": np.eye(4).tolist(), "width": 0.04 * scale,
                    "contacts": [{"point": (c + [0.02 * scale, 0, 0]).tolist(),
                                  "normal": [-1.0, 0, 0]},
                                 {"point": (c - [0.02 * scale, 0, 0]).tolist(),
                                  "normal": [1.0, 0, 0]}],
                    "measures": {"d_star": 1.0}}],
    }
    return doc, part, franka


@pytest.mark.parametrize("units", ["m", "mm"])
def test_a_pinch_holds_its_weight_up_to_twice_mu_times_the_grip(tmp_path, units):
    franka = load_gripper("franka")
    critical = 2 * MU * franka.grip_force / 9.80665  # kg
    doc, part, _ = _pinch(tmp_path, 0.9 * critical, units)
    light = simulate_jaw_document(doc, part, SimSettings(shake=0.0))
    lab = light["grasps"][0]["sim"]
    assert lab["held"] and all(lab["gravity_held"].values()), lab
    assert lab["forces"] == pytest.approx([1.0], abs=1e-3)  # the servo at the rated force
    doc, part, _ = _pinch(tmp_path, 1.1 * critical, units)
    heavy = simulate_jaw_document(doc, part, SimSettings(shake=0.0))
    lab = heavy["grasps"][0]["sim"]
    assert not lab["held"] and lab["failed_at"] == "gravity"
    # across the pads the coupled fingers hold it; along them friction gives way
    assert lab["gravity_held"] == {"+x": True, "-x": True, "+y": False, "-y": False,
                                   "+z": False, "-z": False}


def test_pads_start_clear_of_the_part(tmp_path):
    doc, part, _ = _pinch(tmp_path, 0.1)
    doc["grasps"][0]["width"] = 0.03  # the pads would start inside the 40 mm box
    out = simulate_jaw_document(doc, part, SimSettings(shake=0.0))
    lab = out["grasps"][0]["sim"]
    assert lab["failed_at"] == "start" and "pad" in lab["reason"]


def test_a_soft_pinch_has_no_predicted_escape_and_a_point_pinch_turns_about_its_line():
    # two opposed contacts on x: point contacts leave the turn about x free, soft ones
    # (torsion) resist it
    from synth.sim.label import predicted_escape

    P = np.array([[0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]])
    N = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    esc = predicted_escape(P, N, 0.5, np.zeros(3), 1.0)
    assert np.allclose(np.abs(esc.twist), [0, 0, 0, 1, 0, 0], atol=1e-6)
    assert predicted_escape(P, N, 0.5, np.zeros(3), 1.0, torsion=0.05) is None


@pytest.mark.parametrize("gripper", ["nope", None, [1]])
def test_a_gripper_field_of_another_type_falls_back_to_the_params(tmp_path, gripper):
    """A document whose 'gripper' is not an object was checked (its params.gripper named the
    hand) and then crashed the simulation ('str' object has no attribute 'get')."""
    from synth.sim.document import check_jaw_document

    doc, part, _ = _pinch(tmp_path, 0.1)
    doc["gripper"] = gripper
    check_jaw_document(doc)
    lab = simulate_jaw_document(doc, part, SimSettings(shake=0.0))["grasps"][0]["sim"]
    assert lab["held"]
    del doc["params"]
    with pytest.raises(InputError, match="gripper.source: expected the gripper's name"):
        check_jaw_document(doc)
