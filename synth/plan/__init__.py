"""The planner: the best collision-free grasps of a part, ranked by d*."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from synth.plan.params import PlanParams
from synth.plan.render import export_glb, render_png
from synth.plan.result import FORMAT, FORMAT_VERSION, Plan, PlannedGrasp
from synth.plan.search import Progress, plan_part

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "Plan",
    "PlanParams",
    "PlannedGrasp",
    "Progress",
    "export_glb",
    "plan_mesh_file",
    "plan_part",
    "render_png",
]


def plan_mesh_file(path: str | Path, params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Load a mesh file and plan it; return the ``synth.grasps`` JSON document.

    This is the function ``synth db build`` calls for every mesh. ``params`` holds
    :class:`PlanParams` fields (unknown keys are refused).
    """
    from synth.part import load_part

    prm = PlanParams(**(params or {}))
    part = load_part(path)
    return plan_part(part, prm).to_json()
