"""``synth db export --format acronym|graspgen|isaac``: files the other tools load, checked with
ACRONYM's own loading code (tests/acronym_tools_load.py, MIT) and GraspGen's and isaac_grasp's
documented keys, and read back by ``synth rank`` with the planner's contacts and scores."""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth import GraspDatabase
from synth.cli import main
from synth.formats import read_gripper_poses
from synth.part import load_part
from synth.plan.gripper import GripperParams
from synth.plan.gripper_rank import rank_gripper_poses

h5py = pytest.importorskip("h5py")
yaml = pytest.importorskip("yaml")
acronym = pytest.importorskip("tests.acronym_tools_load")

ROOT = Path(__file__).resolve().parents[1]
CM = 0.009999999999999998  # the cube's unit, metres (trimesh's centimetre, to the last bit)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A gripper database of the sample cube (in cm), with a mass: (folder, database)."""
    tmp = tmp_path_factory.mktemp("db")
    folder = tmp / "meshes"
    folder.mkdir()
    shutil.copy(ROOT / "meshes" / "cube.stl", folder / "cube.stl")
    out = tmp / "g.sqlite"
    assert main(["db", "build", str(folder), "--out", str(out), "--gripper", "franka",
                 "--units", "cm", "--top", "3", "--samples", "60", "--mass", "0.05",
                 "--workers", "0", "--quiet"]) == 0
    return folder, out


def _stored(db_path):
    with GraspDatabase(db_path) as db:
        return list(db.gripper_grasps("cube.stl"))


def test_acronym_loads_the_export_with_its_own_code(built, tmp_path):
    folder, db = built
    assert main(["db", "export", str(db), "--format", "acronym", "--out", str(tmp_path)]) == 0
    path = str(tmp_path / "cube.h5")
    T, success = acronym.load_grasps(path)
    mesh = acronym.load_mesh(path, mesh_root_dir="")  # object/file is the absolute path
    stored = _stored(db)
    assert T.shape == (len(stored), 4, 4) and success.tolist() == [1] * len(stored)
    assert np.allclose(mesh.extents, load_part(folder / "cube.stl").mesh.extents * CM,
                       rtol=1e-12)
    marker = acronym.create_gripper_marker()  # ACRONYM's Franka: fingers from z 0.066 up
    z_lo, z_hi = 0.0659, marker.bounds[1, 2]
    for g, pose in zip(stored, T, strict=True):
        pts = g.points * CM  # synth's contacts, in the frame ACRONYM's loader builds
        closest, dist, _ = trimesh.proximity.closest_point(mesh, pts)
        assert dist.max() <= 1e-9 * np.linalg.norm(mesh.extents)
        local = (pts - pose[:3, 3]) @ pose[:3, :3]  # into the gripper frame of the pose
        assert np.allclose(local[:, 0], [g.width * CM / 2, -g.width * CM / 2], atol=1e-12)
        assert np.all((local[:, 2] >= z_lo) & (local[:, 2] <= z_hi))
        assert np.all(np.abs(local[:, 1]) <= 0.00873 + 1e-12)  # within the pad's half-width
    with h5py.File(path) as f:
        assert f.attrs["units"] == "m" and f["grasps/transforms"].attrs["units"] == "m"
        meaning = f["grasps/qualities/flex/object_in_gripper"].attrs["meaning"]
        assert "not a simulation" in meaning and "margin >= 1" in meaning
        assert f["object/mass"][()] == pytest.approx(0.05, rel=1e-12)
        assert f["gripper/type"][()] == b"franka"
        assert f["object/scale"][()] == CM
        assert np.array_equal(f["grasps/qualities/synth/squeeze_per_weight"][()],
                              [g.squeeze_per_weight for g in stored])


def test_graspgen_and_isaac_files_have_their_documented_keys(built, tmp_path):
    _, db = built
    n = len(_stored(db))
    assert main(["db", "export", str(db), "--format", "graspgen", "--out", str(tmp_path)]) == 0
    doc = json.loads((tmp_path / "cube.json").read_text())
    grasps = np.array(doc["grasps"]["transforms"])
    mask = np.array(doc["grasps"]["object_in_gripper"])
    assert isinstance(doc["object"]["file"], str) and doc["object"]["scale"] == CM
    assert grasps.shape == (n, 4, 4) and mask.dtype == bool and len(grasps[mask]) == n
    assert doc["synth"]["units"] == "m" and "not a simulation" in doc["synth"][
        "object_in_gripper"]
    assert main(["db", "export", str(db), "--format", "isaac", "--out", str(tmp_path)]) == 0
    y = yaml.safe_load((tmp_path / "cube.yaml").read_text())
    assert y["format"] == "isaac_grasp" and y["format_version"] == 1.0
    assert len(y["grasps"]) == n
    for g in y["grasps"].values():
        assert set(g) == {"confidence", "position", "orientation"}
        assert len(g["position"]) == 3 and set(g["orientation"]) == {"w", "xyz"}
        q = np.array([g["orientation"]["w"], *g["orientation"]["xyz"]])
        assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-12)
    assert y["synth"]["units"] == "m"


