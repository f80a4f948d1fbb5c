"""Database builds that are killed, raced, misconfigured or read from read-only places."""

from __future__ import annotations

import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import trimesh

from synth.cli import main
from synth.database import GraspDatabase, build_database, collect_mesh_files, export_database
from synth.database.schema import SCHEMA_VERSION
from synth.errors import DatabaseError, InputError
from tests.db_support import (
    PARAMS,
    PLANNER,
    alive,
    descendants,
    folder_state,
    planner_env,
    snapshot,
)

ARGS = [f"--{k}={v}" for k, v in PARAMS.items()]


def _build_cmd(mesh_dir: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "synth.database", "build", str(mesh_dir), "--out", str(out),
            "--quiet", *ARGS, *extra]  # fmt: skip


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run ``synth`` in this process: (exit status, stdout, stderr), argparse exits included."""
    try:
        code = main(argv)
    except SystemExit as e:
        code = int(e.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def _one_line(err: str) -> None:
    assert err.startswith("synth: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err


def _consistent(path: Path) -> None:
    """Every mesh's stored grasps match its status and count."""
    with GraspDatabase(path) as db:
        for m in db.meshes():
            stored = sum(1 for _ in db.grasps(m.id)) if m.status != "duplicate" else 0
            assert stored == (m.n_grasps if m.status == "done" else 0), m


# -- 1. killing a build ends its workers ----------------------------------------------------


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="finds processes in /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_killed_build_leaves_no_worker_process(
    tmp_path: Path, mesh_dir: Path, reference: Path, sig: signal.Signals
) -> None:
    out, pids = tmp_path / "killed.sqlite", tmp_path / "pids"
    pids.mkdir()
    env = planner_env({"SYNTH_FAKEPLANNER_DELAY": "3", "SYNTH_FAKEPLANNER_PIDS": str(pids)})
    stderr = open(tmp_path / "stderr.txt", "w+")  # a file: workers left over would hold a pipe
    proc = subprocess.Popen(_build_cmd(mesh_dir, out, "--workers", "2"), env=env,
                            stderr=stderr, start_new_session=True)  # fmt: skip
    family: set[int] = set()
    try:
        deadline = time.monotonic() + 60
        while len(os.listdir(pids)) < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        workers = {int(p) for p in os.listdir(pids)}
        assert len(workers) == 2 and proc.poll() is None, "the workers did not start in time"
        family = descendants(proc.pid)  # the workers and multiprocessing's resource tracker
        assert workers <= family
        os.kill(proc.pid, sig)  # the parent alone, as 'kill' does
        proc.wait(timeout=20)
        deadline = time.monotonic() + 5
        while any(alive(p) for p in family) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = {p for p in family if alive(p)}
    finally:
        for p in family:
            if alive(p):
                os.kill(p, signal.SIGKILL)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        stderr.seek(0)
        err = stderr.read()
        stderr.close()
    assert not left, f"processes left running after {sig.name} of the build: {sorted(left)}"
    if sig == signal.SIGTERM:
        assert proc.returncode == 128 + signal.SIGTERM, err
        assert err.startswith("synth: terminated") and err.count("\n") == 1, err
        assert not os.path.exists(f"{out}-wal")  # closed whole, at rest
    else:
        assert proc.returncode == -signal.SIGKILL
    _consistent(out)
    with GraspDatabase(out) as db:
        assert db.info().pending > 0
    report = build_database([mesh_dir], out, PARAMS, workers=0, planner=PLANNER, quiet=True)
    assert report.planned > 0
    assert snapshot(out) == snapshot(reference)


# -- 2. reading never writes ----------------------------------------------------------------


def _wal_copy(src: Path, dst: Path) -> None:
    """A copy of ``src`` left in WAL mode without a -wal file (as older builds left them)."""
    shutil.copyfile(src, dst)
    conn = sqlite3.connect(dst)
    assert conn.execute("PRAGMA journal_mode = WAL").fetchone()[0] == "wal"
    conn.close()
    assert not os.path.exists(f"{dst}-wal")


def _read_everything(db_path: Path, export_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["info", str(db_path)], ["top", str(db_path), "box", "-k", "2"],
                 ["export", str(db_path), "--out", str(export_dir / f"{db_path.name}.json")]):
        code, out, err = _cli(["db", *argv], capsys)
        assert code == 0, err
    assert "2 grasps" in _cli(["db", "top", str(db_path), "box", "-k", "2"], capsys)[1]
    export_database(db_path, export_dir / f"{db_path.name}.npz")
    with GraspDatabase(db_path) as db:
        assert db.info().done == 4 and len(db.top("ico", 3)) == 3


