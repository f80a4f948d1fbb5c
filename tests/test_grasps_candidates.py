"""Candidate files: the fast JSON parser (orjson, when installed) and the standard library's
give the same values, and everything orjson refuses still goes through the standard one."""

from __future__ import annotations

import gc
import json
import sys

import numpy as np
import pytest

from synth.errors import InputError
from synth.grasps import candidates
from synth.grasps.candidates import parse_json, read_candidate_table


def _stdlib_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "orjson", None)  # import orjson now raises ImportError


def test_both_parsers_read_a_candidate_file_identically(tmp_path, monkeypatch) -> None:
    pytest.importorskip("orjson")
    rng = np.random.default_rng(1)
    P, N = rng.normal(size=(50, 7, 3)) * 1e3, rng.normal(size=(50, 7, 3))
    doc = [{"name": f"g{i}", "points": p, "normals": q, "mu": 0.1 * (i % 3)}
           for i, (p, q) in enumerate(zip(P.tolist(), N.tolist(), strict=True))]
    path = tmp_path / "c.json"
    path.write_text(json.dumps(doc))
    fast = read_candidate_table(path)
    with monkeypatch.context() as m:
        _stdlib_only(m)
        slow = read_candidate_table(path)
    (f,), (s,) = fast.groups, slow.groups
    np.testing.assert_array_equal(f.points, s.points)  # bit for bit
    np.testing.assert_array_equal(f.normals, s.normals)
    np.testing.assert_array_equal(fast.mu, slow.mu)
    assert fast.names == slow.names
    np.testing.assert_array_equal(f.points, P)


@pytest.mark.parametrize("raw", [
    b"[NaN, 1]",                              # not JSON, but the standard library reads it
    b"[" + b"9" * 400 + b"]",                 # beyond 64 bits
    b'{"a": 1, "a": 2}',                      # duplicate keys: the last wins
])
def test_what_orjson_refuses_is_parsed_as_the_standard_library_does(raw, monkeypatch) -> None:
    expected = json.loads(raw.decode())
    assert repr(parse_json(raw)) == repr(expected)


def test_nesting_too_deep_for_both_is_the_standard_librarys_recursion_error() -> None:
    with pytest.raises(RecursionError):
        parse_json(b"[" * 100_000 + b"]" * 100_000)


def test_malformed_json_raises_the_standard_librarys_error(monkeypatch) -> None:
    with pytest.raises(json.JSONDecodeError):
        parse_json(b'[{"points": [1, 2,]}]')
    monkeypatch.setitem(sys.modules, "orjson", None)
    with pytest.raises(json.JSONDecodeError):
        parse_json(b'[{"points": [1, 2,]}]')
    assert candidates.parse_json(b"[1.5]") == [1.5]


@pytest.mark.parametrize("text", ['[{"points": [[0, 0, 0]], "normals": [[0, 0, 1]]}]',
                                  "[{", "[]"])
def test_the_garbage_collector_is_back_on_after_reading_or_failing(tmp_path, text) -> None:
    # the JSON reader pauses the cyclic collector while it builds the parsed document
    path = tmp_path / "c.json"
    path.write_text(text)
    assert gc.isenabled()
    try:
        read_candidate_table(path)
    except InputError:
        pass
    assert gc.isenabled()
    gc.disable()
    try:  # a caller that turned it off keeps it off
        try:
            read_candidate_table(path)
        except InputError:
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


# -- files that are not candidate files: one plain line naming the file and what is wrong ------

CUBE = {"points": [[0.5, 0.1, 0.1], [-0.5, 0.1, 0.1], [0.1, 0.5, 0.1], [0.1, -0.5, 0.1],
                   [0.1, 0.1, 0.5], [0.1, 0.1, -0.5], [0.2, 0.5, 0.2]],
        "normals": [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1],
                    [0, -1, 0]]}


@pytest.mark.parametrize("content", [b"hello\n", b'{"points": []}', b"\x80\x04K\x01."])
def test_a_file_named_npz_that_is_no_zip_archive_never_invites_unpickling(tmp_path,
                                                                           content) -> None:
    path = tmp_path / "x.npz"
    path.write_bytes(content)  # text, JSON, a pickle: numpy would offer to unpickle them
    with pytest.raises(InputError) as e:
        read_candidate_table(path)
    message = str(e.value)
    assert message.startswith(f"{path}: ") and "not an NPZ archive" in message
    assert "pickle" not in message and "allow_pickle" not in message


