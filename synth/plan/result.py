"""What the planner returns, and the JSON file format (``synth.grasps``, version 1).

File format
-----------
A JSON object::

    {"format": "synth.grasps", "version": 1, "synth_version": "0.1.0",
     "run_id": "20250101T120000Z-1a2b3c4d",
     "mesh": {"path", "sha256", "units", "length", "precision", "center_mass", "volume",
              "bodies": [{"name", "faces", "closed", "convex", "volume", "area",
                          "exposed_area"}], "repairs": [str], "warnings": [str],
              "dropped": [str]},
     "params": {...every PlanParams field...},
     "fingers": {tip_radius, body_length, body_radius, approach_cone, ...},
     "grasps": [  # best first
        {"rank": 1-based, "points": k x 3, "normals": k x 3 (unit, into the part; the mesh's
         own, along which the fingertips push), "smooth_normals": k x 3 (the smooth reading),
         "features": [str] * k,
         "regions": [int] * k, "d_star": float (under params.surface), "d_star_mesh": float,
         "d_star_smooth": float, "closure": str, "conditioning": float,
         "epsilon": float, "tolerance": float or null, "tolerance_ratio": float or null,
         "contact_regions": {"polygons", "kinds", "tolerance", "limited_by", "d_star_min",
                             "certified"} or null,
         "fingers": {"tip_centers": f x 3, "tip_radius", "approach": f x 3 (unit, away from
                     the part), "body_length", "body_radius", "contact_finger": [int] * k,
                     "tip_sink": float (deepest sink of a tip into the part)}}],
     "message": str, "timing": {"total_s", "evaluations", "stopped_by_time"}}

All coordinates are in the mesh file's coordinates and units. ``run_id`` names the run:
the PNG (title and ``synth.run_id`` text chunk) and the GLB (scene extras ``synth.run_id``)
drawn from the same plan carry it too, so the files of one run can be matched.
"""

from __future__ import annotations

import json
import math
import struct
import time
import uuid
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["FORMAT", "FORMAT_VERSION", "PlannedGrasp", "Plan", "describe_part", "load_record",
           "new_run_id", "scene_run_id"]

FORMAT = "synth.grasps"
FORMAT_VERSION = 1


def new_run_id() -> str:
    """A name for one planner run: UTC time to the second and 8 random hex digits.

    Examples
    --------
    >>> len(new_run_id())  # e.g. '20250101T120000Z-1a2b3c4d'
    25
    """
    return f"{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}-{uuid.uuid4().hex[:8]}"


def load_record(part: Any) -> dict[str, Any]:
    """How to load ``part`` again, for a document's ``mesh.load``: ``units``, ``body``,
    ``sharp_angle`` in degrees and ``decimate``, as :func:`synth.plan.load_options` reads
    them."""
    return {"units": part.units, "body": part.body,
            "sharp_angle": float(f"{math.degrees(part.sharp_angle):.12g}"),
            "decimate": part.decimate}


def describe_part(part: Any) -> dict[str, Any]:
    """The ``mesh`` object of a grasp file: where the part came from and what was done to it.

    Keys: ``path``, ``sha256``, ``units``, ``load`` (how to load the same part again:
    ``units``, ``body`` and ``sharp_angle`` in degrees, as :func:`synth.plan.load_options`
    reads them), ``length`` (bounding-box diagonal), ``precision``
    (rounding error of the coordinates), ``center_mass``, ``volume``, ``bodies`` (one
    summary per body: name, faces, closed, convex, volume, area, exposed_area), ``repairs``,
    ``warnings`` and ``dropped`` (bodies of the file left out, one line each).
    """
    return {
        "path": part.source,
        "sha256": part.sha256,
        "units": part.units,
        "load": load_record(part),
        "length": float(part.length),
        "precision": float(part.precision),
        "center_mass": np.asarray(part.center_mass, float).tolist(),
        "volume": float(part.volume),
        "bodies": [b.to_dict() for b in part.bodies],
        "repairs": list(part.repairs),
        "warnings": list(part.warnings),
        "dropped": list(part.dropped),
    }


def _finite(x: float) -> float | None:
    """A number for JSON: None for NaN or infinity."""
    return float(x) if math.isfinite(x) else None


