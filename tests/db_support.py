"""Helpers shared by the database tests: a folder of small meshes and database snapshots."""

from __future__ import annotations

import os
import shutil
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from synth.database import GraspDatabase

__all__ = [
    "TESTS_DIR", "REPO_DIR", "PLANNER", "PARAMS", "V1_DDL", "make_mesh_dir", "planner_env",
    "snapshot", "write_v1_copy", "descendants", "alive", "folder_state",
]  # fmt: skip

TESTS_DIR = str(Path(__file__).resolve().parent)
REPO_DIR = str(Path(TESTS_DIR).parent)
PLANNER = "tests.db_fakeplanner:plan_mesh_file"
PARAMS: dict[str, Any] = {"evals": 300, "top": 5, "seed": 3}

GOOD = ("box.stl", "ico.stl", "sub/box2.stl", "sub/deeper/cyl.obj")
BROKEN = ("empty.stl", "random.stl")
DUPLICATE = "sub/dup.stl"  # same bytes as box.stl


def make_mesh_dir(root: Path) -> Path:
    """Four good meshes (two in sub-folders), a duplicate, two broken .stl and a .txt."""
    d = root / "meshes"
    (d / "sub" / "deeper").mkdir(parents=True)
    trimesh.creation.box().export(d / "box.stl")
    trimesh.creation.icosphere(subdivisions=1).export(d / "ico.stl")
    trimesh.creation.box(extents=(1.0, 2.0, 3.0)).export(d / "sub" / "box2.stl")
    trimesh.creation.cylinder(radius=0.5, height=1.0, sections=12).export(
        d / "sub" / "deeper" / "cyl.obj"
    )
    shutil.copyfile(d / "box.stl", d / DUPLICATE)
    (d / "empty.stl").write_bytes(b"")
    (d / "random.stl").write_bytes(np.random.default_rng(0).bytes(777))
    (d / "notes.txt").write_text("not a mesh\n")
    return d


def planner_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    """Environment for a subprocess that plans with the test planner."""
    env = dict(os.environ)
    env["SYNTH_DB_PLANNER"] = PLANNER
    env["PYTHONPATH"] = os.pathsep.join([REPO_DIR] + ([env["PYTHONPATH"]] if
                                                        env.get("PYTHONPATH") else []))  # fmt: skip
    env.update(extra or {})
    return env


def snapshot(
    path: str | os.PathLike[str], report: bool = True
) -> tuple[list[tuple[Any, ...]], list[tuple[Any, ...]]]:
    """Everything stored except timings: mesh rows and grasps (as the planner's dicts).

    ``report=False`` leaves out what a schema-1 copy cannot hold (to compare with one): the
    loading reports and the late hold measures (``squeeze_per_weight``, ``least_squeeze``,
    ``margin``).
    """
    late = () if report else ("squeeze_per_weight", "least_squeeze", "margin")
    with GraspDatabase(path) as db:
        meshes = [
            (m.id, m.path, m.name, m.sha256, m.size, m.status, m.error_kind, m.error,
             m.duplicate_of, m.units, m.length, m.n_grasps, m.params, m.planner)
            + ((m.report,) if report else ())
            for m in db.meshes()
        ]  # fmt: skip
        grasps = [(g.mesh_id, g.rank, {k: v for k, v in g.to_dict().items() if k not in late})
                  for g in db.grasps()]
    return meshes, grasps


