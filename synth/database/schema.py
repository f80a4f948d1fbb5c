"""The SQLite schema of a synth grasp database (schema version 4) and its record types.

A grasp database is one SQLite file in WAL mode, written by ``synth db build`` (one writer, the
parent process) and readable by anyone while it is written. It holds four tables: ``meta``,
``meshes``, ``grasps`` for point-finger plans and ``gripper_grasps`` for gripper plans
(``synth db build --gripper``).

``meta`` -- one row per key, text values:

=================  ===========================================================================
key                value
=================  ===========================================================================
application        ``synth.grasps.db`` (also ``PRAGMA application_id = 0x53594E54``)
schema_version     ``4`` (also ``PRAGMA user_version = 4``)
synth_version      the library version that created the file
params             canonical JSON of the planner parameters every mesh of this file is planned with
planner            the planner used, ``"module:function"``
created_at         UTC ISO 8601 time of creation
=================  ===========================================================================

``meshes`` -- one row per mesh file seen (unique by absolute ``path``):

=============  =========  ======================================================================
column         type       meaning
=============  =========  ======================================================================
id             INTEGER    primary key; assigned in sorted path order when a build starts
path           TEXT       absolute path of the file (unique)
name           TEXT       file name (``box.stl``), for lookups by name
sha256         TEXT       SHA-256 of the file's bytes (hex), NULL if the file could not be read
size           INTEGER    file size in bytes, NULL if unknown
status         TEXT       ``pending``, ``done``, ``failed`` or ``duplicate``
error_kind     TEXT       for ``failed``: ``mesh``, ``not_mesh``, ``unreadable``, ``no_grasp``,
                          ``planner``, ``invalid_result``, ``timeout``, ``time_cap``, ``sim``
                          (a build with ``--sim`` could not simulate the grasps found) or
                          ``crashed`` (the worker died: the error names the signal); else NULL
error          TEXT       readable reason of a failure, or the note of a duplicate
duplicate_of   INTEGER    for ``duplicate``: id of the mesh with the same SHA-256 that is planned
units          TEXT       units reported by the planner (``mm``, ``m``, ...)
length         REAL       characteristic length reported by the planner, in those units
params         TEXT       canonical JSON of the requested planner parameters (identity of a run)
planner_params TEXT       JSON of the full parameter set the planner reported
planner        TEXT       ``"module:function"`` of the planner
synth_version  TEXT       version of the planner library that planned the mesh
n_grasps       INTEGER    number of grasps stored for the mesh
plan_s         REAL       planner-reported time (``timing.total_s``), seconds
worker_s       REAL       wall time of the whole task on the worker (load, plan, pack), seconds
finished_at    TEXT       UTC ISO 8601 time the row reached its status
mesh_report    TEXT       what loading did to the mesh: canonical JSON of the planner document's
                          ``mesh`` object without ``path`` and ``sha256`` (with the real planner:
                          ``units``, ``length``, ``precision``, ``center_mass``, ``volume``,
                          ``bodies``, ``repairs``, ``warnings``, ``dropped``; a plugged-in
                          planner's object as it is); NULL when the planner returned no document
                          (the mesh failed before planning, timed out, crashed...) or no ``mesh``
                          object, for ``pending`` and ``duplicate`` rows, and for rows written
                          under schema version 1 (new in version 2)
=============  =========  ======================================================================

``grasps`` -- one row per grasp, ``PRIMARY KEY (mesh_id, rank)``, ``WITHOUT ROWID``:

=============  =========  ======================================================================
column         type       meaning
=============  =========  ======================================================================
mesh_id        INTEGER    ``meshes.id``
rank           INTEGER    1 = best, in the planner's order
d_star         REAL       Trinkle's d*
closure        TEXT       closure class in the paper's words (see the README mapping)
conditioning   REAL       conditioning of the wrench matrix
epsilon        REAL       epsilon quality (friction), as the planner reports it
n_contacts     INTEGER    k
points         BLOB       (k, 3) float64 little-endian, row-major: contact points
normals        BLOB       (k, 3) float64 little-endian: contact normals as the planner gives them
features       TEXT       JSON list of k strings (``face``, ``edge``, ``vertex``, ...)
regions        BLOB       (k,) int64 little-endian: region index of each contact
n_fingers      INTEGER    f
tip_centers    BLOB       (f, 3) float64 little-endian
tip_radius     REAL       fingertip radius
approach       BLOB       (f, 3) float64 little-endian: approach direction of each finger
body_length    REAL       finger body length
body_radius    REAL       finger body radius
tolerance      REAL       placement tolerance (:func:`synth.contact_regions`) in the mesh's
                          units; NULL when the build did not compute regions (new in version 3)
contact_regions TEXT      canonical JSON of the grasp's ``contact_regions`` object (polygons,
                          kinds, tolerance, limited_by, d_star_min, certified); NULL as above
sim            TEXT       canonical JSON of the grasp's simulation label (``synth sim``'s
                          ``sim`` object: simulator, held, failed_at, ...); NULL when the build
                          did not simulate (``synth db build --sim``; new in version 4)
squeeze_per_weight REAL   least force each finger must press with, over the part's weight, to
                          hold it in every orientation (:mod:`synth.scores.hold`); NULL in files
                          written before the column (a late column of version 4)
least_squeeze  REAL       that force in newtons; NULL without the build's --mass or --density
margin         REAL       the build's --grip over the least squeeze; NULL without both
=============  =========  ======================================================================

``gripper_grasps`` -- one row per gripper grasp, ``PRIMARY KEY (mesh_id, rank)``,
``WITHOUT ROWID`` (new in version 4):

==================  =========  =================================================================
column              type       meaning
==================  =========  =================================================================
mesh_id             INTEGER    ``meshes.id``
rank                INTEGER    1 = best, in the planner's order
gripper             TEXT       the gripper's name
pose                BLOB       (4, 4) float64 little-endian: the gripper's base frame in the
                               part's frame (ACRONYM/GraspGen: approach +z, closing x)
tcp                 BLOB       (3,) float64: tool centre point in the part's frame
width               REAL       pad distance at the grasp, in the mesh's units
points              BLOB       (2, 3) float64: contacts, the +x pad's first
normals             BLOB       (2, 3) float64: their inward normals
squeeze_per_weight  REAL       least squeeze holding the part against gravity, over its weight
least_squeeze       REAL       in newtons, NULL without a mass
margin              REAL       rated grip force over the least squeeze, NULL without a mass
mu_min              REAL       least closing friction coefficient, NULL if none closes
epsilon             REAL       Ferrari-Canny epsilon with soft contacts
d_star              REAL       Trinkle's frictional d* with soft contacts
sim                 TEXT       canonical JSON of the grasp's simulation label, NULL as in
                               ``grasps``
==================  =========  =================================================================

Indexes: ``meshes(path)`` (unique), ``meshes(sha256)``, ``meshes(name)``, ``meshes(status)``,
``grasps(d_star)`` and ``grasps(tolerance)``; the primary key of ``grasps`` serves "the best k grasps of a mesh".

A mesh's grasps are written in the same transaction as its ``done`` status, so a reader never
sees a ``done`` mesh with missing grasps, nor grasps of a mesh that is not ``done``.

Versions: schema version 1 lacks ``meshes.mesh_report``; versions 1 and 2 lack
``grasps.tolerance`` and ``grasps.contact_regions``; versions 1 to 3 lack the
``gripper_grasps`` table and ``grasps.sim``. Files of version 4 written before ``sim`` existed
(the day version 4 appeared) lack ``grasps.sim`` and ``gripper_grasps.sim``, and those written
before the hold measures lack ``grasps.squeeze_per_weight``, ``least_squeeze`` and ``margin``. An older file is
read as it is (the missing fields read as None, the missing table as no gripper grasps) and is
migrated in place to the full version 4 -- the missing columns added with ``ALTER TABLE`` (NULL
in existing rows), the ``grasps(tolerance)`` index and the ``gripper_grasps`` table created,
``meta.schema_version`` and ``PRAGMA user_version`` set to 4, in one transaction -- the first
time a build writes to it (:func:`migrate_schema`, :func:`schema_current`). A file of a newer
version than this synth's is refused.
"""

