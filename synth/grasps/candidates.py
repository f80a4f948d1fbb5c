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
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from synth.errors import CandidateError, InputError
from synth.scores.wrench import check_contacts

__all__ = ["Candidate", "read_candidates", "min_contacts", "parse_candidate"]


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


def min_contacts(dim: int, mu: float) -> int:
    """Fewest point contacts that can hold a part: 7 in space / 4 in the plane without friction
    (Somoff; Reuleaux), 3 in space / 2 in the plane with friction."""
    if mu > 0:
        return 3 if dim == 3 else 2
    return 7 if dim == 3 else 4


def parse_candidate(
    obj: object, index: int, *, where: str, require_normals: bool = True
) -> Candidate:
    """Validate one candidate object read from JSON.

    With ``require_normals=False`` a missing ``normals`` field is allowed (the normals are then
    resolved from a mesh, as ``synth rank`` does) and set to NaN.
    """
    label = f"{where}: candidate {index}"
    if not isinstance(obj, dict):
        raise CandidateError(f"{label}: expected an object with 'points' and 'normals'")
    name = str(obj.get("name", f"#{index}"))
    label = f"{where}: candidate {index}" + (f" ({name})" if "name" in obj else "")
    if not require_normals and "normals" not in obj and "points" in obj:
        obj = dict(obj, normals=np.ones(np.shape(obj["points"])))
        placeholder = True
    else:
        placeholder = False
    for key in ("points", "normals"):
        if key not in obj:
            raise CandidateError(f"{label}: missing field '{key}'")
    try:
        P = np.asarray(obj["points"], dtype=np.float64)
        N = np.asarray(obj["normals"], dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise CandidateError(f"{label}: 'points' and 'normals' must be numeric k x 3 lists") from e
    P, N = check_contacts(P, N, name=label)
    if placeholder:
        N = np.full_like(P, np.nan)
    mu = obj.get("mu")
    if mu is not None:
        try:
            mu = float(mu)
        except (TypeError, ValueError) as e:
            raise CandidateError(f"{label}: field 'mu' must be a number, got {mu!r}") from e
        if not np.isfinite(mu) or mu < 0:
            raise CandidateError(f"{label}: field 'mu' must be finite and >= 0, got {mu}")
    return Candidate(name, P, N, mu)


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
        A candidate is malformed (its index, name and field are named).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    if p.suffix.lower() == ".npz":
        return _read_npz(p)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"{p}: not a readable JSON file ({e})") from e
    if isinstance(data, dict):
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
    return [
        parse_candidate(obj, i, where=str(p), require_normals=require_normals)
        for i, obj in enumerate(data)
    ]


def _read_npz(p: Path) -> list[Candidate]:
    try:
        with np.load(p, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile) as e:
        raise InputError(f"{p}: not a readable NPZ file ({e})") from e
    for key in ("points", "normals"):
        if key not in arrays:
            raise CandidateError(f"{p}: missing array '{key}'")
    P, N = arrays["points"], arrays["normals"]
    if P.ndim != 3:
        raise CandidateError(f"{p}: array 'points' must have shape (B, k, 3), got {P.shape}")
    if N.shape != P.shape:
        raise CandidateError(
            f"{p}: array 'normals' has shape {N.shape} but 'points' has {P.shape}"
        )
    names = arrays.get("names")
    mu = arrays.get("mu")
    out = []
    for i in range(P.shape[0]):
        obj: dict[str, object] = {"points": P[i], "normals": N[i]}
        if names is not None:
            obj["name"] = str(names[i])
        if mu is not None:
            obj["mu"] = float(mu if np.ndim(mu) == 0 else mu[i])
        out.append(parse_candidate(obj, i, where=str(p)))
    return out
