"""Open, read and write a grasp database: :class:`GraspDatabase`.

Reading is the public side (``synth.GraspDatabase(path)``); the writing methods are used by
:mod:`synth.database.build`, the only writer, which keeps every mesh's grasps and its status in one
transaction.
"""

from __future__ import annotations

import datetime as _dt
import numbers
import os
import sqlite3
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from types import TracebackType
from typing import Any

from synth.database.access import open_reader, open_writer, release, rest
from synth.database.schema import (
    GraspRecord,
    GripperGraspRecord,
    MeshRecord,
    canonical_json,
    check_schema,
    create_schema,
    migrate_schema,
    schema_current,
    schema_version,
)
from synth.database.worker import PlanOutcome
from synth.errors import DatabaseError, DatabaseFileError, InputError

__all__ = ["GraspDatabase", "DatabaseInfo", "TOP_ORDERS", "GRIPPER_TOP_ORDERS"]

#: Orders of :meth:`GraspDatabase.top` for point-finger grasps: the planner's ranks as stored,
#: or the words of ``--rank-by`` (:func:`synth.plan.ranking.rank_grasps`).
TOP_ORDERS = ("rank", "d_star", "conditioning", "epsilon", "tolerance", "margin")
#: Orders of :meth:`GraspDatabase.top` for gripper grasps: the ranks as stored, or the words of
#: ``synth plan --gripper --rank-by`` (:func:`synth.plan.gripper.rank_order`).
GRIPPER_TOP_ORDERS = ("rank", "margin", "d_star", "mu_min", "epsilon")

_BUSY_TIMEOUT_MS = 30_000


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