# The DDL of schema version 1 (synth before ``meshes.mesh_report``), kept to make old files.
V1_DDL = """
CREATE TABLE meta (
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE meshes (
    id             INTEGER PRIMARY KEY,
    path           TEXT NOT NULL UNIQUE,
    name           TEXT NOT NULL,
    sha256         TEXT,
    size           INTEGER,
    status         TEXT NOT NULL CHECK (status IN ('pending', 'done', 'failed', 'duplicate')),
    error_kind     TEXT,
    error          TEXT,
    duplicate_of   INTEGER REFERENCES meshes(id),
    units          TEXT,
    length         REAL,
    params         TEXT NOT NULL,
    planner_params TEXT,
    planner        TEXT NOT NULL,
    synth_version  TEXT,
    n_grasps       INTEGER NOT NULL DEFAULT 0,
    plan_s         REAL,
    worker_s       REAL,
    finished_at    TEXT
);
CREATE INDEX meshes_sha256 ON meshes(sha256);
CREATE INDEX meshes_name ON meshes(name);
CREATE INDEX meshes_status ON meshes(status);
CREATE TABLE grasps (
    mesh_id      INTEGER NOT NULL REFERENCES meshes(id),
    rank         INTEGER NOT NULL,
    d_star       REAL NOT NULL,
    closure      TEXT NOT NULL,
    conditioning REAL NOT NULL,
    epsilon      REAL NOT NULL,
    n_contacts   INTEGER NOT NULL,
    points       BLOB NOT NULL,
    normals      BLOB NOT NULL,
    features     TEXT NOT NULL,
    regions      BLOB NOT NULL,
    n_fingers    INTEGER NOT NULL,
    tip_centers  BLOB NOT NULL,
    tip_radius   REAL NOT NULL,
    approach     BLOB NOT NULL,
    body_length  REAL NOT NULL,
    body_radius  REAL NOT NULL,
    PRIMARY KEY (mesh_id, rank)
) WITHOUT ROWID;
CREATE INDEX grasps_d_star ON grasps(d_star);
"""
_V1_MESH_COLUMNS = (
    "id, path, name, sha256, size, status, error_kind, error, duplicate_of, units, length, "
    "params, planner_params, planner, synth_version, n_grasps, plan_s, worker_s, finished_at"
)


_V1_GRASP_COLUMNS = (
    "mesh_id, rank, d_star, closure, conditioning, epsilon, n_contacts, points, normals, "
    "features, regions, n_fingers, tip_centers, tip_radius, approach, body_length, body_radius"
)


def write_v1_copy(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
    """Write at ``dst`` the content of the database ``src`` as a schema-1 file (as old synth did).

    Every row of ``meta``, ``meshes`` (without ``mesh_report``) and ``grasps`` is copied;
    ``meta.schema_version`` and ``PRAGMA user_version`` are 1.
    """
    conn = sqlite3.connect(dst, isolation_level=None)
    try:
        conn.execute("PRAGMA journal_mode = WAL")
        conn.execute("PRAGMA application_id = 1398361684")  # 0x53594E54, "SYNT"
        conn.execute("PRAGMA user_version = 1")
        conn.executescript("BEGIN;" + V1_DDL)
        conn.execute("ATTACH DATABASE ? AS src", (os.fspath(src),))
        conn.execute("INSERT INTO meta SELECT key, value FROM src.meta")
        conn.execute("UPDATE meta SET value = '1' WHERE key = 'schema_version'")
        conn.execute(
            f"INSERT INTO meshes({_V1_MESH_COLUMNS}) SELECT {_V1_MESH_COLUMNS} FROM src.meshes"
        )
        conn.execute(f"INSERT INTO grasps({_V1_GRASP_COLUMNS}) SELECT {_V1_GRASP_COLUMNS} "
                     "FROM src.grasps")
        conn.execute("COMMIT")
        conn.execute("DETACH DATABASE src")
    finally:
        conn.close()


def _proc_stat(pid: int) -> tuple[str, int] | None:
    """(state, parent pid) of a process from ``/proc``, None if there is no such process."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as fh:
            text = fh.read()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()  # the name, in parentheses, may hold spaces
    return fields[0], int(fields[1])


def descendants(pid: int) -> set[int]:
    """Pids of every live process below ``pid`` (children, their children, ...), from ``/proc``."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            stat = _proc_stat(int(entry))
            if stat is not None:
                children.setdefault(stat[1], []).append(int(entry))
    found: set[int] = set()
    todo = [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def alive(pid: int) -> bool:
    """Whether ``pid`` is a running process (a zombie, dead but not reaped, is not)."""
    stat = _proc_stat(pid)
    return stat is not None and stat[0] not in ("Z", "X")


def folder_state(folder: str | os.PathLike[str]) -> dict[str, tuple[int, int, int]]:
    """``name -> (size, mtime_ns, mode)`` of every entry of ``folder``, and ``"."`` for itself."""
    out = {}
    for name in [".", *sorted(os.listdir(folder))]:
        st = os.stat(os.path.join(folder, name))
        out[name] = (st.st_size, st.st_mtime_ns, st.st_mode)
    return out
