"""Build a grasp database: find the mesh files, plan the ones not done yet, store each result.

The parent process is the only writer. It hashes every file, decides what to plan (a mesh is
skipped when a row with the same path, SHA-256 and parameters is ``done`` -- or ``failed``,
unless ``retry_failed``), inserts the new meshes as ``pending`` in sorted path order (so ids do
not depend on the engine), then hands one task per mesh to an engine and writes each result in
one transaction with its status. A run killed at any moment leaves only whole meshes; running
the same command again finishes the rest. One build at a time writes a database file (a second
one is refused as busy), and worker processes end with the build's process, however it ends.

Engines: ``local`` (:mod:`synth.database.local`: a pool of spawned processes, each limited to
``cpus // workers`` BLAS/OpenMP threads unless ``OMP_NUM_THREADS`` and friends are set;
``workers=0`` plans in this process) and ``dask`` (a Dask distributed cluster, optional extra
``synth[dask]``; use
dask-jobqueue's ``SLURMCluster``/``PBSCluster`` and pass its scheduler address to reach a batch
system). The planner is deterministic given ``seed`` and the evaluation budget ``evals``; there
is deliberately no wall-clock budget, so results are identical, grasp for grasp, whatever the
engine and the number of workers. (``timeout`` only turns a runaway mesh into a failure.)
"""

from __future__ import annotations

import hashlib
import math
import numbers
import os
import signal
import threading
import time
from collections.abc import Callable, Hashable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TextIO

from synth.database.local import _Task, run_local
from synth.database.progress import ProgressBar, format_duration
from synth.database.schema import canonical_json
from synth.database.store import GraspDatabase
from synth.database.worker import PlanOutcome, crashed, load_planner, resolve_planner, run_one
from synth.errors import DatabaseError, DatabaseFileError, InputError
from synth.filetype import MESH_FORMATS
from synth.plan import LOAD_KEYS
from synth.plan.params import BUILD_TIME, PlanParams

__all__ = [
    "MESH_EXTENSIONS",
    "DEFAULT_PARAMS",
    "PARAMS_BEFORE",
    "MeshInputs",
    "BuildReport",
    "BuildTerminated",
    "normalize_params",
    "gripper_defaults",
    "resume_defaults",
    "collect_mesh_files",
    "build_database",
]

#: Mesh files a folder is searched for (:data:`synth.filetype.MESH_FORMATS`).
MESH_EXTENSIONS = MESH_FORMATS
#: A build's planner parameters when none are given: every field of
#: :class:`synth.plan.PlanParams` (the same search effort as ``synth plan``) and the mesh
#: options of :data:`synth.plan.LOAD_KEYS` (``sharp_angle`` in degrees), except the
#: wall-clock cap: far above a normal plan, so the evaluation budget (not the machine's
#: speed) decides the result; a plan the cap cuts is recorded as failed. A build that
#: simulates (``synth db build --sim``) has one parameter more, ``sim``: the
#: :class:`synth.sim.SimSettings` fields every grasp found is simulated with (by the worker;
#: the planner never sees it).
DEFAULT_PARAMS: dict[str, Any] = {**PlanParams().to_dict(), "time": BUILD_TIME, "units": None,
                                  "body": "largest", "sharp_angle": 30.0, "decimate": None}
#: What a parameter was before it existed, for databases built then: before ``surface``, grasps
#: were scored with the smooth reading of the normals (:mod:`synth.scores.surface`); before
#: ``max_squeeze`` there was no physical floor. Any other
#: parameter missing from a stored set matches its default.
PARAMS_BEFORE: dict[str, Any] = {"surface": "smooth", "max_squeeze": None}
#: Parameters that are numbers (stored as floats, so 1 and 1.0 are one parameter set).
_REAL_PARAMS = ("mu", "time", "finger_radius", "body_length", "body_radius", "approach_cone",
                "support_z", "min_d_star", "min_conditioning", "diversity", "min_tolerance",
                "sharp_angle", "max_squeeze", "grip", "mass", "density")


