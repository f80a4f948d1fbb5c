"""Grasp databases: export round trips, lookups, bad database files, the CLI, the progress bar."""

from __future__ import annotations

import io
import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import synth.database as database
from synth.database import GraspDatabase, build_database, export_database
from synth.database.export import export_columns
from synth.database.progress import ProgressBar
from synth.errors import DatabaseError, InputError
from tests.db_support import PARAMS, PLANNER, make_mesh_dir, planner_env, snapshot


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(mesh folder, database) built once for the read-only tests of this module."""
    root = tmp_path_factory.mktemp("db")
    mesh_dir = make_mesh_dir(root)
    out = root / "grasps.sqlite"
    build_database([mesh_dir], out, PARAMS, workers=0, planner=PLANNER)
    return mesh_dir, out


def test_all_names_exist() -> None:
    for name in database.__all__:
        assert hasattr(database, name), name


def test_export_h5_round_trip(built: tuple[Path, Path], tmp_path: Path) -> None:
    h5py = pytest.importorskip("h5py")
    _, db_path = built
    out = tmp_path / "g.h5"
    assert export_database(db_path, out) == "h5"
    with GraspDatabase(db_path) as db:
        expected = export_columns(db)
        grasps = list(db.grasps())
        params = db.params
    assert len(grasps) > 0
    with h5py.File(out, "r") as f:
        assert json.loads(f.attrs["params"]) == params
        assert f["grasps/points"].chunks is not None
        assert f["grasps/points"].shape == (sum(g.n_contacts for g in grasps), 3)
        for name, arr in expected.items():
            key = (f"meshes/{name[5:]}" if name.startswith("mesh_") else
                   f"gripper_grasps/{name[8:]}" if name.startswith("gripper_") else
                   f"grasps/{name}")
            got = f[key][()]
            if arr.dtype.kind == "U":
                got = np.array([s.decode() for s in got], dtype=str)
            np.testing.assert_array_equal(got, arr, err_msg=name)
        start = f["grasps/contact_start"][()]
        fstart = f["grasps/finger_start"][()]
        for i, g in enumerate(grasps):  # the stored grasps, one by one, from the columns
            c = slice(start[i], start[i + 1])
            np.testing.assert_array_equal(f["grasps/points"][c], g.points)
            np.testing.assert_array_equal(f["grasps/normals"][c], g.normals)
            np.testing.assert_array_equal(f["grasps/regions"][c], g.regions)
            assert [s.decode() for s in f["grasps/features"][c]] == list(g.features)
            np.testing.assert_array_equal(
                f["grasps/tip_centers"][fstart[i] : fstart[i + 1]], g.tip_centers
            )
            assert f["grasps/d_star"][i] == g.d_star and f["grasps/rank"][i] == g.rank
            # a frame per finger: origin at the tip centre, +z along the approach to the part
            frames = f["grasps/finger_frames"][fstart[i] : fstart[i + 1]]
            np.testing.assert_array_equal(frames[:, :3, 3], g.tip_centers)
            np.testing.assert_allclose(frames[:, :3, 2], -g.approach, atol=1e-15)
            assert np.allclose(np.linalg.det(frames[:, :3, :3]), 1.0)
        assert "mesh's unit" in f.attrs["units"]


def test_export_npz_round_trip(built: tuple[Path, Path], tmp_path: Path) -> None:
    _, db_path = built
    out = tmp_path / "g.npz"
    export_database(db_path, out, "npz")
    with GraspDatabase(db_path) as db:
        expected = export_columns(db)
        grasps = list(db.grasps())
    with np.load(out, allow_pickle=False) as z:
        assert json.loads(str(z["params"]))["evals"] == PARAMS["evals"]
        for name, arr in expected.items():
            np.testing.assert_array_equal(z[name], arr, err_msg=name)
        start = z["contact_start"]
        assert len(start) == len(grasps) + 1
        for i, g in enumerate(grasps):
            np.testing.assert_array_equal(z["normals"][start[i] : start[i + 1]], g.normals)
            assert z["conditioning"][i] == g.conditioning and z["closure"][i] == g.closure


def test_export_writes_exactly_the_named_file_and_keeps_the_old_one_on_failure(
        built: tuple[Path, Path], tmp_path: Path) -> None:
    _, db_path = built
    out = tmp_path / "grasps.dat"
    export_database(db_path, out, "npz")  # numpy alone would have written grasps.dat.npz
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grasps.dat"]
    with np.load(out, allow_pickle=False) as z:
        assert "contact_start" in z
    before = out.read_bytes()
    with pytest.raises(DatabaseError):
        export_database(tmp_path / "missing.sqlite", out, "npz")
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grasps.dat"]


def test_export_json_round_trip(built: tuple[Path, Path], tmp_path: Path) -> None:
    _, db_path = built
    out = tmp_path / "g.json"
    export_database(db_path, out, "json")
    doc = json.loads(out.read_text())
    meshes, grasps = snapshot(db_path)
    assert [m["path"] for m in doc["meshes"]] == [m[1] for m in meshes]
    assert [m["status"] for m in doc["meshes"]] == [m[5] for m in meshes]
    exported = [(m["id"], g["rank"], g) for m in doc["meshes"] for g in m["grasps"]]
    assert exported == grasps  # floats survive JSON exactly


def test_export_bad_format_and_missing_h5py(
    built: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _, db_path = built
    with pytest.raises(InputError) as e:
        export_database(db_path, tmp_path / "g.csv")
    # it read "export format must be one of h5, npz, json, got 'csv'", naming no option
    assert str(e.value) == (f"--out {tmp_path / 'g.csv'} (Python: out=): its extension .csv "
                            "names no export format; name it .h5 (or .hdf5), .npz or .json, or "
                            "give --format h5, npz or json (Python: fmt=); --format acronym, "
                            "graspgen or isaac writes a folder of files")
    with pytest.raises(InputError, match=r"it has no extension, so it names no export format"):
        export_database(db_path, tmp_path / "grasps")
    with pytest.raises(InputError, match=r"^--format \(Python: fmt=\): expected one of h5, "
                                         "npz, json, got 'csv'$"):
        export_database(db_path, tmp_path / "g.h5", "csv")
    from synth.database.export_objects import export_objects

    with pytest.raises(InputError, match=r"^--format \(Python: fmt=\): expected one of acronym"):
        export_objects(db_path, tmp_path / "objects", "csv")
    from synth.cli import main

    assert main(["db", "export", str(db_path), "--out", str(tmp_path / "g.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"synth: error: --out {tmp_path / 'g.csv'}: its "
                          "extension .csv names no export format") and "\n" not in err, err
    assert not (tmp_path / "g.csv").exists()
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(InputError, match=r'pip install "synth\[h5\]"'):
        export_database(db_path, tmp_path / "g.h5")


def test_dask_missing_gives_install_hint(
    built: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    mesh_dir, _ = built
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(InputError, match=r'pip install "synth\[dask\]"'):
        build_database([mesh_dir], tmp_path / "d.sqlite", PARAMS, engine="dask", planner=PLANNER)


def test_lookup_by_name_stem_path_and_sha(built: tuple[Path, Path]) -> None:
    mesh_dir, db_path = built
    with GraspDatabase(db_path) as db:
        box = db.mesh("box.stl")
        assert db.mesh("box") == box
        assert db.mesh(str(mesh_dir / "box.stl")) == box
        assert db.mesh(box.sha256[:10]) == box  # type: ignore[index]
        assert db.mesh(box.id) == box
        assert len(db) == 7 and [m.id for m in db] == sorted(m.id for m in db)
        top = db.top("box", k=2)
        assert [g.rank for g in top] == [1, 2]
        assert top == list(db.grasps("box"))[:2]
        dup = db.mesh("dup")
        assert dup.sha256 == box.sha256 and dup.duplicate_of == box.id
        with pytest.raises(InputError, match="no mesh matching 'nothing'"):
            db.mesh("nothing")


def test_no_match_lists_the_meshes_the_database_holds(built: tuple[Path, Path],
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """``db top DB nothere`` said only "no mesh matching 'nothere'", and no command lists a
    database's meshes: the line names the first five and how many more."""
    _, db_path = built
    with GraspDatabase(db_path) as db:
        names = [m.name for m in db.meshes()]
    assert len(names) == 7
    from synth.cli import main

    assert main(["db", "top", str(db_path), "nothere"]) == 2
    assert capsys.readouterr().err.strip() == (
        f"synth: error: {db_path}: no mesh matching 'nothere' (try a path, name or sha256); it "
        f"holds 7 meshes: {', '.join(names[:5])}, and 2 more")
    with GraspDatabase(db_path) as db:
        with pytest.raises(InputError, match=r"no mesh matching 99 .*; it holds 7 meshes: "):
            db.mesh(99)


