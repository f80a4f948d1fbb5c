"""Gripper descriptions: the built-in ones, the frame, and malformed files refused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from synth import InputError
from synth.fingers.gripper import BUILTIN_GRIPPERS, load_gripper

DATA = Path(__file__).resolve().parents[1] / "synth" / "fingers" / "grippers"


@pytest.mark.parametrize("name, opening, force", [("franka", 0.08, 70.0),
                                                  ("robotiq_2f85", 0.085, 235.0),
                                                  ("robotiq_2f140", 0.14, 125.0)])
def test_builtin_grippers_have_the_makers_numbers(name, opening, force):
    g = load_gripper(name)
    assert (g.max_opening, g.grip_force) == (opening, force)
    # ACRONYM/GraspGen frame: the pads face each other across x, in front of the palm (+z)
    palm_top = max(s.vertices[:, 2].max() for s in g.palm)
    assert g.pad_center[1] - g.pad_size[1] / 2 > 0.5 * palm_top
    assert abs(g.tcp[2] - g.pad_center[1]) < g.pad_size[1]
    for w in (0.0, 0.5 * opening, opening):
        right, left = g.finger_transforms(w)
        meshes = g.meshes_at(w)
        fingers = meshes[len(g.palm):]
        half = len(fingers) // 2
        # the +x finger's material lies at x >= w / 2 (its pad plane), the -x finger mirrored
        assert min(v[:, 0].min() for v, _ in fingers[:half]) >= w / 2 - 1e-9
        assert max(v[:, 0].max() for v, _ in fingers[half:]) <= -w / 2 + 1e-9
        assert np.allclose(left[:3, :3] @ right[:3, :3].T, np.diag([-1, -1, 1]))
    for s in g.palm + g.finger:  # closed, outward-wound shapes: positive volume
        V, Fc = s.vertices, s.faces
        vol = np.einsum("ij,ij->i", V[Fc[:, 0]], np.cross(V[Fc[:, 1]], V[Fc[:, 2]])).sum() / 6
        assert vol > 0
    scaled = g.scaled(1000.0)  # to millimetres
    assert scaled.max_opening == pytest.approx(1000 * opening)
    assert scaled.grip_force == force


def test_franka_fingertips_reach_acronyms_marker():
    g = load_gripper("franka")
    tips = max(v[:, 2].max() for v, _ in g.meshes_at(0.08)[1:])
    assert tips == pytest.approx(0.1122, abs=2e-4)  # ACRONYM's gripper marker: z = 0.11217


def _write(tmp_path, **change):
    doc = json.loads((DATA / "robotiq_2f85.json").read_text())
    doc.update(change)
    p = tmp_path / "g.json"
    p.write_text(json.dumps(doc))
    return p


@pytest.mark.parametrize("change, words", [
    ({"max_opening": -1}, "field 'max_opening' is -1, expected a positive number"),
    ({"grip_force": "strong"}, "field 'grip_force' is 'strong', expected a positive number"),
    ({"tcp": [0, 0]}, "field 'tcp' is [0, 0], expected a list of 3 finite numbers"),
    ({"palm": []}, "field 'palm' is [], expected a non-empty list"),
    ({"finger": [{"box": {"center": [0, 0, 0], "size": [1, 0, 1]}}]},
     "field 'finger[0].box.size' is [1, 0, 1], expected a list of 3 finite positive numbers"),
    ({"finger": [{"mesh": "nope.stl"}]}, "field 'finger[0].mesh': no such file"),
    ({"finger": [{"cylinder": 1}]}, "field 'finger[0]' is {'cylinder': 1}, expected"),
    ({"pad": {"center": [0, 0.1]}}, "missing field 'size'"),
    ({"finger_z": [[0, 0], [0.05, 0]]}, "field 'finger_z'"),
    ({"format": "urdf"}, "expected 'synth.gripper'/1"),
])
def test_malformed_descriptions_are_refused(tmp_path, change, words):
    p = _write(tmp_path, **change)
    with pytest.raises(InputError, match=None) as e:
        load_gripper(p)
    assert str(p) in str(e.value) and words in str(e.value)


def test_missing_field_and_unknown_gripper(tmp_path, capsys):
    doc = json.loads((DATA / "franka.json").read_text())
    del doc["grip_force"]
    p = tmp_path / "g.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="missing field 'grip_force'"):
        load_gripper(p)
    with pytest.raises(InputError, match="neither a built-in gripper"):
        load_gripper("shadow_hand")
    assert set(BUILTIN_GRIPPERS) == {"franka", "robotiq_2f85", "robotiq_2f140"}