def test_an_npz_array_of_python_objects_is_named_and_not_loaded(tmp_path) -> None:
    path = tmp_path / "o.npz"
    np.savez(path, points=np.array([None, 1.0], dtype=object), normals=np.zeros((1, 7, 3)))
    with pytest.raises(InputError, match=r"o\.npz: array 'points' holds Python objects") as e:
        read_candidate_table(path)
    assert "pickle" not in str(e.value)


@pytest.mark.parametrize("name", ["dir.json", "dir.npz"])
def test_a_folder_is_named_a_folder_not_a_missing_file(tmp_path, name) -> None:
    (tmp_path / name).mkdir()
    with pytest.raises(InputError, match="a folder, not a candidate file") as e:
        read_candidate_table(tmp_path / name)
    assert "no such file" not in str(e.value)
    with pytest.raises(InputError, match="no such file"):
        read_candidate_table(tmp_path / "missing.json")


def test_without_required_normals_only_points_are_asked_for(tmp_path) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps([5, {"points": "abc"}, {"points": CUBE["points"]}]))
    table = read_candidate_table(path, require_normals=False)  # as synth rank reads
    (i0, m0), (i1, m1) = table.errors
    assert (i0, i1) == (0, 1) and len(table.candidates()) == 1
    assert m0.endswith("candidate 0: expected an object with 'points', got 5")
    assert "field 'points' must be a k x 3 list of numbers" in m1
    assert "normals" not in m0.removeprefix(str(path)) + m1.removeprefix(str(path))
    with_normals = read_candidate_table(path).errors  # as synth score reads
    assert "expected an object with 'points' and 'normals'" in with_normals[0][1]



def test_normals_that_are_nan_in_the_file_are_refused(tmp_path) -> None:
    """Only normals the file leaves out (synth rank) come back as NaN; normals written as NaN,
    in an NPZ or as JSON's NaN, were taken for left out and passed on as NaN."""
    P = np.asarray(CUBE["points"], float)[None]
    np.savez(tmp_path / "c.npz", points=P, normals=np.full(P.shape, np.nan))
    (tmp_path / "c.json").write_text(json.dumps([{"points": CUBE["points"],
                                                  "normals": [[float("nan")] * 3] * 7}]))
    for name in ("c.npz", "c.json"):
        for require_normals in (True, False):
            table = read_candidate_table(tmp_path / name, require_normals=require_normals)
            assert not table.candidates(), name
            assert "field 'normals' row 0 is not finite" in table.errors[0][1], name
    (tmp_path / "left_out.json").write_text(json.dumps([{"points": CUBE["points"]}]))
    left_out = read_candidate_table(tmp_path / "left_out.json", require_normals=False)
    assert np.isnan(left_out.candidates()[0].normals).all()


I4 = np.eye(4).tolist()


@pytest.mark.parametrize("doc", [
    {"format": "synth.gripper_grasps", "version": 1, "grasps": [{"pose": I4, "width": 0.04}]},
    [{"pose": I4, "width": 0.04}],
    {"pose": I4},
    {"poses": [I4]},
    [I4, I4],
    {"object": {"file": "a.obj", "scale": 1.0}, "grasps": {"transforms": [I4]}},
])
def test_gripper_poses_given_as_contact_sets_point_to_the_gripper_option(tmp_path, doc) -> None:
    path = tmp_path / "poses.json"
    path.write_text(json.dumps(doc))
    for require_normals in (False, True):
        with pytest.raises(InputError) as e:
            read_candidate_table(path, require_normals=require_normals)
        assert str(e.value).startswith(f"{path}: holds gripper poses")
        assert "--gripper NAME" in str(e.value)
        assert "normals" not in str(e.value).replace(str(path), "")


def test_gripper_poses_in_an_npz_point_to_the_gripper_option(tmp_path) -> None:
    path = tmp_path / "poses.npz"
    np.savez(path, poses=np.eye(4)[None])
    with pytest.raises(InputError, match=r"holds gripper poses .*--gripper NAME"):
        read_candidate_table(path)


