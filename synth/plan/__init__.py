"""The planner: the best collision-free grasps of a part, ranked by d*."""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

from synth.plan.params import PlanParams
from synth.plan.result import FORMAT, FORMAT_VERSION, Plan, PlannedGrasp

# The search and the renderers pull in trimesh, FCL and matplotlib; they are imported on
# first use (PEP 562), so that reading parameters or results does not pay for them.
_LAZY = {"export_glb": "synth.plan.render", "render_png": "synth.plan.render",
         "Progress": "synth.plan.search", "plan_part": "synth.plan.search",
         "plan_gripper_file": "synth.plan.gripper"}


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'synth.plan' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "Plan",
    "PlanParams",
    "PlannedGrasp",
    "Progress",
    "export_glb",
    "plan_mesh_file",
    "plan_gripper_file",
    "plan_part",
    "render_png",
]


def plan_mesh_file(path: str | Path, params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Load a mesh file and plan it; return the ``synth.grasps`` JSON document.

    This is the function ``synth db build`` calls for every mesh. ``params`` holds
    :class:`PlanParams` fields (unknown keys are refused).
    """
    from synth.part import load_part
    from synth.plan.search import plan_part

    prm = PlanParams(**(params or {}))
    part = load_part(path)
    return plan_part(part, prm).to_json()
