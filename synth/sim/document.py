"""Read a ``synth.grasps`` document (what ``synth plan --out`` writes) for simulation.

A grasp file may come from another version of synth or from another tool that imitates the
format, so every field the simulation uses is checked where it enters, one by one: a bad
field raises :class:`~synth.errors.InputError` naming the file, the field (``grasps[3].fingers
.tip_centers``), what was expected and what was found. Fields the simulation does not use are
not checked, and are written back untouched.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError, shown
from synth.filetype import read_json

__all__ = ["SimGrasp", "GraspFile", "read_grasp_file", "read_json", "check_document",
           "check_jaw_document", "JAW_FORMAT", "RANKED_JAW_FORMAT", "ranking_as_jaw_document",
           "load_keywords", "jaw_gripper_source"]

#: The format and version the simulation reads (see the README's "Output file format").
FORMAT, VERSION = "synth.grasps", 1
#: synth's other JSON documents, which are no plan, in words: a score file of contact sets
#: (``synth score --out``), a ranking of contact sets (``synth rank --out``), a gripper
#: description.
_OTHER_DOCUMENTS: dict[str, str] = {
    "synth.scores": "a score file of contact sets (JSON written by synth score --out)",
    "synth.ranked": "a ranking of contact sets (JSON written by synth rank --out)",
    "synth.gripper": "a gripper description (JSON)",
}


@dataclass(frozen=True)
class SimGrasp:
    """What the simulation needs of one grasp, in the mesh file's coordinates and units.

    Attributes
    ----------
    points : (k, 3) float
        Contact points.
    normals : (k, 3) float
        Unit contact normals the grasp was scored with, pointing into the part.
    tip_centers : (f, 3) float
        Fingertip centres.
    approach : (f, 3) float
        Unit approach directions, away from the part; each finger slides along ``-approach``.
    tip_radius : float
        Fingertip radius (> 0).
    measures : dict of str to float
        The grasp's scores as written (``d_star``, ``conditioning``, ``epsilon``, and
        ``tolerance``, ``d_star_mesh``, ``d_star_smooth``, ``squeeze_per_weight`` when
        present); NaN where absent.
    contact_finger : (k,) int
        The fingertip of each contact (several contacts share one in a groove or an inside
        corner); one each when the file does not say.
    """

    points: NDArray[np.float64] = field(repr=False)
    normals: NDArray[np.float64] = field(repr=False)
    tip_centers: NDArray[np.float64] = field(repr=False)
    approach: NDArray[np.float64] = field(repr=False)
    tip_radius: float
    measures: dict[str, float] = field(default_factory=dict)
    contact_finger: NDArray[np.int64] | None = field(default=None, repr=False)


@dataclass(frozen=True)
class GraspFile:
    """A checked grasp document.

    Attributes
    ----------
    path : str
        Where it was read from (for messages).
    mesh_path : pathlib.Path
        The mesh file, resolved as :func:`synth.paths.resolve_mesh_path` does (a relative
        path is relative to the grasp file's folder).
    sha256 : str or None
        The mesh file's digest as planned.
    length : float
        The part's bounding-box diagonal, mesh units.
    center_mass : (3,) float
    volume : float
        Volume of the part's closed bodies (0 for a part of open surfaces only).
    mu : float
        Friction coefficient the grasps were planned with (0: frictionless).
    grasps : tuple of SimGrasp
    document : dict
        The whole document as read, to write back with the simulation's labels.
    load : dict
        :func:`synth.load_part` keywords that load the part the grasps were planned on
        (``mesh.load``; a file written before it was recorded: ``mesh.units`` and the
        loader's defaults).
    """

    path: str
    mesh_path: Path
    sha256: str | None
    length: float
    center_mass: NDArray[np.float64] = field(repr=False)
    volume: float
    mu: float
    grasps: tuple[SimGrasp, ...] = field(repr=False)
    document: dict[str, Any] = field(repr=False)
    load: dict[str, Any] = field(default_factory=dict)


def _where(name: str, key: str) -> str:
    return f"{name}: field {key}"


def _get(obj: Any, key: str, where: str, name: str) -> Any:
    if not isinstance(obj, dict):
        raise InputError(f"{_where(name, where)}: expected an object, got "
                         f"{type(obj).__name__}")
    if key not in obj:
        raise InputError(f"{_where(name, f'{where}.{key}' if where else key)}: missing")
    return obj[key]


def _object(doc: Any, key: str, name: str) -> dict[str, Any]:
    """``doc[key]``, which must be an object."""
    value = _get(doc, key, "", name)
    if not isinstance(value, dict):
        raise InputError(f"{_where(name, key)}: expected an object, got {shown(value)}")
    return value


def _version_1(doc: Any, name: str) -> None:
    """Refuse a document whose ``version`` is not 1."""
    version = _get(doc, "version", "", name)
    if isinstance(version, bool) or version != 1:
        raise InputError(f"{_where(name, 'version')}: expected 1, got {shown(version)} (a file "
                         "from another version of synth)")


def _number(value: Any, key: str, name: str, lo: float = -math.inf,
            lo_open: bool = False) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    try:
        ok = ok and math.isfinite(value)
    except OverflowError:  # an integer too large for a float
        ok = False
    if not ok or value < lo or (lo_open and value == lo):
        bound = "" if lo == -math.inf else f" {'>' if lo_open else '>='} {lo:g}"
        raise InputError(f"{_where(name, key)}: expected a finite number{bound}, got "
                         f"{shown(value)}")
    return float(value)


def _array(value: Any, key: str, name: str, rows: int | None = None,
           unit: bool = False) -> NDArray[np.float64]:
    want = f"({rows if rows is not None else 'n'}, 3) numbers"
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{_where(name, key)}: expected {want}, got {shown(value)}") from None
    if a.ndim != 2 or a.shape[1] != 3 or len(a) == 0 or (rows is not None and len(a) != rows):
        raise InputError(f"{_where(name, key)}: expected {want}, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise InputError(f"{_where(name, key)}: NaN or infinite values")
    if unit:
        norms = np.linalg.norm(a, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
        if len(bad):
            raise InputError(f"{_where(name, f'{key}[{bad[0]}]')}: expected a unit vector, "
                             f"got length {norms[bad[0]]:.6g}")
    return a


def _measure(g: dict[str, Any], key: str, where: str, name: str) -> float:
    value = g.get(key)
    if value is None:
        return float("nan")
    return _number(value, f"{where}.{key}", name)


def _same_count(n: int, rows: str, m: int, other: str, where: str, name: str) -> None:
    """Refuse two fields of a grasp that must be as long as each other but are not, naming
    both counts (``rows`` and ``other`` say what the rows are, ``"points"``): neither field
    alone is at fault."""
    if n != m:
        raise InputError(f"{name}: {where}: {n} {rows} but {m} {other}; expected as many "
                         f"{other} as {rows}")


def _grasp(g: Any, i: int, name: str) -> SimGrasp:
    where = f"grasps[{i}]"
    points = _array(_get(g, "points", where, name), f"{where}.points", name)
    k = len(points)
    normals = _array(_get(g, "normals", where, name), f"{where}.normals", name, unit=True)
    _same_count(k, "points", len(normals), "normals", where, name)
    fingers = _get(g, "fingers", where, name)
    fw = f"{where}.fingers"
    centers = _array(_get(fingers, "tip_centers", fw, name), f"{fw}.tip_centers", name)
    approach = _array(_get(fingers, "approach", fw, name), f"{fw}.approach", name,
                      unit=True)
    _same_count(len(centers), "fingers.tip_centers", len(approach), "fingers.approach rows",
                where, name)
    radius = _number(_get(fingers, "tip_radius", fw, name), f"{fw}.tip_radius", name, 0.0,
                     lo_open=True)
    measures = {key: _measure(g, key, where, name) for key in
                ("d_star", "conditioning", "epsilon", "tolerance", "d_star_mesh",
                 "d_star_smooth", "squeeze_per_weight")}
    owner = fingers.get("contact_finger")
    if isinstance(owner, list) and len(owner) != k:
        _same_count(k, "points", len(owner), "fingers.contact_finger entries", where, name)
    if owner is None:
        if len(centers) != k:
            raise InputError(f"{_where(name, f'{fw}.contact_finger')}: missing, and there are "
                             f"{len(centers)} fingertips for {k} contacts")
        owner = np.arange(k)
    try:
        cf = np.asarray(owner)
        ok = cf.shape == (k,) and cf.dtype.kind in "iu" and cf.min() >= 0 \
            and cf.max() < len(centers)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(f"{_where(name, f'{fw}.contact_finger')}: expected {k} fingertip "
                         f"indices from 0 to {len(centers) - 1}, got {shown(owner)}")
    return SimGrasp(points, normals, centers, approach, radius, measures,
                    np.asarray(owner, np.int64))


def _mesh_path(text: Any, name: str) -> Path:
    """The mesh file of ``mesh.path`` (:func:`synth.paths.resolve_mesh_path`: relative to the
    grasp file's folder; ``name`` in angle brackets is no file)."""
    from synth.paths import resolve_mesh_path

    return resolve_mesh_path(text, None if name.startswith("<") else name)


def check_document(doc: Any, name: str = "<document>") -> GraspFile:
    """Check a parsed grasp document field by field and return what the simulation needs.

    Parameters
    ----------
    doc : object
        The parsed JSON.
    name : str
        The file's name, for messages.

    Returns
    -------
    GraspFile

    Raises
    ------
    InputError
        A field is missing or of the wrong type, shape or range; the message names it.

    Examples
    --------
    >>> check_document({"format": "other"}, "g.json")  # doctest: +SKIP
    synth.errors.InputError: g.json: field format: expected 'synth.grasps', got 'other'
    """
    if isinstance(doc, list):  # the candidate files of synth rank and synth score are lists
        raise InputError(f"{name}: a list of candidates (for synth rank or synth score), not a "
                         "plan; synth sim takes a grasp file written by synth plan --out")
    if not isinstance(doc, dict):
        raise InputError(f"{name}: expected a synth.grasps JSON object, got "
                         f"{type(doc).__name__}")
    _check_name(name, None)
    fmt = _get(doc, "format", "", name)
    if fmt == "synth.gripper_grasps":
        raise InputError(f"{name}: a gripper grasp file: simulate it with synth sim "
                         "GRASPS.json --mesh PART (check_jaw_document reads it)")
    if fmt == RANKED_JAW_FORMAT:
        raise InputError(f"{name}: a ranking of gripper poses (JSON written by synth rank "
                         "--gripper --out), not a point-finger plan: synth sim FILE simulates "
                         "it (Python: ranking_as_jaw_document reads it)")
    if isinstance(fmt, str) and fmt in _OTHER_DOCUMENTS:
        # another of synth's files, named as what it is (docs/vocabulary.md)
        raise InputError(f"{name}: {_OTHER_DOCUMENTS[fmt]}, not a plan; synth sim takes a "
                         "grasp file written by synth plan --out (point fingers or "
                         "--gripper) or a ranking of gripper poses written by synth rank "
                         "--gripper --out")
    if fmt != FORMAT:
        raise InputError(f"{_where(name, 'format')}: expected {FORMAT!r}, got {shown(fmt)} "
                         "(write grasp files with 'synth plan --out')")
    version = _get(doc, "version", "", name)
    if version != VERSION:
        raise InputError(f"{_where(name, 'version')}: expected {VERSION}, got "
                         f"{shown(version)} (a file from another version of synth)")
    mesh = _get(doc, "mesh", "", name)
    mesh_path = _mesh_path(_get(mesh, "path", "mesh", name), name)
    sha = mesh.get("sha256")
    if sha is not None and not isinstance(sha, str):
        raise InputError(f"{_where(name, 'mesh.sha256')}: expected a hex digest or null, got "
                         f"{shown(sha)}")
    length = _number(_get(mesh, "length", "mesh", name), "mesh.length", name, 0.0, True)
    com = np.asarray(_array([_get(mesh, "center_mass", "mesh", name)], "mesh.center_mass",
                            name, 1)[0])
    volume = _number(_get(mesh, "volume", "mesh", name), "mesh.volume", name, 0.0)
    params = _get(doc, "params", "", name)
    mu = _number(_get(params, "mu", "params", name), "params.mu", name, 0.0)
    grasps = _get(doc, "grasps", "", name)
    if not isinstance(grasps, list):
        raise InputError(f"{_where(name, 'grasps')}: expected a list, got "
                         f"{type(grasps).__name__}")
    return GraspFile(name, mesh_path, sha, length, com, volume, mu,
                     tuple(_grasp(g, i, name) for i, g in enumerate(grasps)), doc,
                     load_keywords(mesh, name))


def load_keywords(mesh: dict[str, Any], name: str) -> dict[str, Any]:
    """:func:`synth.load_part` keywords from a document's ``mesh`` object (its ``load``,
    else its ``units``), checked; ``name`` names the file in errors."""
    from synth.part.load import length_unit
    from synth.plan import load_options

    load = mesh.get("load")
    if load is None:
        load = {"units": mesh.get("units")}
    if not isinstance(load, dict):
        raise InputError(f"{_where(name, 'mesh.load')}: expected an object, got {shown(load)}")
    units = load.get("units")
    if units is not None and (not isinstance(units, str) or length_unit(units) is None):
        raise InputError(f"{_where(name, 'mesh.load.units')}: expected a length unit or null, "
                         f"got {shown(units)}")
    body = load.get("body", "largest")
    if isinstance(body, bool) or not isinstance(body, (str, int)):
        raise InputError(f"{_where(name, 'mesh.load.body')}: expected 'largest', 'all', a name "
                         f"or an index, got {shown(body)}")
    angle = _number(load.get("sharp_angle", 30.0), "mesh.load.sharp_angle", name, 0.0, True)
    if angle >= 180:
        raise InputError(f"{_where(name, 'mesh.load.sharp_angle')}: expected degrees in "
                         f"(0, 180), got {shown(angle)}")
    decimate = load.get("decimate")
    if decimate is not None and (isinstance(decimate, bool) or not isinstance(decimate, int)
                                 or decimate < 4):
        raise InputError(f"{_where(name, 'mesh.load.decimate')}: expected a face count or "
                         f"null, got {shown(decimate)}")
    return load_options({"units": units, "body": body, "sharp_angle": angle,
                         "decimate": decimate})


JAW_FORMAT = "synth.gripper_grasps"


def _check_name(name: object, labels: object) -> None:
    """The document's name (for messages) is text; ``labels``, when given, a list of text."""
    if not isinstance(name, str):
        raise InputError(f"name: expected the document's name (text), got {name!r}")
    if labels is not None and not (isinstance(labels, list)
                                   and all(isinstance(x, str) for x in labels)):
        raise InputError(f"labels: expected a list of grasp names, got {labels!r:.80}")


def jaw_gripper_source(doc: dict[str, Any]) -> Any:
    """The gripper a gripper grasp document was planned with, as written: its
    ``gripper.source``, else its ``params.gripper`` (either may be missing or of another
    type than a dict: None then)."""
    gripper, params = doc.get("gripper"), doc.get("params")
    return (gripper.get("source") if isinstance(gripper, dict) else None) or (
        params.get("gripper") if isinstance(params, dict) else None)


def check_jaw_document(doc: Any, name: str = "<document>",
                       labels: list[str] | None = None) -> dict[str, Any]:
    """Check that a gripper grasp document (``synth.gripper_grasps``, version 1) has what
    the simulation reads: ``mesh.units`` and ``mesh.length`` (and ``mesh.body`` and
    ``mesh.sharp_angle`` where written), ``gripper.source``, ``model.mu`` (> 0: soft contacts
    need friction) and ``model.torsion``, and per grasp its ``pose`` (4 x 4), ``width``, two
    contacts (``point``, unit ``normal``) and ``measures.d_star``. ``labels`` names each
    grasp in messages (default ``grasps[i]``).

    Returns
    -------
    dict
        ``doc`` itself.

    Raises
    ------
    InputError
        A field is missing or of the wrong type, shape or range; the message names it.
    """
    _check_name(name, labels)
    fmt = _get(doc, "format", "", name)
    if fmt != JAW_FORMAT:
        raise InputError(f"{_where(name, 'format')}: expected {JAW_FORMAT!r}, got {shown(fmt)}")
    _version_1(doc, name)
    mesh = _object(doc, "mesh", name)
    source = jaw_gripper_source(doc)
    if not isinstance(source, str) or not source:
        raise InputError(f"{_where(name, 'gripper.source')}: expected the gripper's name or "
                         f"description file, got {shown(source)}")
    units = _get(mesh, "units", "mesh", name)
    from synth.part.load import length_unit

    if not isinstance(units, str) or length_unit(units) is None:
        raise InputError(f"{_where(name, 'mesh.units')}: expected a length unit, got "
                         f"{shown(units)}")
    _number(_get(mesh, "length", "mesh", name), "mesh.length", name, 0.0, True)  # checked
    body = mesh.get("body", "largest")
    if isinstance(body, bool) or not isinstance(body, (str, int)):
        raise InputError(f"{_where(name, 'mesh.body')}: expected 'largest', 'all' or a body "
                         f"index, got {shown(body)}")
    _number(mesh.get("sharp_angle", 30.0), "mesh.sharp_angle", name, 0.0)
    model = _get(doc, "model", "", name)
    from synth.limits import MAX_LENGTH, MAX_MU

    mu = _number(_get(model, "mu", "model", name), "model.mu", name, 0.0, True)
    if mu > MAX_MU:
        raise InputError(f"{_where(name, 'model.mu')}: expected at most {MAX_MU:g}, got "
                         f"{shown(mu)}")
    torsion = _number(_get(model, "torsion", "model", name), "model.torsion", name, 0.0)
    if torsion > MAX_LENGTH:  # the range of --torsion: MuJoCo's default 5 mm may exceed a
        # small part (a 1 mm cube in mm), as the plan that wrote the file allowed
        raise InputError(f"{_where(name, 'model.torsion')}: expected at most {MAX_LENGTH:g} "
                         f"(the range of --torsion), got {shown(torsion)}")
    grasps = _get(doc, "grasps", "", name)
    if not isinstance(grasps, list) or not grasps:
        raise InputError(f"{_where(name, 'grasps')}: expected a list of at least one grasp, "
                         f"got {shown(grasps)}")
    if labels is not None and len(labels) != len(grasps):
        raise InputError(f"labels: expected {len(grasps)} grasp names, one per grasp, got "
                         f"{len(labels)}")
    for i, g in enumerate(grasps):
        where = labels[i] if labels is not None else f"grasps[{i}]"
        pose = _get(g, "pose", where, name)
        try:
            T = np.asarray(pose, dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            T = np.zeros(0)
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise InputError(f"{_where(name, f'{where}.pose')}: expected a 4 x 4 matrix of "
                             f"finite numbers, got {shown(pose)}")
        _number(_get(g, "width", where, name), f"{where}.width", name, 0.0)
        contacts = _get(g, "contacts", where, name)
        if not isinstance(contacts, list) or len(contacts) != 2:
            raise InputError(f"{_where(name, f'{where}.contacts')}: expected two contacts, got "
                             f"{shown(contacts)}")
        for j, c in enumerate(contacts):
            cw = f"{where}.contacts[{j}]"
            _array([_get(c, "point", cw, name)], f"{cw}.point", name, 1)
            _array([_get(c, "normal", cw, name)], f"{cw}.normal", name, 1, unit=True)
        _number(_get(_get(g, "measures", where, name), "d_star", f"{where}.measures", name),
                f"{where}.measures.d_star", name)
    return doc


RANKED_JAW_FORMAT = "synth.ranked_gripper"


def ranking_as_jaw_document(doc: Any, name: str = "<document>") -> tuple[dict[str, Any],
                                                                         list[int]]:
    """The gripper grasp document (``synth.gripper_grasps``) of a ranking of gripper poses
    (``synth rank --gripper``, ``synth.ranked_gripper``): its candidates that landed (status
    ``ok``) as grasps, its mesh with a length unit (the pose file's object scale, as
    ``metres_per_unit``, when the mesh's unit was unknown), its gripper and contact model.

    Returns
    -------
    doc : dict
        The jaw document, checked by :func:`check_jaw_document`.
    rows : list of int
        For each of its grasps, the index of the candidate it is in ``doc["candidates"]``.

    Raises
    ------
    InputError
        The ranking is malformed, or no candidate landed.
    """
    _version_1(doc, name)
    candidates = _get(doc, "candidates", "", name)
    if not isinstance(candidates, list):
        raise InputError(f"{_where(name, 'candidates')}: expected a list, got "
                         f"{shown(candidates)}")
    rows = [i for i, c in enumerate(candidates)
            if isinstance(c, dict) and c.get("status") == "ok"]
    if not rows:
        raise InputError(f"{name}: none of its {len(candidates)} candidates landed on the part "
                         "(status ok), so there is nothing to simulate")
    mesh = dict(_object(doc, "mesh", name))
    if mesh.get("units") is None:
        scale = _number(_get(mesh, "metres_per_unit", "mesh", name), "mesh.metres_per_unit",
                        name, 0.0, True)
        mesh["units"] = "meters" if scale == 1.0 else f"{scale!r}*m"
        if isinstance(mesh.get("load"), dict):
            mesh["load"] = {**mesh["load"], "units": mesh["units"]}
    jaws = {"format": JAW_FORMAT, "version": 1, "mesh": mesh,
            "gripper": _get(doc, "gripper", "", name), "model": _get(doc, "model", "", name),
            "grasps": [candidates[i] for i in rows]}
    return check_jaw_document(jaws, name, [f"candidates[{i}]" for i in rows]), rows


def read_grasp_file(path: str | os.PathLike[str]) -> GraspFile:
    """Read and check a grasp file (see :func:`check_document`).

    Raises
    ------
    InputError
        The file is missing, not JSON, or a field is bad.
    """
    return check_document(read_json(path), str(path))
