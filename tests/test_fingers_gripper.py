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


@pytest.mark.parametrize("name", BUILTIN_GRIPPERS)
def test_no_finger_shape_but_the_pad_meets_a_flat_part_first(name):
    """Where a finger's shapes reach its pad plane (x = w / 2 for the +x finger), they lie
    within the pad's rectangle: closing on a flat face, the pad is what touches first, and
    the contact synth reports is where the fingers meet the part."""
    g = load_gripper(name)
    for w in (0.0, 0.5 * g.max_opening, g.max_opening):
        right, _ = g.finger_transforms(w)
        pad_z = g.pad_center[1] + right[2, 3]  # the pad rises with the finger
        for s in g.finger:
            V = s.vertices @ right[:3, :3].T + right[:3, 3]
            front = V[V[:, 0] <= w / 2 + 1e-6]  # within 1 micrometre of the pad plane
            assert np.all(np.abs(front[:, 1] - g.pad_center[0]) <= g.pad_size[0] / 2 + 1e-6)
            assert np.all(np.abs(front[:, 2] - pad_z) <= g.pad_size[1] / 2 + 1e-6)


# robosuite 1.5.2's collision geoms of the right finger at the open pose, in the base link's
# frame with robosuite's y as synth's x (printed by scripts/fit_gripper_boxes.py): x, y, z
# ranges in metres, to 0.1 mm
ROBOSUITE = {
    "robotiq_2f140": {"pad": [(0.0632, 0.0652), (-0.0139, 0.0141), (0.1422, 0.2082)],
                      "fingertip": [(0.0643, 0.0718), (-0.0149, 0.0151), (0.141, 0.211)],
                      "inner finger": [(0.0713, 0.1012), (-0.0072, 0.0078), (0.1242, 0.1747)]},
    "robotiq_2f85": {"pad": [(0.0427, 0.0447), (-0.01, 0.01), (0.1136, 0.1471)],
                     "fingertip": [(0.043, 0.0494), (-0.011, 0.011), (0.1116, 0.1491)],
                     "inner finger": [(0.0443, 0.0742), (-0.0075, 0.0075), (0.0919, 0.1424)]},
}


@pytest.mark.parametrize("name", sorted(ROBOSUITE))
def test_robotiq_fingers_are_the_sources_pad_fingertip_and_inner_finger(name):
    g = load_gripper(name)
    doc = json.loads((DATA / f"{name}.json").read_text())
    source = ROBOSUITE[name]
    face = source["pad"][0][0]  # the pad plane at the open pose, as synth's x = w / 2 there
    for item, (xs, ys, zs) in zip(doc["finger"], source.values(), strict=True):
        c, size = np.array(item["box"]["center"]), np.array(item["box"]["size"])
        lo, hi = c - size / 2, c + size / 2
        assert lo[0] + face == pytest.approx(xs[0], abs=1e-4)
        assert hi[0] + face == pytest.approx(xs[1], abs=1e-4)
        assert (lo[2], hi[2]) == pytest.approx(zs, abs=1e-4)
        # centred on y = 0: covering the source's range (to its 0.1 mm), no more than the
        # smallest such box
        assert lo[1] <= ys[0] + 1e-4 and hi[1] >= ys[1] - 1e-4
        assert hi[1] - lo[1] <= 2 * max(abs(ys[0]), abs(ys[1])) + 1e-9
    # the pad rectangle is the source's fingerpad face
    (_, _), (y0, y1), (z0, z1) = source["pad"]
    assert g.pad_size == pytest.approx((y1 - y0, z1 - z0), abs=1e-4)
    assert g.pad_center[1] == pytest.approx((z0 + z1) / 2, abs=1e-4)


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


@pytest.mark.parametrize("name", ["junk.stl", "junk.obj"])
def test_an_unreadable_part_mesh_is_named_in_the_formats_words(tmp_path, name):
    """trimesh's own words for a damaged STL were a missing module's ("No module named
    'charset_normalizer'")."""
    (tmp_path / name).write_bytes(np.random.default_rng(0).bytes(500))
    p = _write(tmp_path, finger=[{"mesh": name}])
    with pytest.raises(InputError) as e:
        load_gripper(p)
    ext = name.split(".")[1].upper()
    assert str(e.value).endswith(f"field 'finger[0].mesh': cannot read {str(tmp_path / name)!r}: "
                                 f"not a readable {ext} file (damaged, cut short, or not {ext} "
                                 "at all)")


def test_missing_field_and_unknown_gripper(tmp_path, capsys):
    doc = json.loads((DATA / "franka.json").read_text())
    del doc["grip_force"]
    p = tmp_path / "g.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="missing field 'grip_force'"):
        load_gripper(p)
    with pytest.raises(InputError, match=r"^--gripper \(Python: gripper=\): 'shadow_hand' is "
                                         "neither a built-in gripper"):
        load_gripper("shadow_hand")
    with pytest.raises(InputError, match=r"^--gripper \(Python: gripper=\): expected a "
                                         "built-in"):
        load_gripper(None)  # was "'None' is neither a built-in gripper"
    assert set(BUILTIN_GRIPPERS) == {"franka", "robotiq_2f85", "robotiq_2f140"}