def test_ambiguous_name(tmp_path: Path) -> None:
    import trimesh

    for folder, extents in (("a", (1.0, 1.0, 1.0)), ("b", (1.0, 2.0, 1.0))):
        (tmp_path / folder).mkdir()
        trimesh.creation.box(extents=extents).export(tmp_path / folder / "box.stl")
    out = tmp_path / "g.sqlite"
    build_database([tmp_path / "a", tmp_path / "b"], out, PARAMS, workers=0, planner=PLANNER)
    with GraspDatabase(out) as db:
        with pytest.raises(InputError, match=r"2 meshes match 'box'.*a/box\.stl.*b/box\.stl"):
            db.mesh("box")
        assert db.mesh(str(tmp_path / "b" / "box.stl")).status == "done"


def test_bad_database_files_are_named_and_left_alone(built: tuple[Path, Path],
                                                     tmp_path: Path) -> None:  # fmt: skip
    mesh_dir, db_path = built
    text = tmp_path / "notes.sqlite"
    text.write_text("hello, not a database\n")
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE users (name TEXT)")
    conn.close()
    future = tmp_path / "future.sqlite"
    future.write_bytes(db_path.read_bytes())
    with sqlite3.connect(future) as conn:
        conn.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    conn.close()
    cases = [(text, "not an SQLite file"), (other, "without a 'meta' table"),
             (future, "schema version 99")]  # fmt: skip
    for path, message in cases:
        data = path.read_bytes()
        for mode in ("r", "w"):
            with pytest.raises(DatabaseError, match=message) as err:
                GraspDatabase(path, mode=mode)
            assert str(path) in str(err.value)
        with pytest.raises(DatabaseError, match=message):
            build_database([mesh_dir], path, PARAMS, workers=0, planner=PLANNER)
        assert path.read_bytes() == data
    with pytest.raises(DatabaseError, match="no such grasp database"):
        GraspDatabase(tmp_path / "missing.sqlite")


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "synth", "db", *args],
        capture_output=True, text=True, env=planner_env(), timeout=60,
    )  # fmt: skip


