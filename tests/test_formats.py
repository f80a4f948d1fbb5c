"""Reading gripper poses from the ecosystem's files: layouts, units, scales, malformed poses.

The files are written here from the formats' documented keys (ACRONYM's HDF5 layout, GraspGen's
docs/GRASP_DATASET_FORMAT.md, the isaac_grasp specification), never by synth's writers."""

from __future__ import annotations

import json

import numpy as np
import pytest

from synth.errors import InputError
from synth.formats import read_gripper_poses
from synth.formats.isaac import matrix_quaternion, quaternion_matrix
from synth.formats.poses import canonical_half_turn, check_poses

h5py = pytest.importorskip("h5py")


def _random_poses(n, seed=0):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    T = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        T[i, :3, :3] = quaternion_matrix(q[i, 0], q[i, 1:])
    T[:, :3, 3] = rng.uniform(-0.1, 0.1, size=(n, 3))
    return T


def test_quaternions_round_trip_and_match_a_known_rotation():
    # a quarter turn about z: (w, x, y, z) = (cos 45, 0, 0, sin 45) maps x to y
    R = quaternion_matrix(np.sqrt(0.5), np.array([0.0, 0.0, np.sqrt(0.5)]))
    assert np.allclose(R @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    for T in _random_poses(50):
        w, xyz = matrix_quaternion(T[:3, :3])
        assert np.allclose(quaternion_matrix(w, xyz), T[:3, :3], atol=1e-14)


def test_acronym_file_poses_are_brought_to_the_mesh_by_its_scale(tmp_path):
    T = _random_poses(3)
    path = tmp_path / "obj.h5"
    with h5py.File(path, "w") as f:
        f["grasps/transforms"] = T
        f["grasps/qualities/flex/object_in_gripper"] = np.array([1, 0, 1])
        f["object/file"] = "meshes/Mug/obj.obj"
        f["object/scale"] = 0.004
    poses = read_gripper_poses(path)
    assert poses.format == "acronym" and poses.object_scale == 0.004 and not poses.errors
    assert poses.labels.tolist() == [1, 0, 1] and poses.object_file == "meshes/Mug/obj.obj"
    # the mesh's file unit is unknown: one mesh unit is 0.004 m, as the file says
    at = poses.to_part(None, None)
    assert at.metres_per_unit == 0.004
    assert np.array_equal(at.poses[:, :3, :3], T[:, :3, :3])
    assert np.allclose(at.poses[:, :3, 3], T[:, :3, 3] / 0.004, rtol=1e-15)
    assert "object scale 0.004" in at.applied
    assert at.applied.endswith("translations multiplied by 250 into the mesh's unit, rotations "
                               "as given")
    # a part whose unit says otherwise was not the object the poses were made for
    with pytest.raises(InputError, match="object scale.*another size"):
        poses.to_part(0.001, "mm")
    assert poses.to_part(0.004 * (1 + 1e-9), "x").metres_per_unit == pytest.approx(0.004)


def test_graspgen_json_isaac_yaml_and_arrays_read_their_documented_keys(tmp_path):
    T = _random_poses(2, seed=1)
    gg = tmp_path / "g.json"
    gg.write_text(json.dumps({"object": {"file": "a.obj", "scale": 1.0},
                              "grasps": {"transforms": T.tolist(),
                                         "object_in_gripper": [True, False]}}))
    g = read_gripper_poses(gg)
    assert g.format == "graspgen" and np.array_equal(g.poses, T) and g.labels.tolist() == [1, 0]
    # the isaac_grasp specification's own example, 5 decimals: normalised, not refused
    y = tmp_path / "g.yaml"
    y.write_text("format: isaac_grasp\nformat_version: 1.0\nobject_frame: /World/mug\n"
                 "gripper_frame: /World/panda_hand\ngrasps:\n  \"grasp_0\":\n"
                 "    confidence: 1.0\n    position: [-0.04346, 0.06759, 0.19895]\n"
                 "    orientation: {w: 0.00332, xyz: [0.98453, 0.16837, 0.04837]}\n"
                 "    cspace_position:\n      panda_finger_joint1: 0.00943\n")
    i = read_gripper_poses(y)
    assert i.format == "isaac_grasp" and i.names == ("grasp_0",) and not i.errors
    assert np.allclose(i.poses[0, :3, 3], [-0.04346, 0.06759, 0.19895])
    assert check_poses(i.poses) == []
    # no object scale: metres onto a part in millimetres, and refused without a unit
    mm = i.to_part(0.001, "mm")
    assert np.allclose(mm.poses[0, :3, 3], [-43.46, 67.59, 198.95])
    assert mm.applied.endswith("translations multiplied by 1000 into the mesh's unit, "
                               "rotations as given")
    # metres onto a part in metres: nothing to convert, and the note says so
    assert i.to_part(1.0, "m").applied.endswith("the same unit: translations as given, "
                                                "rotations as given")
    with pytest.raises(InputError, match="unit is unknown.*--units"):
        i.to_part(None, None)
    np.savez(tmp_path / "p.npz", poses=T, widths=[0.01, 0.02], units="mm")
    n = read_gripper_poses(tmp_path / "p.npz")
    assert n.unit == 0.001 and n.widths.tolist() == [0.01, 0.02]
    assert np.allclose(n.to_part(1.0, "m").poses[:, :3, 3], T[:, :3, 3] / 1000)
    (tmp_path / "l.json").write_text(json.dumps(T.tolist()))
    assert np.array_equal(read_gripper_poses(tmp_path / "l.json").poses, T)


def test_malformed_poses_are_named_by_index_and_field_and_the_others_kept(tmp_path):
    T = _random_poses(6, seed=2)
    T[1, 0, 0] = np.nan
    T[2, :3, :3] *= 1.001  # not a rotation
    T[3, :3, 0] *= -1  # a reflection
    T[4, 3] = [0, 0, 1, 1]
    rows = T.tolist()
    rows[5] = [[1, 0, 0], [0, 1, 0]]  # not 4 x 4
    path = tmp_path / "g.json"
    path.write_text(json.dumps({"object": {"file": "a.obj", "scale": 1.0},
                                "grasps": {"transforms": rows}}).replace("NaN", "NaN"))
    poses = read_gripper_poses(path)
    bad = dict(poses.errors)
    assert sorted(bad) == [1, 2, 3, 4, 5]
    for i in bad:
        assert str(path) in bad[i] and f"candidate {i}" in bad[i]
        assert f"grasps.transforms[{i}]" in bad[i]
    assert "NaN" in bad[1] and "orthonormal" in bad[2] and "reflection" in bad[3]
    assert "last row" in bad[4] and "4 x 4" in bad[5]
    y = tmp_path / "b.yaml"
    y.write_text("format: isaac_grasp\nformat_version: 1.0\ngrasps:\n"
                 "  a: {confidence: 1, position: [0, 0, 0], orientation: {w: 2, xyz: [0, 0, 0]}}\n"
                 "  b: {confidence: 1, position: [0, 0], orientation: {w: 1, xyz: [0, 0, 0]}}\n"
                 "  c: {confidence: 1, position: [0, 0, 0], orientation: {w: 1, xyz: [0, 0, 0]}}\n")
    bad = dict(read_gripper_poses(y).errors)
    assert sorted(bad) == [0, 1]
    assert "grasps.a.orientation" in bad[0] and "grasps.b.position" in bad[1]
    # a verdict that is no number was read as "no verdict" (NaN), unsaid
    y.write_text("format: isaac_grasp\nformat_version: 1.0\ngrasps:\n"
                 "  a: {confidence: abc, position: [0, 0, 0],\n"
                 "      orientation: {w: 1, xyz: [0, 0, 0]}}\n"
                 "  b: {position: [0, 0, 0], orientation: {w: 1, xyz: [0, 0, 0]}}\n")
    poses = read_gripper_poses(y)
    assert [i for i, _ in poses.errors] == [0] and "'grasps.a.confidence' is 'abc'" in \
        poses.errors[0][1]
    assert np.isnan(poses.labels[1])  # left out: no verdict


def test_a_width_left_null_is_refused_and_widths_left_out_are_none(tmp_path):
    pose = np.eye(4).tolist()
    doc = {"format": "synth.gripper_grasps", "version": 1, "units": "m",
           "grasps": [{"pose": pose, "width": 0.04}, {"pose": pose, "width": None}]}
    path = tmp_path / "j.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="field 'widths' is .*expected 2 finite numbers"):
        read_gripper_poses(path)
    for g in doc["grasps"]:
        del g["width"]
    path.write_text(json.dumps(doc))
    assert read_gripper_poses(path).widths is None


def test_whole_file_errors_name_the_file_and_the_field(tmp_path):
    path = tmp_path / "x.h5"
    with h5py.File(path, "w") as f:
        f["grasps/transforms"] = np.zeros((2, 3, 3))
        f["object/scale"] = 1.0
    with pytest.raises(InputError, match=r"x.h5: dataset 'grasps/transforms' has shape"):
        read_gripper_poses(path)
    y = tmp_path / "x.yaml"
    y.write_text("format: something\n")
    with pytest.raises(InputError, match="field 'format'.*isaac_grasp"):
        read_gripper_poses(y)
    with pytest.raises(InputError, match="unknown pose file extension"):
        (tmp_path / "x.txt").write_text("")
        read_gripper_poses(tmp_path / "x.txt")


def test_a_pose_and_its_half_turn_have_one_representative():
    T = _random_poses(20, seed=3)
    H = np.diag([-1.0, -1.0, 1.0, 1.0])
    a, ta = canonical_half_turn(T)
    b, tb = canonical_half_turn(T @ H)
    assert np.array_equal(a, b) and np.array_equal(ta, ~tb)
    assert np.array_equal(np.where(ta[:, None, None], T @ H, T), a)


def test_isaac_files_without_pyyaml_name_the_extra(tmp_path, monkeypatch):
    import sys

    y = tmp_path / "g.yaml"
    y.write_text("format: isaac_grasp\n")
    monkeypatch.setitem(sys.modules, "yaml", None)  # as if PyYAML were not installed
    with pytest.raises(InputError, match=r'synth\[formats\]'):
        read_gripper_poses(y)


# -- pose files that cannot be read: one plain line, never an invitation to unpickle -------------

@pytest.mark.parametrize("content", [b"hello\n", b"\x80\x04K\x01."])
def test_a_pose_file_named_npz_that_is_no_zip_archive_is_named_so(tmp_path, content):
    path = tmp_path / "x.npz"
    path.write_bytes(content)
    with pytest.raises(InputError) as e:
        read_gripper_poses(path)
    assert str(e.value).startswith(f"{path}: ") and "not an NPZ archive" in str(e.value)
    assert "pickle" not in str(e.value)


def test_a_pose_array_of_python_objects_is_named_and_not_loaded(tmp_path):
    path = tmp_path / "o.npz"
    np.savez(path, poses=np.array([None, 1.0], dtype=object))
    with pytest.raises(InputError, match=r"array 'poses' holds Python objects") as e:
        read_gripper_poses(path)
    assert "pickle" not in str(e.value)


@pytest.mark.parametrize("name", ["dir.json", "dir.npz", "dir.h5", "dir.yaml"])
def test_a_folder_given_as_a_pose_file_is_named_a_folder(tmp_path, name):
    (tmp_path / name).mkdir()
    with pytest.raises(InputError, match="a folder, not a gripper pose file"):
        read_gripper_poses(tmp_path / name)


def test_a_pose_file_with_an_integer_too_long_to_read_is_bad_input(tmp_path):
    path = tmp_path / "bigint.json"
    path.write_text('{"poses": [[[' + "1" * 5000 + ", 0, 0, 0]]]}")
    with pytest.raises(InputError, match="number too long to read") as e:
        read_gripper_poses(path)
    assert "sys." not in str(e.value)


CUBE_SET = {"points": [[0.5, 0, 0], [-0.5, 0, 0], [0, 0.5, 0]],
            "normals": [[-1, 0, 0], [1, 0, 0], [0, -1, 0]]}


@pytest.mark.parametrize("doc, what", [
    ({"format": "synth.grasps", "version": 1, "mesh": {}, "params": {}, "fingers": {},
      "grasps": [{"rank": 1, **CUBE_SET}]},
     "a point-finger plan (contact sets; JSON written by synth plan --out), not gripper poses; "
     "rank it without --gripper (synth rank MESH {path})"),
    ({"format": "synth.ranked", "version": 2, "candidates": [CUBE_SET]},
     "a ranking of contact sets (JSON written by synth rank --out), not gripper poses; rank it "
     "without --gripper (synth rank MESH {path})"),
    ({"candidates": [CUBE_SET]},
     "contact sets (a candidate file of 'points'), not gripper poses; rank it without "
     "--gripper (synth rank MESH {path})"),
    ([CUBE_SET, CUBE_SET],
     "contact sets (a candidate file of 'points'), not gripper poses; rank it without "
     "--gripper (synth rank MESH {path})"),
    ({"format": "synth.scores", "version": 1, "candidates": []},
     "a score file (JSON written by synth score --out): scores of contact sets, not gripper "
     "poses"),
])
def test_contact_sets_given_as_gripper_poses_are_named_so(tmp_path, doc, what):
    """A point-finger plan given to synth rank --gripper was refused with the list of its JSON
    keys ("expected a list of 4 x 4 poses ...; found keys ['escape', 'fingers', ...]")."""
    path = tmp_path / "cube.grasps.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError) as e:
        read_gripper_poses(path)
    assert str(e.value) == f"{path}: " + what.format(path=path)


def test_contact_sets_in_an_npz_given_as_gripper_poses_are_named_so(tmp_path):
    path = tmp_path / "c.npz"
    np.savez(path, points=np.zeros((2, 7, 3)), normals=np.zeros((2, 7, 3)))
    with pytest.raises(InputError) as e:
        read_gripper_poses(path)
    assert str(e.value) == (f"{path}: contact sets (arrays 'points', 'normals'), not gripper "
                            f"poses; rank them without --gripper (synth rank MESH {path})")