@dataclass(frozen=True)
class PlannedGrasp:
    """One returned grasp.

    Attributes
    ----------
    points : (k, 3) float
    normals : (k, 3) float
        Unit, pointing into the part: the mesh's own normals, along which the fingertips push
        (:mod:`synth.scores.surface`).
    features : tuple of str
        ``"face"``, ``"edge"`` or ``"vertex"`` per contact.
    regions : (k,) int
        Face region of each contact.
    d_star : float
        d* under the surface model the grasp was planned with (``Plan.params["surface"]``).
    closure : str
        ``"form"``, ``"frictional form"``.
    conditioning : float
        ``sigma_min / sigma_max`` of the wrench matrix, moments scaled by the part's length
        (the smaller over the surface model's readings of the normals).
    epsilon : float
        Ferrari-Canny epsilon (same scaling, the smaller over the readings).
    fingers : dict
        Finger geometry: ``tip_centers``, ``tip_radius``, ``approach``, ``body_length``,
        ``body_radius`` (see :class:`synth.FingerPlacement`).
    contact_regions : synth.robust.ContactRegions or None
        Independent contact regions and placement tolerance (None when not computed).
    smooth_normals : (k, 3) float
        The smooth reading of the normals (interpolated on tessellated curved patches).
    d_star_mesh, d_star_smooth : float
        d* with ``normals`` and with ``smooth_normals``.
    squeeze_per_weight : float
        Least force each finger must be able to press with, over the part's weight, to hold
        it in every orientation (:mod:`synth.scores.hold`; the larger over the surface
        model's readings).
    hold_model : str
        The hand it is exact for: ``"stiff"`` (equal-stiffness fingers from a balanced
        squeeze) or ``"any"`` (each finger free to press with any force).
    least_squeeze : float or None
        ``squeeze_per_weight`` times the part's weight, N (None without a mass).
    margin : float or None
        The grip over the least squeeze (None without a grip and a mass).
    """

    points: NDArray[np.float64] = field(repr=False)
    normals: NDArray[np.float64] = field(repr=False)
    features: tuple[str, ...] = field(repr=False)
    regions: NDArray[np.int64] = field(repr=False)
    d_star: float
    closure: str
    conditioning: float
    epsilon: float
    fingers: dict[str, Any] = field(repr=False)
    contact_regions: Any = field(default=None, repr=False)
    smooth_normals: NDArray[np.float64] | None = field(default=None, repr=False)
    d_star_mesh: float = float("nan")
    d_star_smooth: float = float("nan")
    squeeze_per_weight: float = float("nan")
    hold_model: str = ""
    least_squeeze: float | None = None
    margin: float | None = None

    @property
    def tolerance(self) -> float:
        """Placement tolerance in the part's units (NaN when regions were not computed)."""
        r = self.contact_regions
        return float("nan") if r is None else float(r.tolerance)

    def to_dict(self) -> dict[str, Any]:
        """The grasp's JSON object (``tolerance_ratio``: tolerance over the fingertip radius)."""
        r = self.contact_regions
        tip = float(self.fingers.get("tip_radius", float("nan")))
        return {
            "points": np.asarray(self.points).tolist(),
            "normals": np.asarray(self.normals).tolist(),
            "smooth_normals": np.asarray(self.normals if self.smooth_normals is None
                                         else self.smooth_normals).tolist(),
            "features": list(self.features),
            "regions": [int(r) for r in self.regions],
            "d_star": float(self.d_star),
            "d_star_mesh": float(self.d_star_mesh),
            "d_star_smooth": float(self.d_star_smooth),
            "closure": self.closure,
            "conditioning": float(self.conditioning),
            "epsilon": float(self.epsilon),
            "squeeze_per_weight": _finite(self.squeeze_per_weight),
            "hold_model": self.hold_model or None,
            "least_squeeze": self.least_squeeze,
            "margin": self.margin,
            "tolerance": None if r is None else float(r.tolerance),
            "tolerance_ratio": None if r is None else float(r.tolerance / tip),
            "contact_regions": None if r is None else r.to_dict(),
            "fingers": self.fingers,
        }


@dataclass(frozen=True)
class Plan:
    """The planner's answer for one part.

    Attributes
    ----------
    grasps : tuple of PlannedGrasp
        Best first; empty when nothing was found.
    message : str
        A sentence for the user: what was found, or why nothing was (with the escape motion).
    mesh : dict
        ``path``, ``sha256``, ``units``, ``length``.
    params : dict
        Every planner parameter.
    fingers : dict
        The finger model used.
    evaluations : int
        Grasps scored.
    total_s : float
    stopped_by_time : bool
        True when the time cap cut the search (the result then depends on machine speed).
    escape : str or None
        For a part with no closure grasp, the motion the best candidate leaves free.
    run_id : str
        Name of the run that made the plan (:func:`new_run_id`), written into its JSON, PNG
        and GLB files.
    """

    grasps: tuple[PlannedGrasp, ...]
    message: str
    mesh: dict[str, Any]
    params: dict[str, Any]
    fingers: dict[str, Any]
    evaluations: int
    total_s: float
    stopped_by_time: bool = False
    escape: str | None = None
    run_id: str = field(default_factory=new_run_id)

    def to_json(self) -> dict[str, Any]:
        """The plan as a ``synth.grasps`` version-1 JSON document."""
        from synth import __version__

        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "synth_version": __version__,
            "run_id": self.run_id,
            "mesh": self.mesh,
            "params": self.params,
            "fingers": self.fingers,
            "grasps": [{"rank": i, **g.to_dict()} for i, g in enumerate(self.grasps, 1)],
            "message": self.message,
            "escape": self.escape,
            "timing": {
                "total_s": self.total_s,
                "evaluations": self.evaluations,
                "stopped_by_time": self.stopped_by_time,
            },
        }


#: Most bytes of a GLB's JSON chunk :func:`scene_run_id` reads (a synth scene's is a few kB).
_SCENE_JSON_MAX = 1 << 24


def scene_run_id(head: bytes) -> str | None:
    """The run id of a GLB scene synth wrote (``synth plan``'s part-and-fingers picture,
    :func:`synth.plan.export_glb`), from the file's first bytes; None for any other file.

    Parameters
    ----------
    head : bytes
        The start of the file: its 20-byte header and JSON chunk (read
        ``20 + json_length`` bytes, or the whole file).

    Examples
    --------
    >>> scene_run_id(b"solid cube") is None
    True
    """
    if len(head) < 20 or head[:4] != b"glTF":
        return None
    size, kind = struct.unpack("<I4s", head[12:20])
    if kind != b"JSON" or size > _SCENE_JSON_MAX or len(head) < 20 + size:
        return None
    try:
        doc = json.loads(head[20:20 + size])
        scene = doc["scenes"][doc.get("scene", 0)]
        run = scene["extras"]["synth"]["run_id"]
    except (ValueError, KeyError, IndexError, TypeError):
        return None
    return run if isinstance(run, str) else None