def test_cli_build_info_top_export(built: tuple[Path, Path], tmp_path: Path) -> None:
    mesh_dir, db_path = built
    out = tmp_path / "cli.sqlite"
    args = [f"--{k}={v}" for k, v in PARAMS.items()]
    r = _cli("build", str(mesh_dir), "--out", str(out), "--workers", "2", *args)
    assert r.returncode == 0, r.stderr
    assert "4 done, 2 failed" in r.stderr and "random.stl" in r.stderr
    assert snapshot(out)[1] == snapshot(db_path)[1]
    r = _cli("info", str(out), "--json")
    info = json.loads(r.stdout)
    assert {k: info[k] for k in ("meshes", "done", "failed", "grasps")} == {
        "meshes": 7, "done": 4, "failed": 2, "grasps": len(snapshot(out)[1]),
    }  # fmt: skip
    r = _cli("info", str(out))
    assert "failures:" in r.stdout and "empty.stl" in r.stdout
    r = _cli("top", str(out), "ico", "-k", "2")
    assert r.returncode == 0 and r.stdout.count("form closure") == 2
    # the least squeeze per weight, as stored, in its column
    with GraspDatabase(out) as db:
        stored = [g.squeeze_per_weight for g in db.top("ico", 2)]
    head, *rows = r.stdout.splitlines()[1:3 + 1]
    column = head.split().index("N/weight")
    # the row number is '#', as in the gripper table and docs/vocabulary.md ('rank' is a
    # wrench matrix's rank in synth's words)
    assert head.split()[0] == "#" and "rank" not in head.split(), head
    assert [row.split()[0] for row in rows] == ["1", "2"]
    assert None not in stored
    assert [float(row.split()[column]) for row in rows] == pytest.approx(stored, abs=5e-4)
    r = _cli("top", str(out), "random.stl", "--json")  # a failed mesh says so, as the table does
    top = json.loads(r.stdout)
    assert (top["status"], top["error_kind"], top["grasps"]) == ("failed", "mesh", [])
    assert top["error"].startswith("cannot load mesh")
    r = _cli("export", str(out), "--format", "json", "--out", str(tmp_path / "e.json"))
    assert r.returncode == 0 and json.loads((tmp_path / "e.json").read_text())["meshes"]


