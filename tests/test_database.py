"""Building grasp databases: counts, failures, resuming, kill -9, engines and workers."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from synth.database import GraspDatabase, build_database
from synth.errors import DatabaseError, InputError
from tests.db_support import (
    BROKEN,
    DUPLICATE,
    GOOD,
    PARAMS,
    PLANNER,
    make_mesh_dir,
    planner_env,
    snapshot,
)


def test_build_counts_and_failures(tmp_path: Path, mesh_dir: Path) -> None:
    out = tmp_path / "g.sqlite"
    report = build_database([mesh_dir], out, PARAMS, workers=2, planner=PLANNER, quiet=True)
    assert report.found == len(GOOD) + len(BROKEN) + 1
    assert (report.planned, report.done, report.failed) == (6, 4, 2)
    assert report.duplicates == 1 and report.skipped == 0
    assert report.ignored == (str(mesh_dir / "notes.txt"),)
    assert {os.path.basename(p) for p, _ in report.failures} == set(BROKEN)
    with GraspDatabase(out) as db:
        info = db.info()
        assert (info.meshes, info.done, info.failed, info.duplicates, info.pending) == (
            7, 4, 2, 1, 0,
        )  # fmt: skip
        assert info.grasps == report.grasps > 0
        for path, kind, error in info.failures:
            assert kind == "mesh" and "cannot load mesh" in error and path in error
        by_name = {m.name: m for m in db.meshes()}
        assert by_name["dup.stl"].duplicate_of == by_name["box.stl"].id
        assert "same content as" in (by_name["dup.stl"].error or "")
        for m in db.meshes():
            grasps = list(db.grasps(m.id)) if m.status != "duplicate" else []
            assert len(grasps) == m.n_grasps
            if m.status == "done":
                assert m.n_grasps > 0 and m.sha256 and m.size and m.units == "unknown"
                assert [g.rank for g in grasps] == list(range(1, m.n_grasps + 1))
                d = [g.d_star for g in grasps]
                assert d == sorted(d, reverse=True)
            else:
                assert m.n_grasps == 0
        assert db.params == {**db.params, **PARAMS}
        assert [g.d_star for g in db.top("dup.stl", 3)] == [g.d_star for g in db.top("box", 3)]


def test_rerun_skips_then_retry_failed(tmp_path: Path, mesh_dir: Path, reference: Path) -> None:
    before = snapshot(reference)
    again = build_database([mesh_dir], reference, PARAMS, workers=0, planner=PLANNER)
    assert (again.planned, again.skipped, again.grasps) == (0, 7, 0)
    assert snapshot(reference) == before
    retry = build_database(
        [mesh_dir], reference, PARAMS, workers=0, planner=PLANNER, retry_failed=True
    )
    assert (retry.planned, retry.failed, retry.done) == (2, 2, 0)
    assert snapshot(reference) == before


def test_changed_file_is_replanned_and_duplicate_split(
    tmp_path: Path, mesh_dir: Path, reference: Path
) -> None:
    import trimesh

    trimesh.creation.box(extents=(1.0, 1.0, 2.0)).export(mesh_dir / "box.stl")
    report = build_database([mesh_dir], reference, PARAMS, workers=0, planner=PLANNER)
    assert report.planned == 2  # box.stl changed; dup.stl keeps the old bytes, now an original
    with GraspDatabase(reference) as db:
        box, dup = db.mesh("box.stl"), db.mesh(DUPLICATE.split("/")[-1])
        assert box.status == dup.status == "done" and dup.duplicate_of is None
        assert box.sha256 != dup.sha256
        assert db.info().duplicates == 0


def test_kill_and_resume_equals_uninterrupted_run(
    tmp_path: Path, mesh_dir: Path, reference: Path
) -> None:
    out = tmp_path / "killed.sqlite"
    cmd = [
        sys.executable, "-m", "synth.database", "build", str(mesh_dir), "--out", str(out),
        "--workers", "1", "--quiet",
    ] + [f"--{k}={v}" for k, v in PARAMS.items()]  # fmt: skip
    proc = subprocess.Popen(
        cmd, env=planner_env({"SYNTH_FAKEPLANNER_DELAY": "0.4"}), start_new_session=True
    )
    done = 0
    deadline = time.monotonic() + 30
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                with GraspDatabase(out) as db:
                    done = db.info().done
            except DatabaseError:
                pass  # not created yet
            if done >= 1:
                break
            time.sleep(0.02)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL, "the build ended before it could be killed"
    with GraspDatabase(out) as db:
        info = db.info()
        assert 1 <= info.done < len(GOOD)
        assert info.pending > 0
        for m in db.meshes():
            stored = sum(1 for _ in db.grasps(m.id)) if m.status != "duplicate" else 0
            assert stored == (m.n_grasps if m.status == "done" else 0)
    report = build_database([mesh_dir], out, PARAMS, workers=2, planner=PLANNER)
    assert report.skipped >= 1 and report.planned < 6
    assert snapshot(out) == snapshot(reference)


def test_same_results_with_1_and_2_workers_and_dask(
    tmp_path: Path, mesh_dir: Path, reference: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    expected = snapshot(reference)
    for workers in (1, 2):
        out = tmp_path / f"w{workers}.sqlite"
        build_database([mesh_dir], out, PARAMS, workers=workers, planner=PLANNER)
        assert snapshot(out) == expected, f"{workers} workers"
    distributed = pytest.importorskip("distributed")
    for key, value in planner_env().items():
        monkeypatch.setenv(key, value)  # the worker processes import the test planner
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        out = tmp_path / "dask.sqlite"
        report = build_database(
            [mesh_dir], out, PARAMS, engine="dask", scheduler=cluster.scheduler_address,
            planner=PLANNER,
        )  # fmt: skip
        assert report.workers == 2 and report.engine == "dask"
    assert snapshot(out) == expected


def test_timeout_is_recorded_as_failure(tmp_path: Path, mesh_dir: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:  # fmt: skip
    monkeypatch.setenv("SYNTH_FAKEPLANNER_DELAY", "5")
    out = tmp_path / "t.sqlite"
    report = build_database(
        [mesh_dir / "box.stl"], out, PARAMS, workers=0, planner=PLANNER, timeout=0.3
    )
    assert report.failed == 1 and report.elapsed_s < 4
    with GraspDatabase(out) as db:
        m = db.mesh("box")
        assert (m.status, m.error_kind, m.error) == (
            "failed", "timeout", "timed out: the mesh exceeded --timeout 0.3 s"
        )


def test_list_file_with_relative_missing_and_non_mesh_entries(
    tmp_path: Path, mesh_dir: Path
) -> None:
    listing = mesh_dir / "sub" / "list.txt"
    listing.write_text("# meshes\n../box.stl\n\ndeeper/cyl.obj\nmissing.stl\n../notes.txt\n")
    out = tmp_path / "l.sqlite"
    report = build_database([listing], out, PARAMS, workers=0, planner=PLANNER)
    assert (report.found, report.done, report.failed) == (4, 2, 2)
    with GraspDatabase(out) as db:
        reasons = {m.name: (m.error_kind, m.error) for m in db.meshes(status="failed")}
    assert reasons["missing.stl"] == ("unreadable", "no such file (listed in a list file)")
    assert reasons["notes.txt"][0] == "not_mesh" and "not a mesh file" in reasons["notes.txt"][1]


def test_bad_sources_and_parameters_write_nothing(tmp_path: Path, mesh_dir: Path,
                                                  reference: Path) -> None:  # fmt: skip
    before = snapshot(reference)
    with pytest.raises(InputError, match="no such file or folder"):
        build_database([tmp_path / "nope"], reference, PARAMS, planner=PLANNER)
    with pytest.raises(InputError, match="none of its 1 entries"):
        build_database([mesh_dir / "notes.txt"], tmp_path / "new.sqlite", PARAMS, planner=PLANNER)
    assert not (tmp_path / "new.sqlite").exists()
    with pytest.raises(DatabaseError, match=r"reference\.sqlite.*other planner parameters.*seed"):
        build_database([mesh_dir], reference, {**PARAMS, "seed": 9}, planner=PLANNER)
    with pytest.raises(DatabaseError, match="built with planner"):
        build_database([mesh_dir], reference, PARAMS, planner="tests.db_support:snapshot")
    with pytest.raises(InputError, match="unknown planner parameter 'speed'"):
        build_database([mesh_dir], reference, {"speed": 1}, planner=PLANNER)
    with pytest.raises(InputError, match="cannot import planner module"):
        build_database([mesh_dir], reference, PARAMS, planner="no_such_module:plan")
    assert snapshot(reference) == before
    empty = tmp_path / "mine.sqlite"  # a file of the user's, empty: SQLite would take it
    empty.write_bytes(b"")
    with pytest.raises(InputError, match="an empty file, not a grasp database synth began"):
        build_database([mesh_dir], empty, PARAMS, planner=PLANNER)
    assert empty.read_bytes() == b""
    link = tmp_path / "link.sqlite"  # a link to a file not there yet: the file is made
    link.symlink_to(tmp_path / "target.sqlite")
    build_database([mesh_dir], link, PARAMS, planner=PLANNER)
    assert (tmp_path / "target.sqlite").stat().st_size > 0


def test_plan_cut_by_the_time_cap_is_a_failure_not_a_result(tmp_path):
    from synth.database import GraspDatabase

    mesh_dir = make_mesh_dir(tmp_path)
    out = tmp_path / "cut.sqlite"
    build_database([mesh_dir], out, PARAMS, workers=0, quiet=True,
                   planner="tests.db_fakeplanner:plan_cut_by_time")
    with GraspDatabase(out) as db:
        info = db.info()
        assert info.grasps == 0 and info.done == 0 and info.failed >= 1
        failed = [m for m in db.meshes() if m.status == "failed"]
        assert any(m.error_kind == "time_cap" and "time cap" in m.error for m in failed)


def test_a_database_from_before_surface_resumes_only_with_the_smooth_model(
        tmp_path: Path, mesh_dir: Path, reference: Path) -> None:
    """A database built before ``--surface`` existed holds grasps scored with the smooth
    reading: resuming it with the default (both) would mix two models, so it is refused with
    the parameter named; ``surface="smooth"`` resumes it."""
    import json
    import sqlite3

    conn = sqlite3.connect(reference)
    params = json.loads(conn.execute("SELECT value FROM meta WHERE key = 'params'").fetchone()[0])
    del params["surface"]
    with conn:
        conn.execute("UPDATE meta SET value = ? WHERE key = 'params'",
                     (json.dumps(params, sort_keys=True, separators=(",", ":")),))
    conn.close()
    with pytest.raises(DatabaseError, match="surface: stored 'smooth', asked 'both'"):
        build_database([mesh_dir], reference, PARAMS, planner=PLANNER)
    build_database([mesh_dir], reference, {**PARAMS, "surface": "smooth"}, planner=PLANNER)


def test_a_scheduler_address_is_bad_input_and_a_silent_one_the_systems(
        tmp_path: Path, mesh_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An address dask cannot parse is the user's to fix (InputError, exit status 2); a
    scheduler that does not answer is the system's refusal (DatabaseError, exit status 1),
    not an internal error."""
    distributed = pytest.importorskip("distributed")
    with pytest.raises(InputError, match="not a Dask scheduler address"):
        build_database([mesh_dir], tmp_path / "a.sqlite", PARAMS, engine="dask",
                       scheduler="notanaddress", planner=PLANNER)

    def silent(*args: object, **kwargs: object) -> None:
        raise OSError("Timed out trying to connect to tcp://127.0.0.1:1 after 30 s")

    monkeypatch.setattr(distributed, "Client", silent)
    with pytest.raises(DatabaseError, match="cannot connect to the Dask scheduler") as e:
        build_database([mesh_dir], tmp_path / "b.sqlite", PARAMS, engine="dask",
                       scheduler="tcp://127.0.0.1:1", planner=PLANNER)
    assert not isinstance(e.value, InputError)