from __future__ import annotations

import json
import sqlite3
from dataclasses import dataclass
from typing import Any

import numpy as np

from synth.errors import DatabaseError, DatabaseFileError
from synth.fingers.model import finger_frames

__all__ = [
    "SCHEMA_VERSION",
    "READABLE_VERSIONS",
    "APPLICATION",
    "APPLICATION_ID",
    "MESH_STATUSES",
    "MeshRecord",
    "GraspRecord",
    "GripperGraspRecord",
    "GRIPPER_GRASPS_DDL",
    "canonical_json",
    "create_schema",
    "check_schema",
    "schema_version",
    "migrate_schema",
    "schema_current",
    "pack_array",
    "unpack_array",
]

SCHEMA_VERSION = 4
#: Schema versions this synth reads; the older ones are migrated by :func:`migrate_schema`.
READABLE_VERSIONS = (1, 2, 3, 4)
APPLICATION = "synth.grasps.db"
APPLICATION_ID = 0x53594E54  # "SYNT"
MESH_STATUSES = ("pending", "done", "failed", "duplicate")

_DDL = """
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
    finished_at    TEXT,
    mesh_report    TEXT
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
    tolerance    REAL,
    contact_regions TEXT,
    sim          TEXT,
    squeeze_per_weight REAL,
    least_squeeze REAL,
    margin       REAL,
    PRIMARY KEY (mesh_id, rank)
) WITHOUT ROWID;
CREATE INDEX grasps_d_star ON grasps(d_star);
CREATE INDEX grasps_tolerance ON grasps(tolerance);
"""
#: The table of gripper grasps (schema version 4), created by new files and by the migration.
GRIPPER_GRASPS_DDL = """
CREATE TABLE gripper_grasps (
    mesh_id            INTEGER NOT NULL REFERENCES meshes(id),
    rank               INTEGER NOT NULL,
    gripper            TEXT NOT NULL,
    pose               BLOB NOT NULL,
    tcp                BLOB NOT NULL,
    width              REAL NOT NULL,
    points             BLOB NOT NULL,
    normals            BLOB NOT NULL,
    squeeze_per_weight REAL NOT NULL,
    least_squeeze      REAL,
    margin             REAL,
    mu_min             REAL,
    epsilon            REAL NOT NULL,
    d_star             REAL NOT NULL,
    sim                TEXT,
    PRIMARY KEY (mesh_id, rank)
) WITHOUT ROWID;
"""