def test_cli_errors_are_one_line(tmp_path: Path) -> None:
    """A file that is not a database, or no file at all, is bad input (status 2), as a
    missing or malformed mesh is."""
    bad = tmp_path / "bad.sqlite"
    bad.write_bytes(b"\x00" * 100)
    missing = str(tmp_path / "missing.sqlite")
    for code, args in ((2, ("info", str(bad))), (2, ("top", str(bad), "box")),
                       (2, ("build", str(tmp_path / "nope"), "--out", str(bad))),
                       (2, ("info", missing)),
                       (2, ("export", missing, "--out", str(tmp_path / "e.json")))):  # fmt: skip
        r = _cli(*args)
        assert r.returncode == code, r.stderr
        assert r.stderr.startswith("synth: error: ") and r.stderr.count("\n") == 1, r.stderr
        assert "Traceback" not in r.stderr


def test_cli_help_is_plain_text(capsys: pytest.CaptureFixture[str]) -> None:
    from synth.cli import main

    texts = {}
    for args in ((), ("build",), ("info",), ("top",), ("export",)):
        with pytest.raises(SystemExit) as exit_:
            main(["db", *args, "--help"])
        assert exit_.value.code == 0
        texts[args] = " ".join(capsys.readouterr().out.split())
        assert texts[args].startswith("usage: synth db")
        assert "``" not in texts[args] and ":func:" not in texts[args], texts[args]
    build = texts[("build",)]
    assert "same evaluation budget as 'synth plan'" in build
    assert "resumable" in build and "SYNTH_DB_PLANNER" in build


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_on_a_tty() -> None:
    tty, pipe = _Tty(), io.StringIO()
    for stream in (tty, pipe):
        bar = ProgressBar(4, stream=stream)
        bar.update(2, 1, 30, force=True)
        bar.close()
    assert "2/4 meshes, 1 failed, 30 grasps" in tty.getvalue() and "ETA" in tty.getvalue()
    assert pipe.getvalue() == ""
    quiet = _Tty()
    bar = ProgressBar(4, stream=quiet, quiet=True)
    bar.update(1, 0, 1, force=True)
    assert quiet.getvalue() == ""


def test_export_replaces_only_its_own_files(built: tuple[Path, Path], tmp_path: Path) -> None:
    """An export never lands on the database it reads, nor on a file synth did not write;
    an earlier export of each format is replaced."""
    _, db_path = built
    copy = tmp_path / "copy.sqlite"
    copy.write_bytes(db_path.read_bytes())
    with pytest.raises(InputError, match="this is the database being exported"):
        export_database(copy, copy, "json")
    assert copy.read_bytes() == db_path.read_bytes()
    for name in ("mine.json", "mine.npz", "mine.h5"):
        mine = tmp_path / name
        mine.write_bytes(b"the user's own notes")
        with pytest.raises(InputError, match="is not an export synth wrote"):
            export_database(db_path, mine)
        assert mine.read_bytes() == b"the user's own notes"
    for fmt in ("json", "npz", "h5"):
        out = tmp_path / f"again.{fmt}"
        export_database(db_path, out)
        first = out.read_bytes()
        out.write_bytes(first)
        assert export_database(db_path, out) == fmt  # its own earlier export: replaced


