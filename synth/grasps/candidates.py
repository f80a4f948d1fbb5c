"""Read candidate contact sets (from another planner, a learned model, a person).

Accepted files
--------------
JSON
    Either a list of candidates, or an object with a ``"candidates"`` list, or a synth plan
    file (an object with a ``"grasps"`` list). Each candidate is an object with ``points``
    (k x 3, or k x 2 for planar grasps) and ``normals`` (same shape, pointing into the part;
    normalised on reading), and optionally ``name`` (str) and ``mu`` (float).
NPZ
    Arrays ``points`` and ``normals`` of shape (B, k, 3) (or (B, k, 2)), optionally ``names``
    (B,) and ``mu`` (scalar or (B,)).

Coordinates must be finite and at most ``MAX_COORDINATE`` (1e15) in magnitude, and ``mu``
from 0 to ``MAX_MU`` (100): beyond them the closure LPs compute nothing meaningful.

:func:`read_candidate_table` keeps going past malformed candidates (each is reported by
position, name and field) and checks the others in vectorised batches;
:func:`read_candidates` stops at the first malformed one.
"""

from __future__ import annotations

import gc
import json
import os
import re
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import CandidateError, InputError, shown
from synth.filetype import CANDIDATES, Expected, require
from synth.limits import MAX_COORDINATE, MAX_MU
from synth.scores.wrench import check_contacts
from synth.tolerances import NORMAL_NORM_TOL

__all__ = ["Candidate", "CandidateGroup", "CandidateTable", "read_candidates",
           "read_candidate_table", "min_contacts"]


@dataclass(frozen=True)
class Candidate:
    """One candidate contact set.

    Attributes
    ----------
    name : str
        Given name, or ``"#i"`` (its position in the file, from 0).
    points : (k, d) float
        Contact points, d = 3 (space) or 2 (plane).
    normals : (k, d) float
        Unit inward normals.
    mu : float or None
        Friction coefficient given with the candidate, if any.
    """

    name: str
    points: NDArray[np.float64] = field(repr=False)
    normals: NDArray[np.float64] = field(repr=False)
    mu: float | None = None

    def __len__(self) -> int:
        return int(self.points.shape[0])


#: Contact sets, with what to do about gripper pose files given in their place (an ACRONYM
#: HDF5 file, an isaac_grasp YAML file): rank them with ``--gripper``.
_CANDIDATE_FILE = Expected(CANDIDATES.kinds, CANDIDATES.what, {
    **CANDIDATES.hints,
    "hdf5": "gripper poses (ACRONYM .h5) are ranked with synth rank MESH {path} --gripper "
            "NAME|FILE",
    "yaml": "gripper poses (isaac_grasp .yaml) are ranked with synth rank MESH {path} "
            "--gripper NAME|FILE"}, CANDIDATES.error)


def min_contacts(dim: int, mu: float) -> int:
    """Fewest point contacts that can hold a part: 7 in space / 4 in the plane without friction
    (Somoff; Reuleaux), 3 in space / 2 in the plane with friction."""
    if mu > 0:
        return 3 if dim == 3 else 2
    return 7 if dim == 3 else 4


@dataclass(frozen=True)
class CandidateGroup:
    """Valid candidates of one shape, as arrays.

    Attributes
    ----------
    index : (b,) int
        Positions of the candidates in the file.
    points, normals : (b, k, d) float
        Contacts and unit inward normals (NaN normals where the file gave none and none
        were required).
    """

    index: NDArray[np.int64] = field(repr=False)
    points: NDArray[np.float64] = field(repr=False)
    normals: NDArray[np.float64] = field(repr=False)