@pytest.mark.parametrize("fmt, ext", [("acronym", "h5"), ("graspgen", "json"),
                                      ("isaac", "yaml")])
def test_each_export_reads_back_with_the_planners_contacts_and_scores(built, tmp_path, fmt,
                                                                      ext):
    folder, db = built
    assert main(["db", "export", str(db), "--format", fmt, "--out", str(tmp_path)]) == 0
    poses = read_gripper_poses(tmp_path / f"cube.{ext}")
    part = load_part(folder / "cube.stl", units="cm")
    at = poses.to_part(CM, "cm")
    assert at.metres_per_unit == pytest.approx(CM, rel=1e-15)
    r = rank_gripper_poses(part, at.poses, at.metres_per_unit,
                           GripperParams(mass=0.05), dict(poses.errors))
    stored = _stored(db)
    assert sorted(row.index for row in r.rows) == list(range(len(stored)))
    for row in r.rows:  # the cube's grasps tie on the measures: compared by index
        g, h = stored[row.index], row.grasp
        assert row.status == "ok" and h.closure == "frictional form"
        assert np.abs(h.points - g.points).max() <= 1e-9 * part.length
        for key in ("squeeze_per_weight", "mu_min", "epsilon", "d_star", "margin",
                    "least_squeeze"):
            assert getattr(h, key) == pytest.approx(getattr(g, key), rel=1e-9), key


def test_a_mesh_of_unknown_unit_is_refused_unless_named(built, tmp_path, capsys):
    _, db = built
    copy = tmp_path / "u.sqlite"
    shutil.copy(db, copy)
    with sqlite3.connect(copy) as conn:
        conn.execute("UPDATE meshes SET units = NULL")
    conn.close()
    assert main(["db", "export", str(copy), "--format", "acronym", "--out",
                 str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "cube.stl" in err and "unit is unknown" in err and "--units" in err
    assert not (tmp_path / "a" / "cube.h5").exists()
    assert main(["db", "export", str(copy), "--format", "acronym", "--out",
                 str(tmp_path / "a"), "--units", "cm"]) == 0
    with h5py.File(tmp_path / "a" / "cube.h5") as f:
        assert f["object/scale"][()] == CM


def test_the_label_is_mujocos_where_the_grasp_was_simulated(built, tmp_path):
    _, db = built
    copy = tmp_path / "s.sqlite"
    shutil.copy(db, copy)
    with sqlite3.connect(copy) as conn:  # as db build --sim stores a dropped grasp's label
        conn.execute("""UPDATE gripper_grasps SET sim = '{"held": false}' WHERE rank = 2""")
    conn.close()
    assert main(["db", "export", str(copy), "--format", "acronym", "--out", str(tmp_path)]) == 0
    T, success = acronym.load_grasps(str(tmp_path / "cube.h5"))
    assert success.tolist() == [1, 0, 1]
    with h5py.File(tmp_path / "cube.h5") as f:
        assert f["grasps/qualities/synth/simulated"][()].tolist() == [0, 1, 0]
        meaning = f["grasps/qualities/flex/object_in_gripper"].attrs["meaning"]
        assert "(1 of 3 grasps): MuJoCo's label" in meaning


def test_an_export_folder_that_is_a_file_is_refused(built, tmp_path, capsys):
    """These formats write a folder of files: a file of that name is the user's mistake
    (exit 2, one line saying so), and it is left as it was."""
    _, db = built
    mine = tmp_path / "user.json"
    mine.write_text("the user's")
    assert main(["db", "export", str(db), "--format", "graspgen", "--out", str(mine)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "is a file" in err and "a folder" in err
    assert mine.read_text() == "the user's"


@pytest.mark.parametrize("fmt", ["acronym", "graspgen", "isaac"])
def test_an_export_folder_keeps_the_users_files_and_replaces_its_own(built, tmp_path, capsys,
                                                                     fmt):
    """Exporting again into the same folder replaces synth's own files; a file of the user's
    at one of the names stops the export before anything is written."""
    _, db = built
    out = tmp_path / "x"
    argv = ["db", "export", str(db), "--format", fmt, "--out", str(out)]
    assert main(argv) == 0
    (written,) = list(out.iterdir())
    assert main(argv) == 0  # its own file: replaced
    written.write_bytes(b"the user's own notes")
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a file synth exported" in err
    assert written.read_bytes() == b"the user's own notes"


def test_rank_of_a_whole_database_export_points_to_the_per_mesh_export(built, tmp_path,
                                                                       capsys):
    _, db = built
    whole = tmp_path / "all.h5"
    assert main(["db", "export", str(db), "--out", str(whole), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["rank", str(ROOT / "meshes" / "cube.stl"), str(whole), "--gripper", "franka",
                 "--units", "cm"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "db export --format acronym" in err