def test_a_pose_among_contact_sets_is_reported_on_its_own(tmp_path) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps([CUBE, {"pose": I4}]))
    table = read_candidate_table(path)
    assert len(table.candidates()) == 1
    assert "candidate 1: a gripper pose" in table.errors[0][1]
    assert "--gripper NAME" in table.errors[0][1]


def test_an_integer_too_long_to_read_is_named_without_pythons_advice(tmp_path) -> None:
    path = tmp_path / "bigint.json"
    path.write_text('[{"points": [[' + "1" * 5000 + ', 0, 0]], "normals": [[1, 0, 0]]}]')
    with pytest.raises(InputError) as e:
        read_candidate_table(path)
    message = str(e.value)
    assert message.startswith(f"{path}: ") and "number too long to read" in message
    assert "5000 digits" in message and "sys." not in message


@pytest.mark.parametrize("argv", [["score"], ["rank", "MESH"]])
def test_the_commands_refuse_these_files_with_exit_status_2(tmp_path, capsys, argv) -> None:
    from pathlib import Path

    from synth.cli import main

    mesh = str(Path(__file__).parents[1] / "meshes" / "cube.stl")
    (tmp_path / "x.npz").write_text("hello\n")
    (tmp_path / "dir.json").mkdir()
    (tmp_path / "bigint.json").write_text('[{"points": [[' + "1" * 5000 + ", 0, 0]]}]")
    (tmp_path / "poses.json").write_text(json.dumps([{"pose": I4, "width": 0.04}]))
    cases = [("x.npz", "not an NPZ archive"), ("dir.json", "a folder, not a candidate file"),
             ("bigint.json", "number too long to read")]
    if argv[0] == "rank":
        cases.append(("poses.json", "--gripper NAME"))
    for name, words in cases:
        capsys.readouterr()
        args = [mesh if a == "MESH" else a for a in argv] + [str(tmp_path / name), "--quiet"]
        assert main(args) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and words in lines[0] and name in lines[0], lines
        assert "pickle" not in lines[0] and "sys." not in lines[0]


def test_a_plan_files_grasps_carry_its_friction(tmp_path):
    """A synth plan file of frictional grasps (--mu 0.5 --contacts 3) records mu once, in its
    params: each grasp read from it has that mu unless it gives its own."""
    from synth.grasps.candidates import read_candidates

    pts = [[0.5, 0, 0], [-0.5, 0, 0], [0, 0.5, 0]]
    nrm = [[-1, 0, 0], [1, 0, 0], [0, -1, 0]]
    doc = {"format": "synth.grasps", "params": {"mu": 0.5},
           "grasps": [{"points": pts, "normals": nrm}, {"points": pts, "normals": nrm,
                                                        "mu": 0.2}]}
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(doc))
    assert [c.mu for c in read_candidates(path)] == [0.5, 0.2]


@pytest.mark.parametrize("name, head, kind, poses", [
    ("g.h5", b"\x89HDF\r\n\x1a\n" + bytes(64), "an HDF5 file", "ACRONYM .h5"),
    ("g.yaml", b"format: isaac_grasp\n", "a YAML file", "isaac_grasp .yaml"),
])
def test_a_gripper_pose_file_as_candidates_points_to_the_gripper_option(tmp_path, capsys, name,
                                                                         head, kind,
                                                                         poses) -> None:
    """An ACRONYM .h5 (or an isaac_grasp .yaml) given to synth rank without --gripper was
    named "an HDF5 file, not a candidate file (JSON or NPZ)", with no word of what to do."""
    from pathlib import Path

    from synth.cli import main

    path = tmp_path / name
    path.write_bytes(head)
    with pytest.raises(InputError) as e:
        read_candidate_table(path)
    assert str(e.value) == (f"{path}: {kind}, not a candidate file (JSON or NPZ); gripper "
                            f"poses ({poses}) are ranked with synth rank MESH {path} "
                            "--gripper NAME|FILE")
    mesh = str(Path(__file__).parents[1] / "meshes" / "cube.stl")
    assert main(["rank", mesh, str(path)]) == 2
    assert capsys.readouterr().err.strip() == f"synth: error: {e.value}"