@dataclass(frozen=True)
class CandidateTable:
    """Every candidate of a file: the valid ones as arrays grouped by shape, the malformed ones
    as messages (a bad candidate does not stop the others).

    Attributes
    ----------
    source : str
        The file.
    names : tuple of str
        Name of every candidate, in file order (``"#i"`` when not given).
    mu : (B,) float
        Friction coefficient given with each candidate, NaN where none was.
    groups : tuple of CandidateGroup
    errors : tuple of (int, str)
        Position and message of every malformed candidate, in file order.
    mesh : dict or None
        The ``mesh`` object the file records when it is one of synth's documents of contact
        sets (a plan, ``synth.grasps``; a ranking, ``synth.ranked``): the mesh the
        candidates were made on (``path``, relative to the file's folder, ``sha256``,
        ``units``, ``load``), as written, unchecked; None for any other file.
    """

    source: str
    names: tuple[str, ...]
    mu: NDArray[np.float64] = field(repr=False)
    groups: tuple[CandidateGroup, ...]
    errors: tuple[tuple[int, str], ...]
    mesh: dict[str, Any] | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.names)

    def candidates(self) -> list[Candidate]:
        """The valid candidates, in file order."""
        out: dict[int, Candidate] = {}
        for g in self.groups:
            for j, i in enumerate(g.index.tolist()):
                mu = None if np.isnan(self.mu[i]) else float(self.mu[i])
                out[i] = Candidate(self.names[i], g.points[j], g.normals[j], mu)
        return [out[i] for i in sorted(out)]


def _label(where: str, index: int, name: str | None) -> str:
    if name is not None and len(name) > 40:
        name = name[:37] + "..."
    return f"{where}: candidate {index}" + (f" ({name})" if name is not None else "")


def _check_one(points: object, normals: object, label: str) -> tuple[np.ndarray, np.ndarray]:
    """The per-candidate checks, raising CandidateError with the candidate's label (naming
    the field at fault: a file without normals is never asked for them)."""
    arrays = []
    for key, value in (("points", points), ("normals", normals)):
        try:
            arrays.append(np.asarray(value, dtype=np.float64))
        except OverflowError as e:
            raise CandidateError(f"{label}: field '{key}' holds a number too large for a "
                                 f"float; coordinates must be at most {MAX_COORDINATE:g} in "
                                 "magnitude") from e
        except (TypeError, ValueError) as e:
            raise CandidateError(f"{label}: field '{key}' must be a k x 3 list of numbers, "
                                 f"got {shown(value)}") from e
    return check_contacts(arrays[0], arrays[1], name=label)


def _mu_value(value: object, label: str) -> float:
    try:
        mu = float(value)  # type: ignore[arg-type]
    except OverflowError:
        mu = np.inf  # an integer of hundreds of digits: refused below as out of range
    except (TypeError, ValueError) as e:
        raise CandidateError(f"{label}: field 'mu' must be a number, got {shown(value)}") from e
    if not 0 <= mu <= MAX_MU:
        raise CandidateError(f"{label}: field 'mu' must be a number from 0 to {MAX_MU:g}, got "
                             f"{shown(value)}")
    return mu