@dataclass(frozen=True)
class DatabaseInfo:
    """Summary of a grasp database.

    Attributes
    ----------
    path : str
        The database file.
    schema_version : int
        Schema version of the file (1 for a file no build of this synth has written to yet).
    synth_version : str
        Version of synth that created it.
    params : dict
        Planner parameters of every mesh.
    planner : str
        ``"module:function"`` of the planner.
    meshes, done, failed, duplicates, pending, grasps : int
        Row counts (``meshes`` counts every status; ``grasps`` both kinds of grasps).
    failures : tuple of (str, str, str)
        ``(path, error_kind, error)`` of every failed mesh, by path.
    plan_s : float
        Sum of the planner times of the done meshes, seconds.
    with_report : int
        Meshes with a loading report (``meshes.mesh_report`` not NULL).
    repaired, with_dropped, with_warnings : int
        Of those, the meshes whose report lists repairs, dropped objects or warnings (a
        non-empty ``repairs``, ``dropped`` or ``warnings`` list).
    gripper_grasps : int
        Of ``grasps``, the gripper grasps (table ``gripper_grasps``).
    kind : str
        ``"gripper"`` for a database of gripper grasps (``synth db build --gripper``),
        ``"fingers"`` for point-finger grasps.
    """

    path: str
    schema_version: int
    synth_version: str
    params: dict[str, Any]
    planner: str
    meshes: int
    done: int
    failed: int
    duplicates: int
    pending: int
    grasps: int
    failures: tuple[tuple[str, str, str], ...]
    plan_s: float
    with_report: int = 0
    repaired: int = 0
    with_dropped: int = 0
    with_warnings: int = 0
    gripper_grasps: int = 0
    kind: str = "fingers"

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (``failures`` as a list of objects)."""
        d = asdict(self)
        d["failures"] = [{"path": p, "kind": k, "error": e} for p, k, e in self.failures]
        return d


def _gripper_top(grasps: list[GripperGraspRecord], k: int, rank_by: str
                 ) -> list[GripperGraspRecord]:
    """The first ``k`` gripper grasps in ``rank_by`` order (stored ranks break ties)."""
    if rank_by != "rank" and grasps:
        import numpy as np

        from synth.plan.gripper import rank_order

        def column(name: str) -> np.ndarray:
            return np.array([np.inf if getattr(g, name) is None else getattr(g, name)
                             for g in grasps], float)

        order = rank_order(rank_by, column("squeeze_per_weight"), column("d_star"),
                           column("mu_min"), column("epsilon"))
        grasps = [grasps[i] for i in order]
    return grasps[: int(k)]


def _probe(conn: sqlite3.Connection, path: str) -> None:
    """Read the schema of a read-only connection; a failure to read says so, naming the file."""
    try:
        conn.execute("SELECT count(*) FROM sqlite_master").fetchone()
    except sqlite3.OperationalError as e:  # the file is SQLite (its header was checked)
        folder = os.path.dirname(os.path.abspath(path))
        why = "" if os.access(folder, os.W_OK) else f"; its folder {folder} cannot be written"
        raise DatabaseError(f"{path}: cannot read grasp database ({e}{why})") from e


def _differences(old: dict[str, Any], new: dict[str, Any]) -> dict[str, tuple[Any, Any]]:
    """The parameters that differ, by name; of two settings objects (``sim``), the settings
    that differ, as ``sim.shake``; an absent object as None."""
    diff: dict[str, tuple[Any, Any]] = {}
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k), new.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            diff.update({f"{k}.{sub}": v for sub, v in _differences(a, b).items()})
        elif a != b:
            diff[k] = (a, b)
    return diff


class GraspDatabase:
    """A synth grasp database (SQLite), opened for reading unless ``mode="w"``.

    Parameters
    ----------
    path : str or os.PathLike
        The database file.
    mode : {"r", "w"}
        ``"r"`` opens an existing database read-only (safe while a build writes it); ``"w"``
        opens or creates it for writing (used by ``synth db build``).
    meta : dict, optional
        For ``mode="w"`` on a new file: the ``params`` and ``planner`` meta values to store.

    Raises
    ------
    DatabaseError
        Naming the file, if it is missing (``"r"``), not SQLite, not a synth database, or of
        a newer schema version. A file that is not a synth database is never modified. A file
        of schema version 1 is read as it is, and migrated to version 2 the first time it is
        written to (:meth:`bind`, :meth:`transaction`, :meth:`store_outcome`), not on opening.

    Examples
    --------
    >>> with GraspDatabase("grasps.sqlite") as db:  # doctest: +SKIP
    ...     best = db.top("box.stl", k=3)
    ...     print(db.info().done, [g.d_star for g in best])
    """

    def __init__(
        self, path: str | os.PathLike[str], mode: str = "r", meta: dict[str, str] | None = None
    ) -> None:
        if mode not in ("r", "w"):
            raise InputError(f"mode must be 'r' or 'w', got {mode!r}")
        if not isinstance(path, (str, os.PathLike)):
            raise InputError(f"path: expected a database file's path, got {path!r}")
        self.path = os.fspath(path)
        self.mode = mode
        self._lock: int | None = None  # see synth.database.access
        self._closed = False
        self._conn = self._connect(meta)
        try:
            self.meta: dict[str, str] = check_schema(self._conn, self.path)
        except BaseException:
            self._close_connection(self._conn)
            raise
        #: Schema version of the file (older than ``SCHEMA_VERSION`` until migrated).
        self.schema_version: int = schema_version(self.meta)
        self._current = False  # known to be the full current schema (see _require_write)

    # -- opening --------------------------------------------------------------------------
    def _connect(self, meta: dict[str, str] | None) -> sqlite3.Connection:
        path = self.path
        if os.path.isdir(path):
            raise DatabaseFileError(f"{path}: is a directory, not a grasp database")
        if self.mode == "r":
            if not os.path.exists(path):
                raise DatabaseFileError(f"{path}: no such grasp database")
            conn, self._lock = open_reader(path)
        else:
            parent = os.path.dirname(os.path.abspath(path))
            if not os.path.isdir(parent):
                raise DatabaseError(f"{path}: folder {parent} does not exist")
            conn, self._lock = open_writer(path)
        conn.row_factory = sqlite3.Row
        try:
            conn.execute(f"PRAGMA busy_timeout = {_BUSY_TIMEOUT_MS}")
            if self.mode == "w":
                tables = conn.execute("SELECT count(*) FROM sqlite_master").fetchone()[0]
                if tables == 0:
                    conn.execute("PRAGMA journal_mode = WAL")
                    from synth import __version__

                    create_schema(
                        conn, {"synth_version": __version__, "created_at": _now(), **(meta or {})}
                    )
                else:
                    check_schema(conn, path)  # before anything that would write to it
                    conn.execute("PRAGMA journal_mode = WAL")
                conn.execute("PRAGMA synchronous = FULL")
                conn.execute("PRAGMA foreign_keys = ON")
            else:
                _probe(conn, path)
        except sqlite3.OperationalError as e:  # e.g. a reader kept a transaction open too long
            self._close_connection(conn)
            raise DatabaseError(f"{path}: cannot open grasp database for writing ({e})") from e
        except sqlite3.DatabaseError as e:
            self._close_connection(conn)
            raise DatabaseFileError(f"{path}: not a synth grasp database ({e})") from e
        except BaseException:
            self._close_connection(conn)
            raise
        return conn

    def _close_connection(self, conn: sqlite3.Connection) -> None:
        conn.close()
        release(self._lock)
        self._lock = None
        self._closed = True

    def close(self) -> None:
        """Close the connection (idempotent); a writer first leaves the file at rest.

        At rest the file is in rollback-journal mode, without ``-wal`` and ``-shm`` files
        (:func:`synth.database.access.rest`), so that reading it never creates files.
        """
        if self._closed:
            return
        if self.mode == "w":
            rest(self._conn)
        self._close_connection(self._conn)

    def __enter__(self) -> GraspDatabase:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- reading --------------------------------------------------------------------------
    @property
    def params(self) -> dict[str, Any]:
        """Planner parameters of this database (empty before the first build)."""
        import json

        return dict(json.loads(self.meta.get("params", "{}")))

    @property
    def planner(self) -> str:
        """``"module:function"`` of the planner of this database."""
        return self.meta.get("planner", "")

    def _query(self, sql: str, args: Iterable[Any] = ()) -> list[sqlite3.Row]:
        try:
            return self._conn.execute(sql, tuple(args)).fetchall()
        except sqlite3.Error as e:
            raise DatabaseError(f"{self.path}: query failed: {e}") from e

    def _rows(self, sql: str, args: Iterable[Any] = ()) -> Iterator[sqlite3.Row]:
        """The rows of a query one at a time; a damaged file found while reading them (SQLite
        reads its pages as it goes) is :class:`DatabaseError`, as in :meth:`_query`."""
        try:
            yield from self._conn.execute(sql, tuple(args))
        except sqlite3.Error as e:
            raise DatabaseError(f"{self.path}: query failed: {e}") from e

    def info(self) -> DatabaseInfo:
        """Counts, failures and parameters of the database."""
        counts: dict[str, int] = {
            status: n for status, n in self._query(
                "SELECT status, count(*) FROM meshes GROUP BY status")}
        n_grasps = self._query("SELECT count(*) FROM grasps")[0][0]
        n_gripper = 0
        if self.schema_version >= 4:
            n_gripper = self._query("SELECT count(*) FROM gripper_grasps")[0][0]
        plan_s = self._query("SELECT total(plan_s) FROM meshes WHERE status = 'done'")[0][0]
        failures = self._query(
            "SELECT path, error_kind, error FROM meshes WHERE status = 'failed' ORDER BY path"
        )
        loading = self._loading_counts()
        return DatabaseInfo(
            path=self.path,
            schema_version=self.schema_version,
            synth_version=self.meta.get("synth_version", ""),
            params=self.params,
            planner=self.planner,
            meshes=sum(counts.values()),
            done=counts.get("done", 0),
            failed=counts.get("failed", 0),
            duplicates=counts.get("duplicate", 0),
            pending=counts.get("pending", 0),
            grasps=int(n_grasps + n_gripper),
            failures=tuple((r[0], r[1] or "", r[2] or "") for r in failures),
            plan_s=float(plan_s),
            **loading,
            gripper_grasps=int(n_gripper),
            kind=self.kind,
        )

    @property
    def kind(self) -> str:
        """``"gripper"`` when this database holds gripper grasps (built with ``--gripper``,
        or with a planner returning ``synth.gripper_grasps`` documents), else
        ``"fingers"``."""
        if "gripper" in self.params:
            return "gripper"
        if self.schema_version < 4:
            return "fingers"
        return "gripper" if self._query("SELECT 1 FROM gripper_grasps LIMIT 1") else "fingers"

    def _loading_counts(self) -> dict[str, int]:
        """Meshes with a loading report, and those with repairs, dropped objects or warnings."""
        keys = ("with_report", "repaired", "with_dropped", "with_warnings")
        if self.schema_version < 2:  # no mesh_report column yet
            return dict.fromkeys(keys, 0)
        lists = ("repairs", "dropped", "warnings")
        sql = "SELECT count(*), " + ", ".join(
            f"coalesce(sum(coalesce(json_array_length(mesh_report, '$.{k}'), 0) > 0), 0)"
            for k in lists
        ) + " FROM meshes WHERE mesh_report IS NOT NULL"  # fmt: skip
        try:
            row = tuple(self._conn.execute(sql).fetchone())
        except sqlite3.OperationalError:  # an SQLite without the JSON functions
            import json

            counts = [0, 0, 0, 0]
            for (text,) in self._query(
                "SELECT mesh_report FROM meshes WHERE mesh_report IS NOT NULL"
            ):
                report = json.loads(text)
                counts[0] += 1
                for i, k in enumerate(lists, 1):
                    value = report.get(k) if isinstance(report, dict) else None
                    counts[i] += isinstance(value, list) and len(value) > 0
            row = tuple(counts)
        return {k: int(v) for k, v in zip(keys, row, strict=True)}

    def meshes(self, status: str | None = None) -> Iterator[MeshRecord]:
        """Iterate over mesh records in id order, optionally only those of one ``status``."""
        if status is None:
            rows = self._rows("SELECT * FROM meshes ORDER BY id")
        else:
            rows = self._rows("SELECT * FROM meshes WHERE status = ? ORDER BY id", (status,))
        for row in rows:
            yield MeshRecord.from_row(row)

    def __iter__(self) -> Iterator[MeshRecord]:
        return self.meshes()

    def __len__(self) -> int:
        return int(self._query("SELECT count(*) FROM meshes")[0][0])

    def grasps(self, mesh: str | int | None = None) -> Iterator[GraspRecord]:
        """Iterate over grasps by (mesh id, rank): all of them, or those of one mesh.

        Parameters
        ----------
        mesh : str or int, optional
            A mesh id, name, path or SHA-256 (see :meth:`mesh`); duplicates give the grasps
            of the mesh they duplicate.
        """
        if mesh is None:
            rows = self._rows("SELECT * FROM grasps ORDER BY mesh_id, rank")
        else:
            rows = self._rows("SELECT * FROM grasps WHERE mesh_id = ? ORDER BY rank",
                              (self._grasp_owner(mesh),))
        for row in rows:
            yield GraspRecord.from_row(row)

    def gripper_grasps(self, mesh: str | int | None = None) -> Iterator[GripperGraspRecord]:
        """Iterate over gripper grasps by (mesh id, rank): all, or those of one mesh (none in
        a file older than schema version 4)."""
        if self.schema_version < 4:
            return
        if mesh is None:
            rows = self._rows("SELECT * FROM gripper_grasps ORDER BY mesh_id, rank")
        else:
            rows = self._rows("SELECT * FROM gripper_grasps WHERE mesh_id = ? ORDER BY rank",
                              (self._grasp_owner(mesh),))
        for row in rows:
            yield GripperGraspRecord.from_row(row)

    def top(self, mesh: str | int, k: int = 5, rank_by: str = "rank"
            ) -> list[GraspRecord] | list[GripperGraspRecord]:
        """The best ``k`` grasps of a mesh, of either kind, following duplicates to their
        original: :class:`GraspRecord` for point-finger grasps, :class:`GripperGraspRecord`
        for gripper grasps.

        ``rank_by``: ``"rank"`` (the planner's order, as built) or a word of ``--rank-by``.
        Point-finger grasps (:data:`TOP_ORDERS`): ``"d_star"`` (by d* as printed, then
        conditioning), ``"conditioning"``, ``"epsilon"`` or ``"tolerance"`` (placement
        tolerance, largest first; grasps without one last), as
        :func:`synth.plan.ranking.rank_grasps` orders them, then by rank. Gripper grasps
        (:data:`GRIPPER_TOP_ORDERS`): ``"margin"`` (least squeeze per weight first),
        ``"d_star"``, ``"mu_min"`` (smallest first) or ``"epsilon"``, as
        :func:`synth.plan.gripper.rank_order` orders them, then by rank.

        Raises
        ------
        InputError
            ``k`` below 1, or ``rank_by`` not an order of the mesh's kind of grasps.
        """
        if isinstance(k, bool) or not isinstance(k, numbers.Integral) or k < 1:
            raise InputError(f"k: expected an integer of at least 1, got {k!r}")
        if not isinstance(mesh, (str, numbers.Integral)) or isinstance(mesh, bool):
            raise InputError(f"mesh: expected a mesh's id, path, name or SHA-256, got {mesh!r}")
        if rank_by not in TOP_ORDERS + GRIPPER_TOP_ORDERS:
            raise InputError(f"rank_by: expected one of "
                             f"{', '.join(dict.fromkeys(TOP_ORDERS + GRIPPER_TOP_ORDERS))}, got "
                             f"{rank_by!r}")
        owner = self._grasp_owner(mesh)
        jaws = [] if self.schema_version < 4 else self._query(
            "SELECT * FROM gripper_grasps WHERE mesh_id = ? ORDER BY rank", (owner,))
        fingers = [] if jaws else self._query(
            "SELECT * FROM grasps WHERE mesh_id = ? ORDER BY rank", (owner,))
        gripper = bool(jaws) or (not fingers and self.kind == "gripper")
        orders = GRIPPER_TOP_ORDERS if gripper else TOP_ORDERS
        if rank_by not in orders:
            what = "gripper" if gripper else "point-finger"
            raise InputError(f"--rank-by (Python: rank_by=) {rank_by!r}: {self.path}: the "
                             f"grasps of mesh {mesh!r} are {what} grasps, which rank by "
                             f"{', '.join(orders)}")
        if gripper:
            return _gripper_top([GripperGraspRecord.from_row(r) for r in jaws], k, rank_by)
        from synth.plan.ranking import rank_grasps

        grasps = [GraspRecord.from_row(r) for r in fingers]
        if rank_by == "tolerance" and grasps and all(g.tolerance is None for g in grasps):
            raise InputError(f"--rank-by (Python: rank_by=) 'tolerance': {self.path}: the "
                             f"grasps of mesh {mesh!r} have no placement tolerance (the "
                             "database was built without --regions)")
        if rank_by != "rank":
            grasps = rank_grasps(grasps, rank_by)
        return grasps[: int(k)]

    def _grasp_owner(self, mesh: str | int) -> int:
        rec = self.mesh(mesh)
        return rec.duplicate_of if rec.duplicate_of is not None else rec.id

    def mesh(self, key: str | int) -> MeshRecord:
        """Look a mesh up by id, path, SHA-256 (or a prefix of 8+ hex digits), name or stem.

        Raises
        ------
        InputError
            If nothing matches, or several meshes do (their paths are listed); or ``key`` is
            neither text nor an integer.
        """
        if isinstance(key, bool) or not isinstance(key, (str, numbers.Integral)):
            raise InputError(f"mesh: expected a mesh's id, path, name or SHA-256, got {key!r}")
        if isinstance(key, numbers.Integral):
            key = int(key)
            rows = self._query("SELECT * FROM meshes WHERE id = ?", (key,))
        else:
            rows = self._query(
                "SELECT * FROM meshes WHERE path = ? OR path = ?", (key, os.path.abspath(key))
            )
            low = key.lower()
            if not rows and len(low) >= 8 and all(c in "0123456789abcdef" for c in low):
                rows = self._query(
                    "SELECT * FROM meshes WHERE sha256 >= ? AND sha256 < ? ORDER BY id",
                    (low, low + "g"),
                )
                originals = [r for r in rows if r["status"] != "duplicate"]
                rows = originals or rows  # a content's duplicates share its sha256
            if not rows:
                rows = self._query("SELECT * FROM meshes WHERE name = ? ORDER BY id", (key,))
            if not rows:  # the stem: 'box' finds 'box.stl'
                rows = self._query(
                    "SELECT * FROM meshes WHERE name > ? AND name < ? ORDER BY id",
                    (key + ".", key + "/"),
                )
                rows = [r for r in rows if os.path.splitext(r["name"])[0] == key]
        if not rows:
            raise InputError(f"{self.path}: no mesh matching {key!r} (try a path, name or "
                             f"sha256); {self._some_meshes()}")
        if len(rows) > 1:
            paths = ", ".join(r["path"] for r in rows[:5]) + (", ..." if len(rows) > 5 else "")
            raise InputError(
                f"{self.path}: {len(rows)} meshes match {key!r} ({paths}); give a path instead"
            )
        return MeshRecord.from_row(rows[0])

    def _some_meshes(self, shown: int = 5) -> str:
        """The first ``shown`` meshes the database holds, by name, in words for a message."""
        n = len(self)
        if n == 0:
            return "the database holds no mesh"
        names = [r[0] for r in self._query("SELECT name FROM meshes ORDER BY id LIMIT ?",
                                           (shown,))]
        more = f", and {n - shown:,} more" if n > shown else ""
        return f"it holds {n:,} mesh{'es' * (n != 1)}: {', '.join(names)}{more}"

    # -- writing (synth.database.build) ---------------------------------------------------
    def _require_write(self, migrate: bool = True) -> None:
        """Refuse writes on a read-only handle; migrate an older schema before the first write."""
        if self.mode != "w":
            raise DatabaseError(f"{self.path}: opened read-only")
        if migrate and not self._current:
            if not schema_current(self._conn, self.schema_version):
                migrate_schema(self._conn, self.path)
                self.meta = check_schema(self._conn, self.path)
                self.schema_version = schema_version(self.meta)
            self._current = True

    def bind(self, params: dict[str, Any], planner: str,
             defaults: dict[str, Any] | None = None) -> None:
        """Fix this database's parameters and planner, or check they match the stored ones.

        A parameter missing from the stored ones (a database built before the parameter
        existed) matches its value in ``defaults``.

        Raises
        ------
        DatabaseError
            If the database was built with other parameters or another planner.
        """
        if not isinstance(params, dict) or not isinstance(planner, str):
            raise InputError(f"bind: expected a dict of parameters and a planner name, got "
                             f"{type(params).__name__} and {type(planner).__name__}")
        self._require_write(migrate=False)  # a refused build leaves an old file as it is
        text = canonical_json(params)
        stored = self.meta.get("params")
        if stored is None:
            self._require_write()
            with self._conn:
                self._conn.execute("BEGIN IMMEDIATE")
                self._conn.executemany(
                    "INSERT OR REPLACE INTO meta(key, value) VALUES (?, ?)",
                    [("params", text), ("planner", planner)],
                )
            self.meta.update(params=text, planner=planner)
            return
        import json

        if self.meta.get("planner") != planner:  # (another planner's parameters differ too)
            gripper = "gripper" in str(self.meta.get("planner"))
            raise DatabaseFileError(
                f"{self.path}: this database was built with planner {self.meta.get('planner')!r}, "
                f"not {planner!r}" + (" (gripper grasps: give --gripper and the build's "
                                      "gripper options)" if gripper else "")
                + "; use the same planner to resume, or another --out file"
            )
        old = {**(defaults or {}), **json.loads(stored)}
        diff = _differences(old, params)
        if diff:
            shown = ", ".join(f"{k}: stored {a!r}, asked {b!r}" for k, (a, b) in diff.items())
            raise DatabaseFileError(
                f"{self.path}: this database was built with other planner parameters ({shown}); "
                "use the same parameters to resume, or another --out file"
            )
        self._require_write()  # the build goes on: migrate an older schema now

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Cursor]:
        """An immediate transaction: everything done with the cursor is committed or nothing."""
        self._require_write()
        try:
            with self._conn:
                self._conn.execute("BEGIN IMMEDIATE")
                yield self._conn.cursor()
        except sqlite3.Error as e:
            raise DatabaseError(f"{self.path}: write failed: {e}") from e

    def store_outcome(
        self, mesh_id: int, sha256: str | None, size: int | None, outcome: PlanOutcome
    ) -> None:
        """Write one mesh's grasps, its final status and its loading report in one transaction."""
        self._require_write()
        cols = ", ".join(("mesh_id",) + outcome.columns)
        marks = ", ".join("?" * (len(outcome.columns) + 1))
        try:
            with self._conn:
                self._conn.execute("BEGIN IMMEDIATE")
                self._conn.execute("DELETE FROM grasps WHERE mesh_id = ?", (mesh_id,))
                self._conn.execute("DELETE FROM gripper_grasps WHERE mesh_id = ?", (mesh_id,))
                self._conn.executemany(
                    f"INSERT INTO {outcome.table}({cols}) VALUES ({marks})",
                    [(mesh_id,) + row for row in outcome.rows],
                )
                self._conn.execute(
                    "UPDATE meshes SET sha256 = ?, size = ?, status = ?, error_kind = ?, "
                    "error = ?, duplicate_of = NULL, units = ?, length = ?, planner_params = ?, "
                    "synth_version = ?, n_grasps = ?, plan_s = ?, worker_s = ?, finished_at = ?, "
                    "mesh_report = ? WHERE id = ?",
                    (
                        sha256, size, "done" if outcome.ok else "failed", outcome.error_kind,
                        outcome.error, outcome.units, outcome.length, outcome.planner_params,
                        outcome.synth_version, len(outcome.rows), outcome.plan_s,
                        outcome.worker_s, _now(), outcome.report, mesh_id,
                    ),
                )  # fmt: skip
        except sqlite3.Error as e:
            raise DatabaseError(f"{self.path}: write failed: {e}") from e

    def rows_by_path(self, paths: Iterable[str]) -> dict[str, sqlite3.Row]:
        """Existing ``meshes`` rows of these paths."""
        out: dict[str, sqlite3.Row] = {}
        if isinstance(paths, (str, bytes)) or not hasattr(paths, "__iter__"):
            raise InputError(f"paths: expected a list of mesh paths, got {paths!r:.80}")
        paths = [str(p) for p in paths]
        for i in range(0, len(paths), 500):
            chunk = paths[i : i + 500]
            marks = ", ".join("?" * len(chunk))
            for row in self._query(f"SELECT * FROM meshes WHERE path IN ({marks})", chunk):
                out[row["path"]] = row
        return out

    def primary_by_sha(self, sha256: str) -> int | None:
        """Id of the non-duplicate mesh with this content, if any."""
        rows = self._query(
            "SELECT id FROM meshes WHERE sha256 = ? AND status != 'duplicate' ORDER BY id LIMIT 1",
            (sha256,),
        )
        return int(rows[0][0]) if rows else None

    def id_of(self, path: str) -> int:
        """Id of the mesh row of ``path`` (as stored: absolute)."""
        rows = self._query("SELECT id FROM meshes WHERE path = ?", (str(path),))
        if not rows:
            raise InputError(f"{self.path}: no mesh stored with the path {path!r}")
        return int(rows[0][0])

    @staticmethod
    def now() -> str:
        """UTC ISO 8601 time stamp, as stored in ``finished_at``."""
        return _now()