@dataclass(frozen=True)
class MeshRecord:
    """One row of the ``meshes`` table.

    Attributes
    ----------
    id : int
        Row id.
    path, name : str
        Absolute path and file name.
    sha256 : str or None
        SHA-256 of the file (hex), None if it could not be read.
    size : int or None
        File size in bytes.
    status : str
        ``pending``, ``done``, ``failed`` or ``duplicate``.
    error_kind, error : str or None
        Failure category and readable reason (``error`` also notes duplicates).
    duplicate_of : int or None
        Id of the mesh with the same content, for duplicates.
    units : str or None
        Units the planner reported.
    length : float or None
        Characteristic length the planner reported.
    params : dict
        Requested planner parameters.
    planner : str
        ``"module:function"`` of the planner.
    synth_version : str or None
        Version of the library that planned it.
    n_grasps : int
        Number of grasps stored.
    plan_s, worker_s : float or None
        Planner time and whole-task time, seconds.
    finished_at : str or None
        UTC ISO 8601 time of the status.
    report : dict or None
        What loading did to the mesh: the planner document's ``mesh`` object without ``path``
        and ``sha256`` (``repairs``, ``warnings``, ``dropped``, ``bodies``, ... with the synth
        planner); None if the planner returned none, and for rows of a schema-1 database.
    """

    id: int
    path: str
    name: str
    sha256: str | None
    size: int | None
    status: str
    error_kind: str | None
    error: str | None
    duplicate_of: int | None
    units: str | None
    length: float | None
    params: dict[str, Any]
    planner: str
    synth_version: str | None
    n_grasps: int
    plan_s: float | None
    worker_s: float | None
    finished_at: str | None
    report: dict[str, Any] | None = None

    @classmethod
    def from_row(cls, row: sqlite3.Row) -> MeshRecord:
        """Build a record from a ``SELECT * FROM meshes`` row."""
        return cls(
            id=row["id"],
            path=row["path"],
            name=row["name"],
            sha256=row["sha256"],
            size=row["size"],
            status=row["status"],
            error_kind=row["error_kind"],
            error=row["error"],
            duplicate_of=row["duplicate_of"],
            units=row["units"],
            length=row["length"],
            params=json.loads(row["params"]),
            planner=row["planner"],
            synth_version=row["synth_version"],
            n_grasps=row["n_grasps"],
            plan_s=row["plan_s"],
            worker_s=row["worker_s"],
            finished_at=row["finished_at"],
            report=_decode_report(row),
        )