@dataclass(frozen=True)
class MeshInputs:
    """Mesh files found from the command-line sources.

    Attributes
    ----------
    paths : tuple of str
        Absolute paths of the mesh files (by extension), sorted, without repeats.
    ignored : tuple of str
        Files met in directories that are not meshes (by extension).
    not_mesh : tuple of str
        Entries of list files that are not mesh files (recorded as failed).
    missing : tuple of str
        Entries of list files that do not exist (recorded as failed).
    revisited : tuple of str
        Folders met again through a symbolic link (a link cycle, or a second link to a folder
        already searched): not searched twice.
    scenes : tuple of str
        GLB files met in folders that ``synth plan`` wrote (a part with its fingers, not a
        part; see :func:`synth.plan.result.scene_run_id`): not planned.
    """

    paths: tuple[str, ...]
    ignored: tuple[str, ...]
    not_mesh: tuple[str, ...]
    missing: tuple[str, ...]
    revisited: tuple[str, ...] = ()
    scenes: tuple[str, ...] = ()


@dataclass(frozen=True)
class BuildReport:
    """What one ``build_database`` run did.

    Attributes
    ----------
    database : str
        The database file.
    found : int
        Mesh files found in the sources (including list entries that failed).
    planned : int
        Meshes handed to the planner in this run.
    done, failed : int
        Of those (plus files that failed before planning, in ``failed``).
    duplicates : int
        New files recorded as duplicates of a mesh with the same content.
    skipped : int
        Meshes already in the database with the same content and parameters.
    grasps : int
        Grasps stored in this run.
    ignored : tuple of str
        Non-mesh files met in directories.
    revisited : tuple of str
        Folders met again through a symbolic link, not searched twice.
    scenes : tuple of str
        Scenes ``synth plan`` wrote, met in folders and not planned.
    failures : tuple of (str, str)
        ``(path, reason)`` of the meshes that failed in this run.
    elapsed_s : float
        Wall time of the run.
    engine : str
        ``local`` or ``dask``.
    workers : int
        Worker processes (local) or worker threads seen on the cluster (dask).
    """

    database: str
    found: int
    planned: int
    done: int
    failed: int
    duplicates: int
    skipped: int
    grasps: int
    ignored: tuple[str, ...]
    failures: tuple[tuple[str, str], ...]
    elapsed_s: float
    engine: str
    workers: int
    revisited: tuple[str, ...] = ()
    scenes: tuple[str, ...] = ()

    def summary(self) -> str:
        """A few readable lines for the end of a run."""
        lines = [
            f"{self.database}: {self.found} mesh file{'s' * (self.found != 1)}, "
            f"{self.planned} planned "
            f"({self.done} done, {self.failed} failed), {self.skipped} already recorded, "
            f"{self.duplicates} duplicates; {self.grasps} grasps stored in "
            f"{format_duration(self.elapsed_s)} ({self.engine}, "
            + (f"{self.workers} workers)" if self.workers else "in this process)")
        ]
        for path, reason in self.failures[:20]:
            lines.append(f"  failed: {path}: {reason}")
        if len(self.failures) > 20:
            lines.append(f"  ... and {len(self.failures) - 20} more (see 'synth db info')")
        if self.ignored:
            shown = ", ".join(self.ignored[:5]) + (", ..." if len(self.ignored) > 5 else "")
            lines.append(f"  ignored {len(self.ignored)} non-mesh files: {shown}")
        if self.scenes:
            shown = ", ".join(self.scenes[:5]) + (", ..." if len(self.scenes) > 5 else "")
            lines.append(f"  not planned: {len(self.scenes)} scenes synth plan wrote (a part "
                         f"with its fingers, not a part): {shown}")
        if self.revisited:
            shown = ", ".join(self.revisited[:5]) + (", ..." if len(self.revisited) > 5 else "")
            lines.append(f"  searched once: {len(self.revisited)} folders met again through "
                         f"symbolic links (a link cycle or a second link): {shown}")  # fmt: skip
        return "\n".join(lines)