def _two_databases(tmp_path: Path, mesh_dir: Path, workers: int) -> tuple[Path, Path]:
    """A folder with a finished build (g.sqlite) and a copy still in WAL mode (wal.sqlite),
    and an empty folder for exports."""
    folder, exports = tmp_path / "dbs", tmp_path / "exports"
    folder.mkdir()
    exports.mkdir()
    build_database([mesh_dir], folder / "g.sqlite", PARAMS, workers=workers, planner=PLANNER,
                   quiet=True)  # fmt: skip
    assert sorted(os.listdir(folder)) == ["g.sqlite"]  # a finished build leaves no -wal, -shm
    _wal_copy(folder / "g.sqlite", folder / "wal.sqlite")
    return folder, exports


def test_reading_leaves_the_folder_as_it_was(
    tmp_path: Path, mesh_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder, exports = _two_databases(tmp_path, mesh_dir, workers=2)
    before = folder_state(folder)
    data = {name: (folder / name).read_bytes() for name in os.listdir(folder)}
    time.sleep(0.01)  # so that a write would change an mtime
    for name in ("g.sqlite", "wal.sqlite"):
        _read_everything(folder / name, exports, capsys)
    assert folder_state(folder) == before
    assert {name: (folder / name).read_bytes() for name in os.listdir(folder)} == data


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes to read-only folders")
def test_reading_in_a_read_only_folder(
    tmp_path: Path, mesh_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder, exports = _two_databases(tmp_path, mesh_dir, workers=0)
    before = folder_state(folder)
    folder.chmod(0o555)
    try:
        for name in ("g.sqlite", "wal.sqlite"):
            _read_everything(folder / name, exports, capsys)
    finally:
        folder.chmod(0o755)
    assert folder_state(folder) == {**before, ".": folder_state(folder)["."]}


def _private_mounts() -> bool:
    """Whether this process may make a private mount namespace (root with CAP_SYS_ADMIN)."""
    if os.geteuid() != 0 or shutil.which("unshare") is None:
        return False
    probe = subprocess.run(["unshare", "--mount", "--propagation", "private", "true"],
                           capture_output=True)  # fmt: skip
    return probe.returncode == 0


@pytest.mark.skipif(not _private_mounts(), reason="needs root and mount namespaces")
def test_reading_on_a_read_only_mount(tmp_path: Path, mesh_dir: Path) -> None:
    """As root, a read-only bind mount (in a private mount namespace) makes the folder truly
    unwritable."""
    folder, exports = _two_databases(tmp_path, mesh_dir, workers=0)
    before = folder_state(folder)
    reads = "; ".join(
        f"codes.append(main(['db', {cmd!r}, {str(folder / name)!r}, *{extra!r}]))"
        for name in ("g.sqlite", "wal.sqlite")
        for cmd, extra in (("info", []), ("top", ["box"]),
                           ("export", ["--out", str(exports / f"{name}.json")]))
    )  # fmt: skip
    script = (
        "import sys\nfrom synth.cli import main\n"
        f"try:\n    open({str(folder / 'probe')!r}, 'w')\n"  # the mount must refuse writes
        "except OSError:\n    pass\nelse:\n    sys.exit('the folder is writable')\n"
        f"codes = []; {reads}; sys.exit(max(codes))"
    )
    shell = 'mount --bind "$1" "$1" && mount -o remount,bind,ro "$1" && shift && exec "$@"'
    r = subprocess.run(
        ["unshare", "--mount", "--propagation", "private", "sh", "-c", shell, "sh", str(folder),
         sys.executable, "-c", script],
        capture_output=True, text=True, env=planner_env(), timeout=120,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("synth grasp database") == 2 and "Traceback" not in r.stderr
    assert len(list(exports.iterdir())) == 2
    assert folder_state(folder) == before


def test_a_killed_builds_log_is_read_not_ignored(tmp_path: Path, mesh_dir: Path,
                                                 reference: Path) -> None:  # fmt: skip
    out = tmp_path / "killed.sqlite"
    shutil.copyfile(reference, out)
    script = (
        "import os, sqlite3, sys\n"
        "c = sqlite3.connect(sys.argv[1], isolation_level=None)\n"
        "c.execute('PRAGMA journal_mode = WAL')\n"
        "c.execute(\"UPDATE meta SET value = 'x' WHERE key = 'created_at'\")\n"
        "os._exit(0)  # like a kill: the -wal holds the committed change\n"
    )
    subprocess.run([sys.executable, "-c", script, str(out)], check=True)
    assert os.path.getsize(f"{out}-wal") > 0
    with GraspDatabase(out) as db:
        assert db.meta["created_at"] == "x"


# -- 3. one writer at a time ------------------------------------------------------------------


def test_second_writer_is_refused_as_busy(tmp_path: Path) -> None:
    path = tmp_path / "new.sqlite"
    results: list[str] = []
    opened, tried = threading.Barrier(2), threading.Barrier(2)

    def open_writer() -> None:  # both create the schema of a new file at once
        opened.wait()
        try:
            db = GraspDatabase(path, mode="w")
        except DatabaseError as e:
            tried.wait()
            results.append(str(e))
        else:
            tried.wait()  # hold the file until the other one has tried
            db.close()
            results.append("opened")

    threads = [threading.Thread(target=open_writer) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(results) == 2 and results.count("opened") == 1, results
    message = next(r for r in results if r != "opened")
    assert message.startswith(f"{path}: database busy") and "\n" not in message
    with GraspDatabase(path, mode="w") as db:  # free again once the first writer is closed
        assert db.schema_version == SCHEMA_VERSION


def test_two_builds_of_one_new_database(tmp_path: Path, mesh_dir: Path, reference: Path) -> None:
    out = tmp_path / "raced.sqlite"
    env = planner_env({"SYNTH_FAKEPLANNER_DELAY": "0.3"})
    procs = [subprocess.Popen(_build_cmd(mesh_dir, out, "--workers", "0"), env=env,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]  # fmt: skip
    errs = [p.communicate(timeout=60)[1] for p in procs]
    codes = [p.returncode for p in procs]
    assert sorted(codes) == [0, 1], errs
    err = errs[codes.index(1)]
    _one_line(err)
    assert f"{out}: database busy" in err and "already exists" not in err
    assert snapshot(out) == snapshot(reference)


# -- 4. parameters are checked before the database is touched ---------------------------------


@pytest.mark.parametrize(
    "option", [["--evals", "50"], ["--contacts", "3"], ["--mu", "inf"], ["--top", "0"]]
)
def test_bad_parameters_exit_2_and_touch_no_database(
    tmp_path: Path, mesh_dir: Path, reference: Path, option: list[str],
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    new = tmp_path / "new.sqlite"
    before, data = folder_state(tmp_path), reference.read_bytes()
    for out in (new, reference):
        code, _, err = _cli(["db", "build", str(mesh_dir), "--out", str(out), "--planner",
                             PLANNER, *ARGS, *option], capsys)  # fmt: skip
        assert code == 2, err
        _one_line(err)
        assert option[0].lstrip("-") in err
    assert not new.exists() and reference.read_bytes() == data
    assert folder_state(tmp_path) == before


def test_bad_parameters_raise_before_the_database_is_created(tmp_path: Path,
                                                             mesh_dir: Path) -> None:  # fmt: skip
    out = tmp_path / "new.sqlite"
    for params, message in (({"evals": 50}, "^evals: expected .*100"),
                            ({"contacts": 3}, "needs at least 7 contacts"),
                            ({"mu": float("inf")}, "^mu: expected .*got inf"),
                            ({"mu": "a lot"}, "'mu' must be a number")):  # fmt: skip
        with pytest.raises(InputError, match=message):
            build_database([mesh_dir], out, {**PARAMS, **params}, workers=0, planner=PLANNER)
    assert not out.exists()
    report = build_database([mesh_dir / "box.stl"], out, {**PARAMS, "contacts": 3, "mu": 0.5},
                            workers=0, planner=PLANNER)  # fmt: skip
    assert report.planned == 1


# -- 5. a timeout is a timeout ------------------------------------------------------------------


def test_timeout_is_recorded_as_a_timeout_whatever_the_planner_catches(
    tmp_path: Path, mesh_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("SYNTH_FAKEPLANNER_DELAY", "5")
    out = tmp_path / "t.sqlite"
    report = build_database([mesh_dir / "box.stl"], out, PARAMS, workers=0, timeout=0.2,
                            planner="tests.db_fakeplanner:plan_catching_everything")  # fmt: skip
    assert report.failed == 1 and report.elapsed_s < 4
    with GraspDatabase(out) as db:
        m = db.mesh("box")
    assert (m.error_kind, m.error) == ("timeout", "timed out: the mesh exceeded --timeout 0.2 s")


def test_a_lost_alarm_is_raised_again(tmp_path: Path, mesh_dir: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """An alarm that fires where Python cannot pass an exception on (a gc callback) is lost:
    the limit raises again until the planner stops, instead of letting it run unbounded."""
    monkeypatch.setenv("SYNTH_FAKEPLANNER_DELAY", "5")
    out = tmp_path / "t.sqlite"
    report = build_database([mesh_dir / "box.stl"], out, PARAMS, workers=0, timeout=0.2,
                            planner="tests.db_fakeplanner:plan_losing_one_alarm")  # fmt: skip
    with GraspDatabase(out) as db:
        m = db.mesh("box")
    assert (m.error_kind, m.error) == ("timeout", "timed out: the mesh exceeded --timeout 0.2 s")
    assert report.elapsed_s < 4  # the lost alarm was followed by another


def test_a_worker_that_crashes_fails_its_mesh_with_the_signal(tmp_path: Path,
                                                               mesh_dir: Path) -> None:
    """A worker killed by SIGSEGV while planning a mesh: that mesh is recorded as failed,
    kind "crashed", with the signal; the other meshes are planned."""
    out = tmp_path / "c.sqlite"
    report = build_database([mesh_dir / "box.stl", mesh_dir / "ico.stl"], out, PARAMS,
                            workers=1, quiet=True,
                            planner="tests.db_fakeplanner:plan_crashing_on_ico")
    with GraspDatabase(out) as db:
        ico = db.mesh("ico")
        box = db.mesh("box")
    assert (ico.status, ico.error_kind) == ("failed", "crashed")
    assert "killed by SIGSEGV (segmentation fault)" in ico.error
    assert box.status == "done" and (report.done, report.failed) == (1, 1)
    assert any("ico.stl" in path and "SIGSEGV" in why for path, why in report.failures)


# An alarm that lands in a garbage-collector callback is dropped by Python, which reports it as
# unraisable; the repeating alarm (``worker._REPEAT``) then stops the planner, which this checks.
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_tiny_timeout_with_the_synth_planner(tmp_path: Path, mesh_dir: Path) -> None:
    out = tmp_path / "t.sqlite"
    build_database([mesh_dir / "box.stl", mesh_dir / "ico.stl"], out, {"evals": 2000},
                   workers=0, timeout=0.001, planner="synth.plan:plan_mesh_file")  # fmt: skip
    with GraspDatabase(out) as db:
        kinds = {(m.error_kind, m.error) for m in db.meshes()}
    assert kinds == {("timeout", "timed out: the mesh exceeded --timeout 0.001 s")}


# -- 6. symbolic links to folders -----------------------------------------------------------------


def test_symlinked_folders_are_followed_and_cycles_searched_once(
    tmp_path: Path, mesh_dir: Path, reference: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = tmp_path / "other"
    other.mkdir()
    trimesh.creation.box(extents=(1.0, 1.0, 3.0)).export(other / "tall.stl")
    (mesh_dir / "linked").symlink_to(other, target_is_directory=True)
    (mesh_dir / "sub" / "loop").symlink_to(mesh_dir, target_is_directory=True)  # a cycle
    inputs = collect_mesh_files([mesh_dir])
    assert str(mesh_dir / "linked" / "tall.stl") in inputs.paths
    assert len(inputs.paths) == 8  # the 7 meshes of make_mesh_dir and tall.stl, once each
    assert inputs.revisited == (str(mesh_dir / "sub" / "loop"),)
    assert collect_mesh_files([mesh_dir, other]).paths == inputs.paths  # other searched once
    nested = collect_mesh_files([mesh_dir, mesh_dir / "sub"])  # given twice, no link involved
    assert nested.paths == inputs.paths and nested.revisited == inputs.revisited
    out = tmp_path / "links.sqlite"
    code, _, err = _cli(["db", "build", str(mesh_dir), "--out", str(out), "--workers", "0",
                         "--planner", PLANNER, *ARGS], capsys)  # fmt: skip
    assert code == 0, err
    assert "5 done" in err and "searched once: 1 folders" in err and "sub/loop" in err
    with GraspDatabase(out) as db:
        assert db.mesh("tall").status == "done"
    _cli(["db", "build", "--help"], capsys)
    help_text = " ".join(_cli(["db", "build", "--help"], capsys)[1].split())
    assert "symbolic links to files and folders are followed" in help_text
    assert "link cycle, is searched once" in help_text


# -- 7. numeric options are checked up front ------------------------------------------------------


def test_numeric_options_are_checked_up_front(
    reference: Path, mesh_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    huge = "1" * 22
    cases = [
        # the words of every other option's check: "--top: ...", not argparse's "argument
        # --top/-k: ..."
        (["top", str(reference), "box", "-k", huge],
         "synth: error: --top: expected an integer from 0 to 1,000"),
        (["top", str(reference), "box", "--top", "-1"],
         "synth: error: --top: expected an integer from 0 to 1,000, got -1"),
        (["top", str(reference), "box", "-k", "two"],
         "synth: error: --top: expected an integer from 0 to 1,000, got 'two'"),
        (["build", str(mesh_dir), "--out", str(reference), "--workers", huge], "--workers"),
        (["build", str(mesh_dir), "--out", str(reference), "--workers", "-1"],
         "synth: error: --workers: expected an integer from 0 to 1,024, got -1"),
        (["build", str(mesh_dir), "--out", str(reference), "--workers", "x"],
         "synth: error: --workers: expected an integer from 0 to 1,024, got 'x'"),
        (["build", str(mesh_dir), "--out", str(reference), "--timeout", "-1"],
         "synth: error: --timeout: expected a number in (0, 1e+06] seconds, got '-1'"),
        (["build", str(mesh_dir), "--out", str(reference), "--seed", "-1"], "--seed"),
        (["build", str(mesh_dir), "--out", str(reference), "--timeout", "0"], "--timeout"),
        (["build", str(mesh_dir), "--out", str(reference), "--finger-radius", "nan"],
         "--finger-radius"),
        (["build", str(mesh_dir), "--out", str(reference), "--evals", huge], "--evals"),
    ]  # fmt: skip
    data = reference.read_bytes()
    for argv, message in cases:
        code = main(["db", *argv])  # returns 2 like every other command: no SystemExit
        out, err = capsys.readouterr()
        assert code == 2 and out == "", err
        _one_line(err)
        assert message in err and f"see 'synth db {argv[0]} --help'" in err
        assert "argument " not in err, err
    assert reference.read_bytes() == data
    top_help = " ".join(_cli(["db", "top", "--help"], capsys)[1].split())
    assert "print the best N grasps, 1 to 1,000, or 0 for all" in top_help
    build_help = " ".join(_cli(["db", "build", "--help"], capsys)[1].split())
    for text in ("contacts per grasp, one fingertip each: 7 to 64 without friction, 3 to 64 "
                 "with", "keep the best N grasps, 1 to 1,000",
                 "budget of grasp evaluations, 100 to 10,000,000", "worker processes, 0 to 1024",
                 "seconds of planning per mesh, above 0 to 1,000,000"):  # fmt: skip
        assert text in build_help, text
    with GraspDatabase(reference) as db:  # the library takes any k
        n = db.mesh("box").n_grasps
        assert len(db.top("box", 10**22)) == n
    assert n > 1
    code, out, _ = _cli(["db", "top", str(reference), "box", "--top", "0"], capsys)
    assert code == 0 and f": {n} grasps" in out.splitlines()[0]  # 0: all, as rank and score
    code, out, _ = _cli(["db", "top", str(reference), "box", "--top", "1"], capsys)
    assert code == 0 and out.splitlines()[0].endswith(": 1 grasp")


def test_a_reader_in_the_writers_process_leaves_the_writers_locks(tmp_path: Path) -> None:
    """Closing any descriptor of a file drops the POSIX locks SQLite holds on it in the
    process: a reader opened and closed next to a writer must not let another process switch
    the writer's database out of WAL mode under it."""
    path = tmp_path / "g.sqlite"
    probe = ("import sqlite3, sys\n"
             f"c = sqlite3.connect({str(path)!r}, isolation_level=None, timeout=0)\n"
             "try:\n"
             "    c.execute('PRAGMA journal_mode=DELETE')\n"
             "    print('switched')\n"
             "except sqlite3.OperationalError:\n"
             "    print('refused')\n")
    with GraspDatabase(path, "w") as w:
        w._conn.execute("SELECT count(*) FROM meshes").fetchone()
        other = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
        assert other.stdout.strip() == "refused"
        GraspDatabase(path).close()
        other = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
        assert other.stdout.strip() == "refused", other.stderr
        assert w._conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_one_source_given_as_a_string_is_one_source(mesh_dir: Path) -> None:
    """``build_database("parts", ...)``: a folder's name, not the folders 'p', 'a', 'r', ..."""
    assert collect_mesh_files(str(mesh_dir)).paths == collect_mesh_files([mesh_dir]).paths
    assert collect_mesh_files(mesh_dir).paths == collect_mesh_files([mesh_dir]).paths