def _decode_report(row: sqlite3.Row) -> dict[str, Any] | None:
    """The decoded ``mesh_report`` of a ``meshes`` row; None if NULL or a schema-1 row."""
    text = row["mesh_report"] if "mesh_report" in row.keys() else None
    return None if text is None else dict(json.loads(text))


class _StoredGrasp:
    """What both kinds of stored grasps share: their contacts' count, and equality field by
    field (arrays compared exactly, through ``to_dict``)."""

    mesh_id: int
    points: np.ndarray

    @property
    def n_contacts(self) -> int:
        """Number of contacts k (2 for a gripper grasp, one per pad)."""
        return int(self.points.shape[0])

    def to_dict(self) -> dict[str, Any]:
        raise NotImplementedError

    def __eq__(self, other: object) -> bool:
        """Field-by-field equality, arrays compared exactly."""
        if type(other) is not type(self):
            return NotImplemented
        return self.to_dict() == other.to_dict() and self.mesh_id == other.mesh_id  # type: ignore[attr-defined]


@dataclass(frozen=True, eq=False)
class GraspRecord(_StoredGrasp):
    """One stored grasp (a row of ``grasps``), arrays decoded.

    Attributes
    ----------
    mesh_id : int
        Id of its mesh.
    rank : int
        1 = best.
    d_star, conditioning, epsilon : float
        Quality figures as the planner gave them.
    closure : str
        Closure class in the paper's words.
    points, normals : (k, 3) float
        Contact points and normals.
    features : tuple of str
        Feature kind of each contact, length k.
    regions : (k,) int
        Region index of each contact.
    tip_centers, approach : (f, 3) float
        Finger tip centres and approach directions.
    tip_radius, body_length, body_radius : float
        Finger geometry.
    tolerance : float or None
        Placement tolerance, None when not computed (or in a file older than version 3).
    contact_regions : dict or None
        The grasp's ``contact_regions`` JSON object, None as above.
    sim : dict or None
        The grasp's simulation label (the ``sim`` object of ``synth sim``), None when the
        build did not simulate (or in a file without the column).
    squeeze_per_weight, least_squeeze, margin : float or None
        The hold measures (:mod:`synth.scores.hold`), None where not stored.
    """

    mesh_id: int
    rank: int
    d_star: float
    closure: str
    conditioning: float
    epsilon: float
    points: np.ndarray
    normals: np.ndarray
    features: tuple[str, ...]
    regions: np.ndarray
    tip_centers: np.ndarray
    tip_radius: float
    approach: np.ndarray
    body_length: float
    body_radius: float
    tolerance: float | None = None
    contact_regions: dict[str, Any] | None = None
    sim: dict[str, Any] | None = None
    squeeze_per_weight: float | None = None
    least_squeeze: float | None = None
    margin: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The grasp in the planner's JSON format (format version 1), plus ``rank``; ``sim``
        as ``synth plan --sim`` writes it, or None."""
        return {
            "rank": self.rank,
            "points": self.points.tolist(),
            "normals": self.normals.tolist(),
            "features": list(self.features),
            "regions": self.regions.tolist(),
            "d_star": self.d_star,
            "closure": self.closure,
            "conditioning": self.conditioning,
            "epsilon": self.epsilon,
            "squeeze_per_weight": self.squeeze_per_weight,
            "least_squeeze": self.least_squeeze,
            "margin": self.margin,
            "fingers": {
                "tip_centers": self.tip_centers.tolist(),
                "tip_radius": self.tip_radius,
                "approach": self.approach.tolist(),
                "body_length": self.body_length,
                "body_radius": self.body_radius,
                "frames": finger_frames(self.tip_centers, self.approach).tolist(),
            },
            "tolerance": self.tolerance,
            "contact_regions": self.contact_regions,
            "sim": self.sim,
        }

    @classmethod
    def from_row(cls, row: sqlite3.Row) -> GraspRecord:
        """Build a record from a ``SELECT * FROM grasps`` row."""
        k, f = row["n_contacts"], row["n_fingers"]
        keys = row.keys()
        regions = row["contact_regions"] if "contact_regions" in keys else None
        return cls(
            mesh_id=row["mesh_id"],
            rank=row["rank"],
            d_star=row["d_star"],
            closure=row["closure"],
            conditioning=row["conditioning"],
            epsilon=row["epsilon"],
            points=unpack_array(row["points"], (k, 3)),
            normals=unpack_array(row["normals"], (k, 3)),
            features=tuple(json.loads(row["features"])),
            regions=unpack_array(row["regions"], (k,), dtype="<i8"),
            tip_centers=unpack_array(row["tip_centers"], (f, 3)),
            tip_radius=row["tip_radius"],
            approach=unpack_array(row["approach"], (f, 3)),
            body_length=row["body_length"],
            body_radius=row["body_radius"],
            tolerance=row["tolerance"] if "tolerance" in keys else None,
            contact_regions=None if regions is None else json.loads(regions),
            sim=_decode_sim(row),
            **{m: row[m] if m in keys else None
               for m in ("squeeze_per_weight", "least_squeeze", "margin")},
        )


def _decode_sim(row: sqlite3.Row) -> dict[str, Any] | None:
    """The decoded ``sim`` of a grasp row; None if NULL or the file has no such column."""
    text = row["sim"] if "sim" in row.keys() else None
    return None if text is None else dict(json.loads(text))


@dataclass(frozen=True, eq=False)
class GripperGraspRecord(_StoredGrasp):
    """One stored gripper grasp (a row of ``gripper_grasps``), arrays decoded.

    Attributes
    ----------
    mesh_id, rank : int
    gripper : str
    pose : (4, 4) float
    tcp : (3,) float
    width : float
    points, normals : (2, 3) float
    squeeze_per_weight : float
    least_squeeze, margin, mu_min : float or None
    epsilon, d_star : float
    sim : dict or None
        The simulation label, as in :class:`GraspRecord`.
    """

    mesh_id: int
    rank: int
    gripper: str
    pose: np.ndarray
    tcp: np.ndarray
    width: float
    points: np.ndarray
    normals: np.ndarray
    squeeze_per_weight: float
    least_squeeze: float | None
    margin: float | None
    mu_min: float | None
    epsilon: float
    d_star: float
    sim: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The grasp in the gripper planner's JSON format (a grasp of a
        ``synth.gripper_grasps`` document: ``pose``, ``tcp``, ``width``, ``contacts`` with
        ``point``, ``normal`` and ``touch``, ``measures``), plus ``rank``, ``gripper`` and
        ``sim`` (the label, or None). The contacts' patch sizes and the worst gravity
        direction are not stored."""
        from synth.fingers.jaws import pad_touch

        return {
            "rank": self.rank, "gripper": self.gripper, "pose": self.pose.tolist(),
            "tcp": self.tcp.tolist(), "width": self.width,
            "contacts": [{"point": p.tolist(), "normal": n.tolist(), "touch": t} for p, n, t
                         in zip(self.points, self.normals, pad_touch(self.pose, self.normals))],
            "measures": {"margin": self.margin, "least_squeeze": self.least_squeeze,
                         "squeeze_per_weight": self.squeeze_per_weight, "d_star": self.d_star,
                         "mu_min": self.mu_min, "epsilon": self.epsilon},
            "sim": self.sim,
        }  # fmt: skip

    @classmethod
    def from_row(cls, row: sqlite3.Row) -> GripperGraspRecord:
        """Build a record from a ``SELECT * FROM gripper_grasps`` row."""
        return cls(
            mesh_id=row["mesh_id"], rank=row["rank"], gripper=row["gripper"],
            pose=unpack_array(row["pose"], (4, 4)), tcp=unpack_array(row["tcp"], (3,)),
            width=row["width"], points=unpack_array(row["points"], (2, 3)),
            normals=unpack_array(row["normals"], (2, 3)),
            squeeze_per_weight=row["squeeze_per_weight"], least_squeeze=row["least_squeeze"],
            margin=row["margin"], mu_min=row["mu_min"], epsilon=row["epsilon"],
            d_star=row["d_star"], sim=_decode_sim(row),
        )  # fmt: skip