def normalize_params(params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Planner parameters with defaults filled in, types checked, and checked by the planner.

    The values are checked as the planner will check them (:class:`synth.plan.PlanParams`:
    enough contacts for closure, a finite friction coefficient, an evaluation budget of at
    least 100, ...), so that a build with bad parameters fails before any file is touched,
    instead of recording every mesh as failed.

    A ``sim`` key (the simulation settings of ``synth db build --sim``, a dict of
    :class:`synth.sim.SimSettings` fields) is completed with the settings' defaults; None or
    absent, there is none (a build without simulation has the parameters it had before
    simulation existed).

    Raises
    ------
    InputError
        On an unknown key or a value of the wrong type or range.

    Examples
    --------
    >>> normalize_params({"contacts": 3})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    synth.errors.InputError: contacts: frictionless form closure in space needs at least 7 ...
    """
    given = dict(params or {})
    sim = _check_sim(given.pop("sim", None))
    out = _gripper_params(given) if "gripper" in given else _synth_params(given)
    return out if sim is None else {**out, "sim": sim}


def _synth_params(params: dict[str, Any]) -> dict[str, Any]:
    """Parameters of a point-finger build, defaults filled in (see :func:`normalize_params`)."""
    out = dict(DEFAULT_PARAMS)
    for key, value in params.items():
        if key not in DEFAULT_PARAMS:
            raise InputError(f"unknown planner parameter {key!r}; valid: {sorted(DEFAULT_PARAMS)}")
        out[key] = value
    for key in ("contacts", "top", "seed", "evals", "edges"):
        if isinstance(out[key], bool) or not isinstance(out[key], int):
            raise InputError(f"planner parameter {key!r} must be an integer, got {out[key]!r}")
    if not isinstance(out["regions"], bool):
        raise InputError(f"planner parameter 'regions' must be true or false, got "
                         f"{out['regions']!r}")
    for key in _REAL_PARAMS:
        if out[key] is not None:
            try:
                out[key] = float(out[key])
            except (TypeError, ValueError) as e:
                raise InputError(f"planner parameter {key!r} must be a number, got "
                                 f"{out[key]!r}") from e  # fmt: skip
    _check_load_options(out)
    PlanParams(**{k: v for k, v in out.items() if k not in LOAD_KEYS})
    return out


def _check_sim(sim: Any) -> dict[str, Any] | None:
    """The ``sim`` parameter: None, or every :class:`synth.sim.SimSettings` field (so that
    settings given in part and in full are one parameter set)."""
    if sim is None:
        return None
    from synth.sim.settings import SimSettings

    return SimSettings.from_dict(sim, "planner parameter 'sim'").to_dict()


def gripper_defaults() -> dict[str, Any]:
    """A gripper build's parameters when none are given: every field of
    :class:`synth.plan.gripper.GripperParams` and the mesh options of
    :data:`synth.plan.LOAD_KEYS` (``sharp_angle`` in degrees). A gripper database built before
    ``body`` and ``sharp_angle`` were among them resumes with their defaults."""
    from dataclasses import asdict

    from synth.plan.gripper import GripperParams

    return {**asdict(GripperParams()), "units": None, "body": "largest", "sharp_angle": 30.0}


def resume_defaults(params: dict[str, Any]) -> dict[str, Any]:
    """What a parameter missing from a stored set means, for a build of ``params`` (a point-
    finger or a gripper build): its default, or what it was before it existed
    (:data:`PARAMS_BEFORE`)."""
    if "gripper" in params:  # before min_margin, no grasp was refused for its squeeze
        return {**gripper_defaults(), "min_margin": None}
    return {**DEFAULT_PARAMS, **PARAMS_BEFORE}


def _gripper_params(params: dict[str, Any]) -> dict[str, Any]:
    """Parameters of a gripper build (``synth db build --gripper``), checked the same way:
    :func:`gripper_defaults`' keys, defaults filled in."""
    from synth.fingers.gripper import load_gripper

    defaults = gripper_defaults()
    for key in params:
        if key not in defaults:
            raise InputError(f"unknown gripper planner parameter {key!r}; valid: "
                             f"{sorted(defaults)}")
    out = {**defaults, **params}
    if out["sharp_angle"] is not None and not isinstance(out["sharp_angle"], bool):
        out["sharp_angle"] = float(out["sharp_angle"])
    _check_load_options(out)
    load_gripper(out["gripper"])
    for key in ("top", "seed", "samples"):
        if isinstance(out[key], bool) or not isinstance(out[key], int) or out[key] < 1 - (
                key == "seed"):
            raise InputError(f"planner parameter {key!r} must be a positive integer, got "
                             f"{out[key]!r}")
    if isinstance(out["mu"], bool) or not isinstance(out["mu"], (int, float)) or not (
            0 < out["mu"] < float("inf")):
        raise InputError(f"planner parameter 'mu' must be a number > 0, got {out['mu']!r}")
    margin = out["min_margin"]
    if margin is not None:
        if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not (
                0 <= margin < float("inf")):
            raise InputError("planner parameter 'min_margin' must be a number >= 0 or None, "
                             f"got {margin!r}")
        out["min_margin"] = float(margin) or None  # 0: no floor, stored as the CLI stores it
    return out


def _check_load_options(params: dict[str, Any]) -> None:
    """The mesh options of a parameter set, as :func:`synth.load_part` will check them."""
    from synth.part.load import length_unit

    units, body, angle = params["units"], params["body"], params["sharp_angle"]
    if units is not None and length_unit(str(units)) is None:
        raise InputError(f"planner parameter 'units': unknown length unit {units!r}; use "
                         "mm, cm, dm, m, um, in, ft or a trimesh unit name such as "
                         "'millimeters'")
    if isinstance(body, bool) or not isinstance(body, (int, str)):
        raise InputError(f"planner parameter 'body' must be 'largest', 'all', an index or a "
                         f"body name, got {body!r}")
    if angle is None or not 0 < angle < 180:
        raise InputError(f"planner parameter 'sharp_angle' must be in (0, 180) degrees, got "
                         f"{angle!r}")


def _is_mesh(path: str) -> bool:
    return os.path.splitext(path)[1].lower().lstrip(".") in MESH_EXTENSIONS


def _walk(folder: str, seen: set[str]) -> Iterator[tuple[str, list[str], bool]]:
    """``(folder, file names, first visit)`` under ``folder``, following symbolic links.

    A folder whose real path is in ``seen`` (met before through another path: a link cycle,
    or two links to one folder) is reported once with ``first visit`` False and not entered.
    """
    for root, dirs, files in os.walk(folder, followlinks=True):
        real = os.path.realpath(root)
        if real in seen:
            dirs.clear()
            yield root, [], False
            continue
        seen.add(real)
        dirs.sort()
        yield root, sorted(files), True


def collect_mesh_files(sources: Sequence[str | os.PathLike[str]]) -> MeshInputs:
    """Find mesh files: directories (recursively), mesh files, or text files listing paths.

    A source that is a directory contributes every file under it with a mesh extension
    (``stl obj ply off glb gltf 3mf``, any case), following symbolic links to files and
    folders; a folder met again through a link (a link cycle, or a second link to the same
    folder) is searched once and listed in ``revisited``; a folder given twice (``meshes/`` and
    ``meshes/corpus``) is searched once without a word. A file with a mesh extension is
    itself; any other file is read as a list of paths, one per line (blank lines and ``#``
    comments skipped; relative paths are relative to the list file's folder).

    Raises
    ------
    InputError
        If a source does not exist, a list file is not text, or no mesh file is found.
    """
    paths: set[str] = set()
    ignored: list[str] = []
    not_mesh: set[str] = set()
    missing: set[str] = set()
    seen: set[str] = set()  # real paths of the folders searched
    revisited: list[str] = []
    scenes: list[str] = []
    if isinstance(sources, (str, os.PathLike)):  # one source, not its letters
        sources = [sources]
    if not isinstance(sources, (list, tuple)) or not all(
            isinstance(s, (str, os.PathLike)) for s in sources):
        raise InputError(f"sources: expected folders, mesh files or list files (paths), got "
                         f"{sources!r:.80}")
    if not sources:
        raise InputError("no mesh source given (a folder, mesh files or a list file)")
    for src in (os.fspath(s) for s in sources):
        if os.path.isdir(src):
            for root, files, first in _walk(src, seen):
                if not first and os.path.realpath(root) != os.path.abspath(root):
                    revisited.append(os.path.abspath(root))  # met again through a link
                for name in files:
                    full = os.path.abspath(os.path.join(root, name))
                    if not _is_mesh(name):
                        ignored.append(full)
                    elif _is_scene(full):
                        scenes.append(full)
                    else:
                        paths.add(full)
        elif not os.path.exists(src):
            raise InputError(f"{src}: no such file or folder")
        elif _is_mesh(src):
            paths.add(os.path.abspath(src))
        else:
            base = os.path.dirname(os.path.abspath(src))
            try:
                with open(src, encoding="utf-8") as fh:
                    lines = fh.read().splitlines()
            except (OSError, UnicodeDecodeError) as e:
                raise InputError(
                    f"{src}: not a mesh file ({', '.join(MESH_EXTENSIONS)}) nor a readable text "
                    f"list of paths: {e}"
                ) from e
            entries = [e.strip() for e in lines if e.strip() and not e.strip().startswith("#")]
            fulls = [os.path.abspath(os.path.join(base, os.path.expanduser(e))) for e in entries]
            if not any(os.path.exists(f) for f in fulls):
                raise InputError(
                    f"{src}: not a mesh file ({', '.join(MESH_EXTENSIONS)}), and read as a list "
                    f"of paths none of its {len(entries)} entries names an existing file"
                )
            for full in fulls:
                if not os.path.exists(full):
                    missing.add(full)
                elif not _is_mesh(full):
                    not_mesh.add(full)
                else:
                    paths.add(full)
    if not paths and not not_mesh and not missing:
        also = f" (only {len(scenes)} scenes synth plan wrote)" if scenes else ""
        raise InputError(
            f"no mesh files ({', '.join(MESH_EXTENSIONS)}) found in "
            f"{', '.join(map(str, sources))}{also}"
        )
    return MeshInputs(
        tuple(sorted(paths)), tuple(sorted(ignored)), tuple(sorted(not_mesh)),
        tuple(sorted(missing)), tuple(revisited), tuple(sorted(scenes)),
    )  # fmt: skip


def _is_scene(path: str) -> bool:
    """Whether a file is a GLB scene ``synth plan`` wrote (its header and JSON chunk)."""
    from synth.plan.result import scene_run_id

    if not path.lower().endswith(".glb"):
        return False
    try:
        with open(path, "rb") as fh:
            head = fh.read(20)
            size = int.from_bytes(head[12:16], "little") if len(head) == 20 else 0
            return scene_run_id(head + fh.read(min(size, 1 << 24))) is not None
    except OSError:
        return False  # planned, and recorded as unreadable


def _hash_file(path: str) -> tuple[str, int]:
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return h.hexdigest(), size


def _prepare(
    db: GraspDatabase, inputs: MeshInputs, params_text: str, planner: str, retry_failed: bool
) -> tuple[list[_Task], dict[int, tuple[str, int]], int, int, list[tuple[str, str]]]:
    """Decide what to plan and record what needs no planning, in one transaction.

    Returns the tasks, the (sha256, size) of each task's mesh id, the skipped and duplicate
    counts, and the failures recorded before planning.
    """
    hashes: dict[str, tuple[str, int] | str] = {}
    for p in inputs.paths:
        try:
            hashes[p] = _hash_file(p)
        except OSError as e:
            hashes[p] = f"cannot read file: {e.strerror or e}"
    for p in inputs.missing:
        hashes[p] = "no such file (listed in a list file)"
    for p in inputs.not_mesh:
        hashes[p] = f"not a mesh file (extension not one of {', '.join(MESH_EXTENSIONS)})"
    existing = db.rows_by_path(hashes)
    # rows whose file changed (or is unreadable now) are re-planned: not an original for others
    stale = {
        int(row["id"])
        for path, row in existing.items()
        if isinstance(hashes[path], str) or hashes[path][0] != row["sha256"]  # type: ignore[index]
    }
    now = db.now()
    tasks: list[str] = []
    planned_sha: dict[str, int] = {}  # sha256 -> id of the mesh planned for it in this run
    skipped = duplicates = 0
    failures: list[tuple[str, str]] = []
    with db.transaction() as cur:
        for path in sorted(hashes):
            h, row = hashes[path], existing.get(path)
            if isinstance(h, str):  # unreadable, missing or not a mesh: record once
                kind = "not_mesh" if path in inputs.not_mesh else "unreadable"
                if row is not None and row["status"] == "failed" and row["error"] == h:
                    skipped += 1
                    continue
                failures.append((path, h))
                cur.execute("DELETE FROM grasps WHERE mesh_id = (SELECT id FROM meshes WHERE "
                            "path = ?)", (path,))  # fmt: skip
                cur.execute(
                    "INSERT INTO meshes(path, name, status, error_kind, error, params, planner, "
                    "finished_at) VALUES (?, ?, 'failed', ?, ?, ?, ?, ?) ON CONFLICT(path) DO "
                    "UPDATE SET status='failed', error_kind=excluded.error_kind, "
                    "error=excluded.error, sha256=NULL, size=NULL, n_grasps=0, duplicate_of=NULL, "
                    "mesh_report=NULL, finished_at=excluded.finished_at",
                    (path, os.path.basename(path), kind, h, params_text, planner, now),
                )
                continue
            sha, size = h
            if row is not None and row["sha256"] == sha:
                status = row["status"]
                original_ok = status != "duplicate" or (
                    row["duplicate_of"] not in stale
                    and cur.execute(
                        "SELECT sha256 FROM meshes WHERE id = ?", (row["duplicate_of"],)
                    ).fetchone()[0]
                    == sha
                )
                if (status in ("done", "duplicate") and original_ok) or (
                    status == "failed" and not retry_failed
                ):
                    skipped += 1
                    continue
            own = row["id"] if row is not None else -1
            primary = planned_sha.get(sha)
            if primary is None:
                found = cur.execute(
                    "SELECT id FROM meshes WHERE sha256 = ? AND status IN ('done', 'failed') "
                    "AND id != ? ORDER BY id",
                    (sha, own),
                ).fetchall()
                found = [int(r[0]) for r in found if int(r[0]) not in stale]
                primary = found[0] if found else None
            if primary is not None:
                first = cur.execute("SELECT path FROM meshes WHERE id = ?", (primary,)).fetchone()
                duplicates += 1
                cur.execute("DELETE FROM grasps WHERE mesh_id = ?", (own,))
                cur.execute(
                    "INSERT INTO meshes(path, name, sha256, size, status, error, duplicate_of, "
                    "params, planner, finished_at) VALUES (?, ?, ?, ?, 'duplicate', ?, ?, ?, ?, ?) "
                    "ON CONFLICT(path) DO UPDATE SET sha256=excluded.sha256, size=excluded.size, "
                    "status='duplicate', error_kind=NULL, error=excluded.error, n_grasps=0, "
                    "duplicate_of=excluded.duplicate_of, mesh_report=NULL, "
                    "finished_at=excluded.finished_at",
                    (path, os.path.basename(path), sha, size, f"same content as {first[0]}",
                     primary, params_text, planner, now),
                )  # fmt: skip
                continue
            if row is None:
                cur.execute(
                    "INSERT INTO meshes(path, name, sha256, size, status, params, planner) "
                    "VALUES (?, ?, ?, ?, 'pending', ?, ?)",
                    (path, os.path.basename(path), sha, size, params_text, planner),
                )
                mesh_id = int(cur.lastrowid or 0)
            else:
                mesh_id = int(row["id"])  # stays as it is until its new result is stored
            planned_sha[sha] = mesh_id
            tasks.append(path)
    ids = {p: int(r["id"]) for p, r in db.rows_by_path(tasks).items()}
    task_list = [(ids[p], p) for p in tasks]
    sizes = {ids[p]: hashes[p] for p in tasks}
    return task_list, sizes, skipped, duplicates, failures  # type: ignore[return-value]


def _run_inline(
    tasks: list[_Task], params: dict[str, Any], planner: str, timeout: float | None
) -> Iterator[tuple[int, PlanOutcome]]:
    for mesh_id, path in tasks:
        yield mesh_id, run_one(path, params, planner, timeout)


def _run_dask(
    tasks: list[_Task],
    params: dict[str, Any],
    planner: str,
    workers: int,
    scheduler: str | None,
    on_workers: Callable[[int], None],
) -> Iterator[tuple[int, PlanOutcome]]:
    """One task per mesh on a Dask distributed cluster (or a new local one)."""
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError as e:
        raise InputError(
            "the Dask engine needs dask.distributed, which is not installed: "
            'pip install "synth[dask]"'
        ) from e
    cluster = None
    try:
        if scheduler:
            client = Client(scheduler, timeout=30)
        else:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)
            client = Client(cluster)
    except ValueError as e:  # dask's words for an address it cannot parse
        raise InputError(f"--scheduler {scheduler!r}: not a Dask scheduler address ({e}); "
                         "expected one such as tcp://host:8786") from e
    except (OSError, TimeoutError) as e:  # a scheduler that does not answer: the system's
        # refusal (exit status 1), not the address's fault
        raise DatabaseError(f"cannot connect to the Dask scheduler {scheduler!r}: {e}; is it "
                            "running, and reachable from here?") from e
    try:
        nthreads = max(1, sum(client.nthreads().values()))
        on_workers(nthreads)
        queue = list(reversed(tasks))
        pending: dict[Hashable, _Task] = {}  # by Dask's key of the task's future
        ac = as_completed()

        def submit() -> None:
            task = queue.pop()
            fut = client.submit(run_one, task[1], params, planner, None, pure=False)
            pending[fut.key] = task
            ac.add(fut)

        while queue and len(pending) < 2 * nthreads:
            submit()
        for fut in ac:
            task = pending.pop(fut.key)
            try:
                outcome = fut.result()
            except Exception as e:  # noqa: BLE001 - KilledWorker and the like
                outcome = crashed(task[1], f"Dask task failed: {type(e).__name__}: {e}")
            fut.release()
            yield task[0], outcome
            if queue:
                submit()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