def _uniform(points: object, normals: object) -> tuple[np.ndarray, np.ndarray] | None:
    """Points and normals as (B, k, d) arrays when every candidate has one shape, else None."""
    try:
        P = np.asarray(points, dtype=np.float64)
        N = np.asarray(normals, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        return None
    if P.ndim != 3 or P.shape != N.shape or P.shape[2] not in (2, 3) or P.shape[1] == 0:
        return None
    return P, N


def _table(where: str, names: list[str], named: list[bool], points: Any, normals: Any,
           mu: list[object], errors: dict[int, str],
           omitted: frozenset[int] = frozenset()) -> CandidateTable:
    """Validate candidates given as lists or (B, k, d) arrays (None marks an item already in
    ``errors``); ``omitted``: the candidates whose normals the file left out (NaN here), the
    only ones whose normals may be NaN.

    Candidates of one shape are checked together as arrays; only those that fail are checked
    one by one, for their message.
    """
    B = len(names)
    mu_a = np.full(B, np.nan)
    for i, m in enumerate(mu):
        if m is not None and i not in errors:
            try:
                mu_a[i] = _mu_value(m, _label(where, i, names[i] if named[i] else None))
            except CandidateError as e:
                errors[i] = str(e)
    shapes: dict[tuple[int, ...], list[int]] = {}
    arrays: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    uniform = _uniform(points, normals) if not errors else None
    if uniform is not None:  # every candidate of one shape: no per-candidate work
        Pu, Nu = uniform
        shapes[Pu.shape[1:]] = list(range(B))
    for i in range(B) if uniform is None else ():
        if i in errors:
            continue
        try:
            P = np.asarray(points[i], dtype=np.float64)
            N = np.asarray(normals[i], dtype=np.float64)
        except (TypeError, ValueError, OverflowError):
            P = N = None  # type: ignore[assignment]
        if P is None or N is None or P.shape != N.shape or P.ndim != 2 or P.shape[1] not in \
                (2, 3) or P.shape[0] == 0:
            try:  # raises here: its checks include those above
                P, N = _check_one(points[i], normals[i],
                                  _label(where, i, names[i] if named[i] else None))
            except CandidateError as e:
                errors[i] = str(e)
                continue
        arrays[i] = (P, N)
        shapes.setdefault(P.shape, []).append(i)
    groups = []
    for idx in shapes.values():
        if uniform is not None:
            P, N = uniform
        else:
            P = np.stack([arrays[i][0] for i in idx])
            N = np.stack([arrays[i][1] for i in idx])
        placeholder = np.asarray(np.isnan(N).all(axis=(1, 2)))  # (B,) bool
        placeholder &= np.isin(np.asarray(idx), list(omitted))  # left out, not NaN in the file
        length = np.linalg.norm(N, axis=2)
        finite = np.asarray(np.isfinite(P).all(axis=(1, 2)))
        huge = finite & (np.abs(np.where(np.isfinite(P), P, 0.0)) > MAX_COORDINATE).any(
            axis=(1, 2))
        bad = huge | ~(finite & ((np.isfinite(N).all(axis=(1, 2)) &
                                  (length > NORMAL_NORM_TOL).all(axis=1)) | placeholder))
        for j in np.flatnonzero(bad):
            i = idx[j]
            label = _label(where, i, names[i] if named[i] else None)
            if huge[j]:
                errors[i] = (f"{label}: field 'points' has a coordinate of magnitude "
                             f"{np.abs(P[j]).max():.3g}, above the {MAX_COORDINATE:g} synth can "
                             "score meaningfully")
                continue
            try:
                _check_one(P[j], N[j], label)
            except CandidateError as e:
                errors[i] = str(e)
        keep = ~bad
        N = np.where(placeholder[:, None, None], N,
                     N / np.where(length > 0, length, 1.0)[..., None])
        groups.append(CandidateGroup(np.asarray(idx, np.int64)[keep], P[keep], N[keep]))
    return CandidateTable(where, tuple(names), mu_a, tuple(g for g in groups if len(g.index)),
                          tuple(sorted(errors.items())))


@contextmanager
def _collector_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector while a large parsed document is built and
    walked. The millions of lists a 100 MB candidate file becomes hold no cycles, yet every
    700 allocations trigger a collection that rescans them: about 1 s of a 1.5 s parse."""
    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_on:
            gc.enable()


def parse_json(raw: bytes) -> Any:
    """A JSON document from UTF-8 bytes: with orjson when it is installed (the ``fast`` extra;
    about twice as fast on a 100 MB candidate file), else the standard library. Whatever
    orjson refuses (NaN, integers beyond 64 bits, nesting deeper than 1,024, bad UTF-8) goes to
    the standard library, so values and error messages are the same either way."""
    try:
        import orjson
    except ImportError:
        return json.loads(raw.decode("utf-8"))
    try:
        return orjson.loads(raw)
    except orjson.JSONDecodeError:
        return json.loads(raw.decode("utf-8"))


def parse_json_file(path: str | Path, what: str) -> Any:
    """The JSON document of a file (:func:`parse_json`), every failure one plain line.

    Parameters
    ----------
    path : path
    what : str
        What the file should be, for the messages (``"a candidate file (JSON or NPZ)"``).

    Raises
    ------
    InputError
        The file cannot be read, is not UTF-8 text, is not JSON, holds an integer of more
        digits than Python converts (``sys.get_int_max_str_digits``), or nests too deep.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except IsADirectoryError:
        raise InputError(f"{p}: a folder, not {what}") from None
    except FileNotFoundError:
        raise InputError(f"{p}: no such file") from None
    except OSError as e:
        raise InputError(f"{p}: cannot be read ({e.strerror or e})") from None
    try:
        return parse_json(raw)
    except json.JSONDecodeError as e:
        raise InputError(f"{p}: not a readable JSON file ({e.msg} at line {e.lineno}), so not "
                         f"{what}") from None
    except UnicodeDecodeError:
        raise InputError(f"{p}: not a readable JSON file (not UTF-8 text), so not "
                         f"{what}") from None
    except RecursionError:
        raise InputError(f"{p}: not a readable JSON file (RecursionError: arrays or objects "
                         "nested too deep to read)") from None
    except ValueError:
        # the one other ValueError of json.loads: an integer literal of more digits than
        # Python converts to a number
        digits = max((len(m) for m in re.findall(rb"\d+", raw)), default=0)
        raise InputError(f"{p}: not a readable JSON file: it holds a number too long to read "
                         f"({digits} digits; at most {sys.get_int_max_str_digits() or digits} "
                         "are read)") from None


#: synth's documents of contact sets that record the mesh they were made on (``mesh``).
_RECORDING_MESH = ("synth.grasps", "synth.ranked")
#: Fields of a gripper pose (``synth plan --gripper``, ``synth rank --gripper``, GraspGen,
#: pose arrays): what tells a pose file given where contact sets belong.
_POSE_FIELDS = ("pose", "poses", "transform", "transforms")
#: The message's end for gripper poses given where contact sets belong.
_POSES_HINT = ("gripper poses (4 x 4 'pose' matrices), not contact sets with 'points'; rank "
               "them with synth rank MESH {path} --gripper NAME")


def _is_pose(obj: Any) -> bool:
    """Whether a candidate entry is a gripper pose: an object with a pose field and no
    'points', or a bare 4 x 4 matrix."""
    if isinstance(obj, dict):
        return "points" not in obj and any(k in obj for k in _POSE_FIELDS)
    if isinstance(obj, list) and len(obj) == 4:
        return all(isinstance(row, list) and len(row) == 4 for row in obj)
    return False


def _holds_poses(doc: Any) -> bool:
    """Whether a parsed JSON document is a file of gripper poses (synth's gripper grasp or
    ranked pose files, GraspGen's, a list or an object of 4 x 4 poses) and no contact set."""
    if isinstance(doc, dict):
        if doc.get("format") in ("synth.gripper_grasps", "synth.ranked_gripper"):
            return True
        grasps = doc.get("grasps")
        if isinstance(grasps, dict) and "transforms" in grasps:  # GraspGen
            return True
        if "candidates" not in doc and not isinstance(grasps, list):
            return any(k in doc for k in _POSE_FIELDS)
        doc = doc.get("candidates", grasps)
    return isinstance(doc, list) and bool(doc) and all(_is_pose(obj) for obj in doc)


def read_candidate_table(path: str | Path, *, require_normals: bool = True) -> CandidateTable:
    """Read every candidate of a JSON or NPZ file, keeping the malformed ones as messages.

    Parameters
    ----------
    path : str or Path
    require_normals : bool
        When False, candidates may omit ``normals`` (JSON only); they come back as NaN.

    Returns
    -------
    CandidateTable

    Raises
    ------
    InputError
        The file is missing or unreadable, or is not JSON / NPZ of the documented layout
        (no candidate can be read at all).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"path: expected a candidate file's path, got {type(path).__name__}")
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p}: a folder, not {CANDIDATES.what}")
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    require(p, _CANDIDATE_FILE)  # a mesh, a database, gripper poses: named as such
    if p.suffix.lower() == ".npz":
        return _read_npz(p)
    with _collector_paused():
        return _read_json(p, require_normals)


def _read_json(p: Path, require_normals: bool) -> CandidateTable:
    where = str(p)
    data = parse_json_file(p, CANDIDATES.what)
    if _holds_poses(data):
        raise InputError(f"{p}: holds " + _POSES_HINT.format(path=p))
    wanted = "'points' and 'normals'" if require_normals else "'points'"
    planned_mu = None  # a plan's friction (its params), for grasps that do not give their own
    mesh = None  # the mesh a synth plan or ranking records
    if isinstance(data, dict):
        if data.get("format") in _RECORDING_MESH and isinstance(data.get("mesh"), dict):
            mesh = data["mesh"]
        params = data.get("params")
        if isinstance(params, dict) and isinstance(params.get("mu"), (int, float)) \
                and not isinstance(params.get("mu"), bool):
            planned_mu = float(params["mu"])
        for key in ("candidates", "grasps"):
            if key in data:
                data = data[key]
                break
        else:
            raise InputError(f"{p}: expected a list of candidates or a 'candidates' list")
    if not isinstance(data, list):
        raise InputError(f"{p}: expected a list of candidates")
    if not data:
        raise InputError(f"{p}: holds no candidates")
    errors: dict[int, str] = {}
    names, named, pts, nrm, mus = [], [], [], [], []
    omitted: set[int] = set()
    for i, obj in enumerate(data):
        ok = isinstance(obj, dict)
        has_name = ok and "name" in obj
        # a synth plan file's grasps are known by their 1-based rank
        names.append(str(obj["name"]) if has_name else
                     f"#{obj['rank']}" if ok and isinstance(obj.get("rank"), int) else f"#{i}")
        named.append(has_name)
        label = _label(where, i, names[i] if has_name else None)
        if _is_pose(obj):
            errors[i] = f"{label}: a gripper pose, not a contact set with {wanted}; rank " \
                "gripper poses with --gripper NAME"
        elif not ok:
            errors[i] = f"{label}: expected an object with {wanted}, got {shown(obj)}"
        elif "points" not in obj:
            errors[i] = f"{label}: missing field 'points'"
        elif "normals" not in obj and require_normals:
            errors[i] = f"{label}: missing field 'normals'"
        pts.append(obj.get("points") if ok else None)
        nrm.append(obj.get("normals", None) if ok else None)
        if ok and "normals" not in obj and "points" in obj and not require_normals:
            omitted.add(i)
            try:
                nrm[-1] = np.full(np.shape(obj["points"]), np.nan)
            except (TypeError, ValueError):
                nrm[-1] = None
        mus.append(obj.get("mu", planned_mu) if ok else None)
    table = _table(where, names, named, pts, nrm, mus, errors, frozenset(omitted))
    return table if mesh is None else replace(table, mesh=mesh)


def read_candidates(path: str | Path, *, require_normals: bool = True) -> list[Candidate]:
    """Read and validate every candidate of a JSON or NPZ file.

    Parameters
    ----------
    path : str or Path
    require_normals : bool
        When False, candidates may omit ``normals`` (JSON only); they come back as NaN.

    Returns
    -------
    list of Candidate

    Raises
    ------
    InputError
        The file is missing or unreadable, or is not JSON / NPZ of the documented layout.
    CandidateError
        A candidate is malformed (its index, name and field are named; the first one).
    """
    table = read_candidate_table(path, require_normals=require_normals)
    if table.errors:
        raise CandidateError(table.errors[0][1])
    return table.candidates()


def _read_npz(p: Path) -> CandidateTable:
    from synth.formats.arrays import load_npz

    arrays = load_npz(p, "'points', 'normals'[, 'names', 'mu']")
    if "points" not in arrays and any(k in arrays for k in _POSE_FIELDS):
        raise InputError(f"{p}: holds " + _POSES_HINT.format(path=p))
    for key in ("points", "normals"):
        if key not in arrays:
            raise CandidateError(f"{p}: missing array '{key}'")
    P, N = arrays["points"], arrays["normals"]
    if P.ndim != 3 or P.shape[2] not in (2, 3) or P.shape[1] == 0 or P.dtype.kind not in "iuf":
        raise CandidateError(f"{p}: array 'points' must be numbers of shape (B, k, 3), got "
                             f"{P.shape} {P.dtype}")
    if N.shape != P.shape or N.dtype.kind not in "iuf":
        raise CandidateError(f"{p}: array 'normals' must be numbers of the shape of 'points' "
                             f"{P.shape}, got {N.shape} {N.dtype}")
    B = P.shape[0]
    if B == 0:
        raise InputError(f"{p}: holds no candidates")
    names = arrays.get("names")
    mu = arrays.get("mu")
    if names is not None and names.shape != (B,):
        raise CandidateError(f"{p}: array 'names' must have shape ({B},) like the candidates, "
                             f"got {names.shape}")
    if mu is not None and mu.shape not in ((), (B,)):
        raise CandidateError(f"{p}: array 'mu' must be one number or shape ({B},), got "
                             f"{mu.shape}")
    named = names is not None
    name_list = [str(x) for x in names] if names is not None else [f"#{i}" for i in range(B)]
    mu_list: list[object] = [None] * B if mu is None else (
        [mu.item()] * B if mu.ndim == 0 else mu.tolist())
    return _table(str(p), name_list, [named] * B, P.astype(np.float64), N.astype(np.float64),
                  mu_list, {})