def test_an_export_named_for_another_format_and_an_order_without_its_measure(
        built: tuple[Path, Path], tmp_path: Path) -> None:
    """``--format npz`` into ``x.json`` would write a zip file named JSON; ranking by the
    placement tolerance a database built without ``--regions`` would keep the build order."""
    _, db_path = built
    with pytest.raises(InputError, match="a .json name for a npz export"):
        export_database(db_path, tmp_path / "x.json", "npz")
    assert not (tmp_path / "x.json").exists()
    with GraspDatabase(db_path) as db:
        name = next(m.path for m in db.meshes() if m.n_grasps)
        assert all(g.tolerance is None for g in db.top(name, 5))
        with pytest.raises(InputError, match=r"^--rank-by \(Python: rank_by=\) 'tolerance': "
                                             ".* no placement tolerance"):
            db.top(name, 5, "tolerance")
    with pytest.raises(InputError, match=r"^--workers \(Python: workers=\): expected at least "
                                         r"1 with the dask engine \(0, in this process: the "
                                         r"local engine only\), got 0"):
        build_database([tmp_path], tmp_path / "d.sqlite", {}, engine="dask", workers=0)


def test_a_damaged_page_found_while_exporting_is_a_database_error(
        built: tuple[Path, Path], tmp_path: Path) -> None:
    """SQLite reads a table's pages as a query goes: a database damaged past its first pages
    opens, then fails mid-export; that is the file's failure (DatabaseError, exit status 1),
    not an internal error, and no export is written."""
    _, db_path = built
    copy = tmp_path / "damaged.sqlite"
    data = bytearray(db_path.read_bytes())
    data[-3 * 4096:] = b"\xff" * (3 * 4096)  # the last pages: grasps and meshes rows
    copy.write_bytes(bytes(data))
    for fmt in ("json", "npz"):
        with pytest.raises(DatabaseError, match="query failed"):
            export_database(copy, tmp_path / f"x.{fmt}")
        assert not (tmp_path / f"x.{fmt}").exists()


def test_database_arguments_are_named(built: tuple[Path, Path]) -> None:
    """None as a path, a count given as text, no mesh: InputError naming the argument (a
    TypeError from deep inside before)."""
    _, db_path = built
    with pytest.raises(InputError, match="^path: expected"):
        GraspDatabase(None)  # type: ignore[arg-type]
    with GraspDatabase(db_path) as db:
        name = next(m.path for m in db.meshes() if m.n_grasps)
        with pytest.raises(InputError, match="^k: expected an integer"):
            db.top(name, "2")  # type: ignore[arg-type]
        with pytest.raises(InputError, match="^mesh: expected"):
            db.top(None, 2)  # type: ignore[arg-type]
        assert len(db.top(name, 1)) == 1


def test_a_planner_name_without_its_function_names_where_it_came_from(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The planner's name is checked before anything is opened; the message says which of the
    argument (the command's option and the Python keyword) and the environment variable gave
    it."""
    from synth.database.worker import PLANNER_ENV

    meshes = make_mesh_dir(tmp_path)
    with pytest.raises(InputError, match=r"planner 'synth\.plan' \(from --planner, Python: "
                                         r"planner=\) must be 'module:function'"):
        build_database(meshes, tmp_path / "a.db", planner="synth.plan")
    monkeypatch.setenv(PLANNER_ENV, "synth.plan")
    with pytest.raises(InputError, match=rf"\(from {PLANNER_ENV}\)"):
        build_database(meshes, tmp_path / "b.db")
    assert not (tmp_path / "a.db").exists() and not (tmp_path / "b.db").exists()


def test_the_build_summary_counts_in_words(tmp_path):
    """'1 mesh file', not '1 mesh files'."""
    import trimesh

    trimesh.creation.box().export(tmp_path / "one.stl")
    report = build_database([tmp_path / "one.stl"], tmp_path / "g.sqlite", PARAMS,
                            planner=PLANNER, workers=0)
    assert ": 1 mesh file, 1 planned" in report.summary()