class BuildTerminated(KeyboardInterrupt):
    """A build stopped by SIGTERM: its workers are stopped, the meshes finished are stored."""


@contextmanager
def _sigterm_stops_build() -> Iterator[None]:
    """In the main thread, make SIGTERM raise :class:`BuildTerminated` (once) in the block.

    The exception unwinds the build like Ctrl-C: the transaction in progress is rolled back,
    the workers are terminated and the database is closed whole. A second SIGTERM acts as
    it did before the build (by default, ending the process at once).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def _raise(signum: int, frame: object) -> None:
        signal.signal(signal.SIGTERM, previous)
        raise BuildTerminated

    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _refuse_empty(out: str | os.PathLike[str]) -> None:
    """Refuse an ``out`` that is an empty file: SQLite would take it for an empty database and
    a build would make it one, but synth did not begin it (a build writes its schema as soon
    as it holds the file; before a checkpoint, in the ``-wal`` file alone). Checked before the
    database is opened, not under its lock: two builds opening a new file at once must find
    one of them busy, not both refused."""
    path = os.fspath(out)
    if os.path.isfile(path) and os.path.getsize(path) == 0 and not (
            os.path.isfile(path + "-wal") and os.path.getsize(path + "-wal") > 0):
        raise DatabaseFileError(f"{path}: an empty file, not a grasp database synth began "
                                "(unless another build is creating it at this moment); write "
                                "the database to a new file")


def build_database(
    sources: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    params: dict[str, Any] | None = None,
    *,
    workers: int | None = None,
    engine: str = "local",
    scheduler: str | None = None,
    planner: str | None = None,
    retry_failed: bool = False,
    timeout: float | None = None,
    quiet: bool = False,
    stream: TextIO | None = None,
) -> BuildReport:
    """Plan grasps for every mesh of ``sources`` and store them in the database ``out``.

    Parameters
    ----------
    sources : sequence of path
        Folders (searched recursively), mesh files, or text files listing mesh paths.
    out : path
        The database file, created if missing, resumed if it exists.
    params : dict, optional
        Planner parameters (see :data:`DEFAULT_PARAMS`); must equal those of an existing file.
        With ``sim`` (:class:`synth.sim.SimSettings` fields), each mesh's grasps are
        simulated on the worker after planning and their labels stored (column ``sim``).
    workers : int, optional
        Worker processes (default: the CPUs available); ``0`` plans in this process (local).
    engine : {"local", "dask"}
        Where tasks run.
    scheduler : str, optional
        Dask scheduler address (``tcp://host:8786``); without it a local Dask cluster is made.
    planner : str, optional
        ``"module:function"``; default ``$SYNTH_DB_PLANNER`` or ``synth.plan:plan_mesh_file``.
    retry_failed : bool
        Plan again the meshes recorded as failed.
    timeout : float, optional
        Seconds per mesh before it is recorded as timed out (local engine only).
    quiet : bool
        No progress bar.
    stream : file, optional
        Where the progress bar goes (default ``sys.stderr``; drawn only on a TTY).

    Returns
    -------
    BuildReport
        Counts of this run.

    Raises
    ------
    InputError
        On bad sources, parameters, engine or planner, or ``sim`` without mujoco and coacd
        installed (nothing is written then).
    DatabaseError
        If ``out`` is not a synth database of this version or an older one (a schema-1 file is
        migrated to this version before the first write), was built with other parameters, or
        is busy (another build is writing it).
    BuildTerminated
        If the process receives SIGTERM during the build (when run in the main thread): the
        workers are terminated, the meshes finished are stored, and running the same build
        again finishes the rest. Worker processes never outlive the build's process, even
        when it is killed (see :mod:`synth.database.local`).

    Examples
    --------
    >>> report = build_database(["meshes/"], "grasps.sqlite", {"seed": 1})  # doctest: +SKIP
    >>> print(report.summary())  # doctest: +SKIP
    """
    with _sigterm_stops_build():
        start = time.perf_counter()
        if engine not in ("local", "dask"):
            raise InputError(f"engine must be 'local' or 'dask', got {engine!r}")
        if workers is not None and (isinstance(workers, bool)
                                    or not isinstance(workers, numbers.Integral)):
            raise InputError(f"--workers (Python: workers=): expected an integer, got "
                             f"{workers!r}")
        n_workers = len(os.sched_getaffinity(0)) if workers is None else int(workers)
        if n_workers < 0 or (engine == "dask" and n_workers == 0):
            least = "1 with the dask engine (0, in this process: the local engine only)" \
                if engine == "dask" else "0 (0: in this process)"
            raise InputError(f"--workers (Python: workers=): expected at least {least}, got "
                             f"{workers}")
        if timeout is not None and (isinstance(timeout, bool) or not isinstance(
                timeout, numbers.Real) or not (timeout > 0 and math.isfinite(timeout))):
            raise InputError(f"timeout: expected a finite number of seconds > 0, or None, got "
                             f"{timeout!r}")
        run_params = normalize_params(params)
        planner_name = resolve_planner(planner)
        load_planner(planner_name)  # fail now, not once per mesh
        if "sim" in run_params:
            from synth.sim import require_sim

            require_sim()
        inputs = collect_mesh_files(sources)
        _refuse_empty(out)
        params_text = canonical_json(run_params)
        seen_workers = [n_workers]
        with GraspDatabase(out, mode="w") as db:
            db.bind(run_params, planner_name, resume_defaults(run_params))
            tasks, hashes, skipped, duplicates, failures = _prepare(
                db, inputs, params_text, planner_name, retry_failed
            )
            n_failed_before = len(failures)
            done = failed = grasps = 0
            bar = ProgressBar(len(tasks), stream=stream, quiet=quiet)
            if engine == "dask":
                results = _run_dask(
                    tasks, run_params, planner_name, n_workers, scheduler,
                    lambda n: seen_workers.__setitem__(0, n),
                )  # fmt: skip
            elif n_workers == 0:
                results = _run_inline(tasks, run_params, planner_name, timeout)
            else:
                results = run_local(tasks, run_params, planner_name, timeout, n_workers)
            try:
                bar.update(0, 0, 0, force=True)
                for mesh_id, outcome in results:
                    sha, size = hashes[mesh_id]
                    db.store_outcome(mesh_id, sha, size, outcome)
                    if outcome.ok:
                        done += 1
                        grasps += len(outcome.rows)
                    else:
                        failed += 1
                        failures.append((outcome.path, outcome.error or outcome.error_kind or ""))
                    bar.update(done + failed, failed, grasps, force=done + failed == len(tasks))
            finally:
                close = getattr(results, "close", None)
                if close is not None:
                    close()
                bar.close()
        return BuildReport(
            database=os.fspath(out),
            found=len(inputs.paths) + len(inputs.missing) + len(inputs.not_mesh),
            planned=len(tasks),
            done=done,
            failed=failed + n_failed_before,
            duplicates=duplicates,
            skipped=skipped,
            grasps=grasps,
            ignored=inputs.ignored,
            failures=tuple(failures),
            elapsed_s=time.perf_counter() - start,
            engine=engine,
            workers=seen_workers[0],
            revisited=inputs.revisited,
            scenes=inputs.scenes,
        )
