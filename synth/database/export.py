"""Export a grasp database to HDF5, NPZ or JSON.

HDF5 and NPZ hold the same columns, one array per field (never one group per grasp). Contacts
and fingers are ragged, so they are stored flat with offsets (CSR style): the contacts of grasp
``i`` are rows ``contact_start[i]:contact_start[i+1]`` of ``points``, ``normals``, ``features``
and ``regions``; its fingers rows ``finger_start[i]:finger_start[i+1]`` of ``tip_centers`` and
``approach``.

=====================  ============  ==========================================================
field                  shape         meaning
=====================  ============  ==========================================================
mesh_id                (m,) int64    id of each mesh row (every status)
mesh_path, mesh_name   (m,) str      absolute path and file name
mesh_sha256            (m,) str      SHA-256, ``""`` if unknown
mesh_size              (m,) int64    bytes, -1 if unknown
mesh_status            (m,) str      pending / done / failed / duplicate
mesh_error             (m,) str      failure reason or duplicate note, ``""`` if none
mesh_units             (m,) str      units, ``""`` if unknown
mesh_length            (m,) float64  characteristic length, NaN if unknown
mesh_n_grasps          (m,) int64    grasps stored
mesh_duplicate_of      (m,) int64    id of the original of a duplicate, -1 otherwise
mesh_report            (m,) str      what loading did to the mesh: JSON text of its report
                                     (``meshes.mesh_report``: repairs, warnings, dropped,
                                     bodies, ...), ``""`` if none
grasp_mesh_id, rank    (n,) int64    mesh of each grasp and its rank (1 = best)
d_star, conditioning,  (n,) float64  quality figures
epsilon
closure                (n,) str      closure class
contact_start          (n+1,) int64  offsets into the contact arrays
points, normals        (c, 3) f8     contact points and normals
features               (c,) str      feature kind of each contact
regions                (c,) int64    region of each contact
finger_start           (n+1,) int64  offsets into the finger arrays
tip_centers, approach  (g, 3) f8     finger tip centres and approach directions
finger_frames          (g, 4, 4) f8  a frame per finger: origin at the tip centre, +z along
                                     its approach towards the part
tip_radius,            (n,) float64  finger geometry of each grasp
body_length,
body_radius
tolerance              (n,) float64  placement tolerance, NaN where not computed
contact_regions        (n,) str      JSON text of the grasp's contact regions, ``""`` if none
sim                    (n,) str      JSON text of the grasp's simulation label (``synth db
                                     build --sim``), ``""`` if not simulated
sim_held               (n,) float64  1 if the simulated part held, 0 if not (also when the
                                     simulation diverged), NaN if not simulated (or synth
                                     could not simulate it: its label says why)
squeeze_per_weight,    (n,) float64  the least finger force per weight that holds the part in
least_squeeze, margin                every orientation, in newtons, and the grip over it (NaN
                                     where the build had no mass or grip, or predates them)
=====================  ============  ==========================================================

Gripper grasps (``synth db build --gripper``; every array empty, with its shape, in a
point-finger database) have columns of their own, prefixed ``gripper_``:

==============================  ==============  =================================================
field                           shape           meaning
==============================  ==============  =================================================
gripper_mesh_id, gripper_rank   (j,) int64      mesh of each gripper grasp and its rank (1 = best)
gripper_name                    (j,) str        the gripper (``franka``, ...)
gripper_pose                    (j, 4, 4) f8    the gripper's base frame in the part's frame
                                                (approach +z, closing x), in the mesh's unit
gripper_tcp                     (j, 3) f8       tool centre point
gripper_width                   (j,) f8         pad distance
gripper_points, gripper_normals (j, 2, 3) f8    the two contacts (the +x pad's first) and their
                                                inward normals
gripper_squeeze_per_weight,     (j,) f8         the gripper measures (``least_squeeze`` in N and
gripper_least_squeeze,                          ``margin`` NaN without a mass, ``mu_min`` NaN
gripper_margin, gripper_mu_min,                 where none closes)
gripper_epsilon, gripper_d_star
gripper_sim, gripper_sim_held   (j,) str, f8    as ``sim`` and ``sim_held``
==============================  ==============  =================================================

In HDF5 the ``mesh_*`` fields are datasets of the group ``meshes`` (without the prefix), the
``gripper_*`` fields of the group ``gripper_grasps`` (without the prefix) and the others of the
group ``grasps``; datasets are chunked and gzip-compressed; the file's
attributes hold ``format``, ``schema_version``, ``params`` (JSON), ``planner`` and ``units``
(``UNITS``: every length is in its mesh's unit). NPZ uses the flat names above plus ``params``,
``planner`` and ``units`` (0-d strings). JSON is one object with ``units`` and ``meshes``, each
carrying its unit, its loading ``report`` (an object, or null), its ``grasp_format``
(``synth.grasps`` or, for gripper grasps, ``synth.gripper_grasps``) and its ``grasps`` in that
planner's format (with ``sim``, the label object or null).
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from synth.database.schema import SCHEMA_VERSION, canonical_json
from synth.database.store import GraspDatabase
from synth.errors import InputError
from synth.files import atomic_path, wrote_by_synth
from synth.fingers.model import finger_frames

__all__ = ["EXPORT_FORMATS", "UNITS", "export_columns", "export_database"]

EXPORT_FORMATS = ("h5", "npz", "json")
_FORMAT_TAG = "synth.grasps.db-export"
#: What the exports say about the unit of their numbers.
UNITS = ("every length (points, tip centres, radii, tolerances, frames, gripper poses, tool "
         "centre points and widths) is in its mesh's unit: mesh_units ('' when the mesh file "
         "did not say); d_star, conditioning, epsilon, squeeze_per_weight, margin and mu_min "
         "are unitless, least_squeeze is in newtons")


def _str_array(values: list[str]) -> np.ndarray:
    return np.array(values, dtype=str) if values else np.zeros(0, dtype="<U1")


def export_columns(db: GraspDatabase) -> dict[str, np.ndarray]:
    """All meshes and grasps of ``db`` as flat columns (see the module docstring)."""
    meshes = list(db.meshes())
    cols: dict[str, Any] = {
        "mesh_id": np.array([m.id for m in meshes], dtype=np.int64),
        "mesh_path": _str_array([m.path for m in meshes]),
        "mesh_name": _str_array([m.name for m in meshes]),
        "mesh_sha256": _str_array([m.sha256 or "" for m in meshes]),
        "mesh_size": np.array([-1 if m.size is None else m.size for m in meshes], dtype=np.int64),
        "mesh_status": _str_array([m.status for m in meshes]),
        "mesh_error": _str_array([m.error or "" for m in meshes]),
        "mesh_units": _str_array([m.units or "" for m in meshes]),
        "mesh_length": np.array(
            [np.nan if m.length is None else m.length for m in meshes], dtype=np.float64
        ),
        "mesh_n_grasps": np.array([m.n_grasps for m in meshes], dtype=np.int64),
        "mesh_duplicate_of": np.array(
            [-1 if m.duplicate_of is None else m.duplicate_of for m in meshes], dtype=np.int64
        ),
        "mesh_report": _str_array(
            ["" if m.report is None else canonical_json(m.report) for m in meshes]
        ),
    }
    lists: dict[str, list[Any]] = {
        k: []
        for k in (
            "grasp_mesh_id rank d_star closure conditioning epsilon points normals features "
            "regions tip_centers approach finger_frames tip_radius body_length body_radius "
            "tolerance contact_regions sim sim_held squeeze_per_weight least_squeeze margin"
        ).split()
    }
    contact_start, finger_start = [0], [0]
    for g in db.grasps():
        lists["grasp_mesh_id"].append(g.mesh_id)
        for name in ("rank", "d_star", "closure", "conditioning", "epsilon", "tip_radius",
                     "body_length", "body_radius"):  # fmt: skip
            lists[name].append(getattr(g, name))
        lists["points"].append(g.points)
        lists["normals"].append(g.normals)
        lists["features"].extend(g.features)
        lists["regions"].append(g.regions)
        lists["tip_centers"].append(g.tip_centers)
        lists["approach"].append(g.approach)
        lists["finger_frames"].append(finger_frames(g.tip_centers, g.approach))
        lists["tolerance"].append(np.nan if g.tolerance is None else g.tolerance)
        lists["contact_regions"].append(
            "" if g.contact_regions is None else canonical_json(g.contact_regions))
        lists["sim"].append("" if g.sim is None else canonical_json(g.sim))
        lists["sim_held"].append(np.nan if g.sim is None or g.sim["held"] is None
                                 else float(bool(g.sim["held"])))
        for name in ("squeeze_per_weight", "least_squeeze", "margin"):
            value = getattr(g, name)
            lists[name].append(np.nan if value is None else float(value))
        contact_start.append(contact_start[-1] + g.n_contacts)
        finger_start.append(finger_start[-1] + g.tip_centers.shape[0])
    for name in ("grasp_mesh_id", "rank"):
        cols[name] = np.array(lists[name], dtype=np.int64)
    for name in ("d_star", "conditioning", "epsilon", "tip_radius", "body_length", "body_radius",
                 "tolerance", "sim_held", "squeeze_per_weight", "least_squeeze", "margin"):
        cols[name] = np.array(lists[name], dtype=np.float64)
    cols["contact_regions"] = _str_array(lists["contact_regions"])
    cols["sim"] = _str_array(lists["sim"])
    cols["closure"] = _str_array(lists["closure"])
    cols["features"] = _str_array(lists["features"])
    for name in ("points", "normals", "tip_centers", "approach"):
        cols[name] = np.concatenate(lists[name]) if lists[name] else np.zeros((0, 3))
    cols["finger_frames"] = (np.concatenate(lists["finger_frames"]) if lists["finger_frames"]
                             else np.zeros((0, 4, 4)))
    cols["regions"] = (
        np.concatenate(lists["regions"]).astype(np.int64) if lists["regions"] else
        np.zeros(0, dtype=np.int64)
    )  # fmt: skip
    cols["contact_start"] = np.array(contact_start, dtype=np.int64)
    cols["finger_start"] = np.array(finger_start, dtype=np.int64)
    cols.update(_gripper_columns(db))
    return cols


#: Stored measures of a gripper grasp that may be None (NaN in the columns).
_GRIPPER_MEASURES = ("squeeze_per_weight", "least_squeeze", "margin", "mu_min", "epsilon",
                     "d_star")


def _gripper_columns(db: GraspDatabase) -> dict[str, np.ndarray]:
    """The ``gripper_*`` columns: every gripper grasp of ``db`` (see the module docstring)."""
    grasps = list(db.gripper_grasps())

    def stack(name: str, shape: tuple[int, ...]) -> np.ndarray:
        return (np.array([getattr(g, name) for g in grasps], np.float64) if grasps
                else np.zeros((0, *shape)))

    cols: dict[str, np.ndarray] = {
        "gripper_mesh_id": np.array([g.mesh_id for g in grasps], np.int64),
        "gripper_rank": np.array([g.rank for g in grasps], np.int64),
        "gripper_name": _str_array([g.gripper for g in grasps]),
        "gripper_pose": stack("pose", (4, 4)),
        "gripper_tcp": stack("tcp", (3,)),
        "gripper_width": stack("width", ()),
        "gripper_points": stack("points", (2, 3)),
        "gripper_normals": stack("normals", (2, 3)),
    }
    for name in _GRIPPER_MEASURES:
        cols[f"gripper_{name}"] = np.array(
            [np.nan if getattr(g, name) is None else getattr(g, name) for g in grasps],
            np.float64)
    cols["gripper_sim"] = _str_array(["" if g.sim is None else canonical_json(g.sim)
                                      for g in grasps])
    cols["gripper_sim_held"] = np.array(
        [np.nan if g.sim is None or g.sim["held"] is None else float(bool(g.sim["held"]))
         for g in grasps], np.float64)
    return cols


def _write_h5(db: GraspDatabase, out: Path) -> None:
    try:
        import h5py
    except ImportError as e:
        raise InputError(
            'HDF5 export needs h5py, which is not installed: pip install "synth[h5]"'
        ) from e
    cols = export_columns(db)
    with h5py.File(out, "w") as f:
        f.attrs["format"] = _FORMAT_TAG
        f.attrs["schema_version"] = SCHEMA_VERSION
        f.attrs["params"] = json.dumps(db.params, sort_keys=True)
        f.attrs["planner"] = db.planner
        f.attrs["units"] = UNITS
        groups = {"mesh_": f.create_group("meshes"), "gripper_": f.create_group("gripper_grasps"),
                  "": f.create_group("grasps")}
        for name, arr in cols.items():
            prefix = next(p for p in groups if name.startswith(p))
            group, key = groups[prefix], name[len(prefix):]
            if arr.dtype.kind == "U":
                data: Any = arr.astype(object)
                dtype: Any = h5py.string_dtype("utf-8")
            else:
                data, dtype = arr, arr.dtype
            opts = {"chunks": True, "compression": "gzip"} if arr.size else {}
            group.create_dataset(key, data=data, dtype=dtype, **opts)


def _write_json(db: GraspDatabase, out: Path) -> None:
    by_mesh: dict[int, list[dict[str, Any]]] = {}
    formats: dict[int, str] = {}
    for fmt, grasps in (("synth.grasps", db.grasps()),
                        ("synth.gripper_grasps", db.gripper_grasps())):
        for g in grasps:
            by_mesh.setdefault(g.mesh_id, []).append(g.to_dict())
            formats[g.mesh_id] = fmt
    meshes = []
    for m in db.meshes():
        meshes.append(
            {
                "id": m.id, "path": m.path, "name": m.name, "sha256": m.sha256, "size": m.size,
                "status": m.status, "error_kind": m.error_kind, "error": m.error,
                "duplicate_of": m.duplicate_of, "units": m.units, "length": m.length,
                "synth_version": m.synth_version, "n_grasps": m.n_grasps, "report": m.report,
                "grasp_format": formats.get(m.id), "grasps": by_mesh.get(m.id, []),
            }
        )  # fmt: skip
    doc = {
        "format": _FORMAT_TAG,
        "version": 1,
        "schema_version": SCHEMA_VERSION,
        "params": db.params,
        "planner": db.planner,
        "units": UNITS,
        "meshes": meshes,
    }
    with open(out, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=1)


def export_database(
    database: str | os.PathLike[str], out: str | os.PathLike[str], fmt: str | None = None
) -> str:
    """Export every mesh and grasp of ``database`` to ``out``.

    Parameters
    ----------
    database : path
        A grasp database.
    out : path
        The file to write, under exactly this name (replaced if it exists, and only once the
        new file is complete: see :mod:`synth.files`).
    fmt : {"h5", "npz", "json"}, optional
        Default: from the extension of ``out`` (``.h5``/``.hdf5``, ``.npz``, ``.json``).

    Returns
    -------
    str
        The format written.

    Raises
    ------
    InputError
        On an unknown format, or h5py missing for ``h5``.
    DatabaseError
        If ``database`` is not a synth grasp database.

    Examples
    --------
    >>> export_database("grasps.sqlite", "grasps.h5")  # doctest: +SKIP
    'h5'
    """
    if not isinstance(out, (str, os.PathLike)):
        raise InputError(f"out: expected the export file's path, got {type(out).__name__}")
    out = os.fspath(out)
    if fmt is None:
        ext = os.path.splitext(out)[1].lower().lstrip(".")
        fmt = {"hdf5": "h5"}.get(ext, ext)
        if fmt not in EXPORT_FORMATS:
            named = f"its extension .{ext} names" if ext else "it has no extension, so it names"
            raise InputError(f"--out {out} (Python: out=): {named} no export format; name it "
                             ".h5 (or .hdf5), .npz or .json, or give --format h5, npz or json "
                             "(Python: fmt=); --format acronym, graspgen or isaac writes a "
                             "folder of files")
    if fmt not in EXPORT_FORMATS:
        raise InputError(f"--format (Python: fmt=): expected one of "
                         f"{', '.join(EXPORT_FORMATS)}, got {fmt!r}")
    ext = os.path.splitext(out)[1].lower().lstrip(".")
    if ext in EXPORT_FORMATS + ("hdf5",) and {"hdf5": "h5"}.get(ext, ext) != fmt:
        raise InputError(f"{out}: a .{ext} name for a {fmt} export; name it .{fmt}, or leave "
                         "the format to the name")
    with GraspDatabase(database) as db, _replaceable(database, out), atomic_path(out) as tmp:
        if fmt == "h5":
            _write_h5(db, tmp)
        elif fmt == "npz":
            cols: dict[str, Any] = export_columns(db)
            cols["params"] = np.array(json.dumps(db.params, sort_keys=True))
            cols["planner"] = np.array(db.planner)
            cols["units"] = np.array(UNITS)
            cols["format"] = np.array(_FORMAT_TAG)
            with open(tmp, "wb") as fh:  # a file object: numpy adds no ".npz" to the name
                np.savez_compressed(fh, **cols)
        else:
            _write_json(db, tmp)
    return fmt


@contextlib.contextmanager
def _replaceable(database: str | os.PathLike[str], out: str) -> Iterator[None]:
    """Refuse to write ``out`` over the database itself or over a file that is not one of
    synth's exports (synth replaces only its own outputs); entered once the database opened,
    so that a missing database is said first."""
    if os.path.isfile(out):
        if os.path.exists(database) and os.path.samefile(out, database):
            raise InputError(f"--out {out}: this is the database being exported; give the "
                             "export another name")
        if not _is_export(out):
            raise InputError(f"--out {out}: exists and is not an export synth wrote (synth "
                             "replaces only its own outputs); give another name or move it")
    yield


def _is_export(path: str) -> bool:
    """Whether ``path`` is an export of :func:`export_database` (JSON, HDF5 or NPZ; an NPZ
    from before the format tag by its arrays); a file that cannot be parsed is not."""
    try:
        with open(path, "rb") as f:
            head = f.read(8)
        if head.startswith(b"\x89HDF"):
            import h5py

            with h5py.File(path, "r") as h5:
                return str(h5.attrs.get("format", "")) == _FORMAT_TAG
        if head.startswith(b"PK"):
            with np.load(path, allow_pickle=False) as z:
                if "format" in z.files:
                    return str(z["format"]) == _FORMAT_TAG
                return {"params", "planner", "mesh_id", "contact_start"} <= set(z.files)
    except Exception:  # noqa: BLE001 - unreadable, damaged, odd: not an export of synth's
        return False
    return wrote_by_synth(path)
