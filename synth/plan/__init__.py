"""The planner: the best collision-free grasps of a part, ranked by d*."""

from __future__ import annotations

import math
import numbers
from pathlib import Path
from typing import TYPE_CHECKING, Any

from synth.errors import InputError
from synth.lazy import lazy_attributes
from synth.plan.params import PlanParams, from_dict

if TYPE_CHECKING:  # what the lazy names are, for type checkers
    from synth.plan.gripper import plan_gripper_file
    from synth.plan.render import export_glb, render_png
    from synth.plan.result import FORMAT, FORMAT_VERSION, Plan, PlannedGrasp
    from synth.plan.search import Progress, plan_part

# The search and the renderers pull in trimesh, FCL and matplotlib, the results numpy; they
# are imported on first use (PEP 562), so that reading parameters (the command line's
# ``--help``) does not pay for them.
_LAZY = {**dict.fromkeys(["FORMAT", "FORMAT_VERSION", "Plan", "PlannedGrasp"],
                         "synth.plan.result"),
         "export_glb": "synth.plan.render", "render_png": "synth.plan.render",
         "Progress": "synth.plan.search", "plan_part": "synth.plan.search",
         "plan_gripper_file": "synth.plan.gripper"}


__getattr__ = lazy_attributes(__name__, _LAZY)

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "Plan",
    "PlanParams",
    "PlannedGrasp",
    "Progress",
    "LOAD_KEYS",
    "load_options",
    "export_glb",
    "plan_mesh_file",
    "plan_gripper_file",
    "plan_part",
    "render_png",
]


#: Keys of a planner parameter dict that say how to load the mesh (:func:`synth.load_part`;
#: ``sharp_angle`` in degrees); the others are :class:`PlanParams` fields.
LOAD_KEYS = ("units", "body", "sharp_angle", "decimate")


def load_options(params: dict[str, Any]) -> dict[str, Any]:
    """:func:`synth.load_part` keywords from a parameter dict's ``LOAD_KEYS`` (absent keys:
    the defaults). ``body`` may be the text of an index (``"2"``); ``sharp_angle`` is in
    degrees."""
    if not isinstance(params, dict):
        raise InputError(f"load_options: expected a dict of parameters, got "
                         f"{type(params).__name__}")
    angle = params.get("sharp_angle", 30.0)
    if isinstance(angle, bool) or not isinstance(angle, numbers.Real):
        raise InputError(f"sharp_angle: expected degrees in (0, 180), got {angle!r}")
    body = params.get("body", "largest")
    if isinstance(body, str) and body.strip().lstrip("-").isdigit():
        body = int(body)
    return {"units": params.get("units"), "body": body,
            "sharp_angle": math.radians(float(params.get("sharp_angle", 30.0))),
            "decimate": params.get("decimate")}


def plan_mesh_file(path: str | Path, params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Load a mesh file and plan it; return the ``synth.grasps`` JSON document.

    This is the function ``synth db build`` calls for every mesh. ``params`` holds
    :class:`PlanParams` fields and the mesh options ``LOAD_KEYS`` (unknown keys are
    refused).
    """
    from synth.part import load_part
    from synth.plan.search import plan_part

    if params is not None and not isinstance(params, dict):
        raise InputError(f"plan_mesh_file: params must be a dict of parameter names, got "
                         f"{type(params).__name__}")
    given = dict(params or {})
    load = {k: given.pop(k) for k in LOAD_KEYS if k in given}
    prm = from_dict(PlanParams, given, "plan_mesh_file", LOAD_KEYS)
    part = load_part(path, **load_options(load))
    return plan_part(part, prm).to_json()