def canonical_json(value: Any) -> str:
    """JSON text with sorted keys and no spaces, so equal parameters give equal text."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"))


def pack_array(values: Any, shape: tuple[int, ...], dtype: str = "<f8") -> bytes:
    """Encode an array as little-endian bytes after checking its shape.

    Parameters
    ----------
    values : array_like
        The values.
    shape : tuple of int
        The shape expected.
    dtype : str
        ``"<f8"`` (float64) or ``"<i8"`` (int64), little-endian.

    Returns
    -------
    bytes
        The row-major bytes.

    Raises
    ------
    ValueError
        If the shape differs or a float is not finite.
    """
    arr = np.asarray(values, dtype=dtype)
    if arr.shape != shape:
        raise ValueError(f"expected shape {shape}, got {arr.shape}")
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"array of shape {shape} has non-finite values")
    return np.ascontiguousarray(arr).tobytes()


def unpack_array(blob: bytes, shape: tuple[int, ...], dtype: str = "<f8") -> np.ndarray:
    """Decode bytes written by :func:`pack_array` into a native-endian array of ``shape``."""
    return np.frombuffer(blob, dtype=dtype).reshape(shape).astype(dtype[1:])


def create_schema(conn: sqlite3.Connection, meta: dict[str, str]) -> None:
    """Create the tables of an empty database and write its ``meta`` rows (one transaction)."""
    conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
    conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    rows = {"application": APPLICATION, "schema_version": str(SCHEMA_VERSION), **meta}
    conn.executescript("BEGIN IMMEDIATE;" + _DDL + GRIPPER_GRASPS_DDL)
    try:
        conn.executemany("INSERT INTO meta(key, value) VALUES (?, ?)", sorted(rows.items()))
        conn.execute("COMMIT")
    except BaseException:
        conn.execute("ROLLBACK")
        raise


def check_schema(conn: sqlite3.Connection, path: str) -> dict[str, str]:
    """Check that ``conn`` is a synth grasp database of a readable schema version; return its meta.

    The readable versions are :data:`READABLE_VERSIONS` (this one and the older ones
    :func:`migrate_schema` upgrades); :func:`schema_version` gives the version of the meta.

    Raises
    ------
    DatabaseError
        Naming ``path``, if the file is not SQLite, not a synth database, or of a version this
        synth does not read (a newer one).
    """
    try:
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    except sqlite3.DatabaseError as e:
        raise DatabaseFileError(f"{path}: not a synth grasp database (not SQLite: {e})") from e
    if "meta" not in tables:
        raise DatabaseFileError(
            f"{path}: not a synth grasp database (an SQLite file without a 'meta' table; "
            f"tables found: {sorted(tables) or 'none'})"
        )
    meta = dict(conn.execute("SELECT key, value FROM meta").fetchall())
    if meta.get("application") != APPLICATION:
        raise DatabaseFileError(
            f"{path}: not a synth grasp database (meta.application is "
            f"{meta.get('application')!r}, expected {APPLICATION!r})"
        )
    if meta.get("schema_version") not in {str(v) for v in READABLE_VERSIONS}:
        raise DatabaseFileError(
            f"{path}: grasp database of schema version {meta.get('schema_version')}, this synth "
            f"reads versions {READABLE_VERSIONS[0]} to {SCHEMA_VERSION}; rebuild it with this "
            "version of synth or use the version that wrote it"
        )
    missing = {"meshes", "grasps"} - tables
    if missing:
        raise DatabaseFileError(f"{path}: damaged grasp database, missing tables {sorted(missing)}")
    return meta


def schema_version(meta: dict[str, str]) -> int:
    """The schema version recorded in a meta dict checked by :func:`check_schema`."""
    return int(meta["schema_version"])


#: Columns version 4 gained after files of it were written: (table, column, type).
_LATE_COLUMNS = (("grasps", "sim", "TEXT"), ("gripper_grasps", "sim", "TEXT"),
                 ("grasps", "squeeze_per_weight", "REAL"), ("grasps", "least_squeeze", "REAL"),
                 ("grasps", "margin", "REAL"))


def _missing_columns(conn: sqlite3.Connection) -> list[tuple[str, str, str]]:
    """The columns of :data:`_LATE_COLUMNS` missing from tables that exist."""
    missing = []
    for table, column, kind in _LATE_COLUMNS:
        have = {r[1] for r in conn.execute(f"PRAGMA table_info({table})")}
        if have and column not in have:
            missing.append((table, column, kind))
    return missing


def schema_current(conn: sqlite3.Connection, version: int) -> bool:
    """Whether a file of schema ``version`` (from its meta) is the full current schema: this
    version, with every column (a version-4 file written before ``sim`` existed is not)."""
    return version == SCHEMA_VERSION and not _missing_columns(conn)


def migrate_schema(conn: sqlite3.Connection, path: str) -> int:
    """Upgrade a readable database of an older schema version to this one, in one transaction.

    Version 1 to 2: ``ALTER TABLE meshes ADD COLUMN mesh_report TEXT``; 2 to 3: ``grasps``
    gains ``tolerance REAL`` and ``contact_regions TEXT`` and the ``grasps(tolerance)`` index
    (NULL in every existing row); 3 to 4: the ``gripper_grasps`` table and ``grasps.sim``;
    a version-4 file written before ``sim`` existed gains ``grasps.sim`` and
    ``gripper_grasps.sim``; then ``meta.schema_version`` and ``PRAGMA user_version`` are set
    to 4. The version and the columns are read again inside the transaction, so a file
    another process has just migrated is left alone. Either the whole migration is committed
    or nothing is.

    Returns
    -------
    int
        The version the file had before (``SCHEMA_VERSION`` if there was nothing to do).

    Raises
    ------
    DatabaseError
        Naming ``path``, if the migration fails (the file is then unchanged).
    """
    try:
        conn.execute("BEGIN IMMEDIATE")
        try:
            row = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
            before = int(row[0])
            if before not in READABLE_VERSIONS:
                raise DatabaseError(
                    f"{path}: cannot migrate a grasp database of schema version {before} to "
                    f"version {SCHEMA_VERSION}"
                )
            if before < 2:
                conn.execute("ALTER TABLE meshes ADD COLUMN mesh_report TEXT")
            if before < 3:
                conn.execute("ALTER TABLE grasps ADD COLUMN tolerance REAL")
                conn.execute("ALTER TABLE grasps ADD COLUMN contact_regions TEXT")
                conn.execute("CREATE INDEX grasps_tolerance ON grasps(tolerance)")
            if before < 4:
                conn.execute(GRIPPER_GRASPS_DDL)
            for table, column, kind in _missing_columns(conn):
                conn.execute(f"ALTER TABLE {table} ADD COLUMN {column} {kind}")
            if before != SCHEMA_VERSION:
                conn.execute(
                    "UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(SCHEMA_VERSION),)
                )
                conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
            conn.execute("COMMIT")
        except BaseException:
            if conn.in_transaction:
                conn.execute("ROLLBACK")
            raise
    except sqlite3.Error as e:
        raise DatabaseError(
            f"{path}: cannot migrate the grasp database to schema version {SCHEMA_VERSION}: {e}"
        ) from e
    return before
