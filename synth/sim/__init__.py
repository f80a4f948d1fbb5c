"""Physics as the judge: each grasp of a grasp file simulated in MuJoCo and labelled.

The data path: a grasp file (:mod:`~synth.sim.document`) names its mesh and how it was
loaded; the planned part's bodies become its collision shape (:mod:`~synth.sim.shape`: exact
convex pieces, and the facets of non-convex bodies near the hand); each grasp becomes a
MuJoCo scene (:mod:`~synth.sim.scene`) of the part and force-limited point fingers with the
grasp's contact model (:mod:`~synth.sim.contact`) and a hand (:mod:`~synth.sim.settings`);
the protocol (:mod:`~synth.sim.protocol`) squeezes, adds gravity, pushes and shakes; the label
(:mod:`~synth.sim.label`) says whether it held, how much, and how it moved;
:mod:`~synth.sim.plans` does all that to a plan's document. Needs the
optional extra ``synth[sim]`` (mujoco).
"""

from __future__ import annotations

import importlib
from typing import Any

#: Each public name and the module that defines it. The modules load on first use, so the
#: command line can read the settings' ranges (:mod:`synth.sim.settings`) without loading
#: trimesh, scipy or MuJoCo.
_WHERE = {
    "ContactModel": "contact",
    "GraspFile": "document", "SimGrasp": "document", "check_document": "document",
    "check_jaw_document": "document", "read_grasp_file": "document", "read_json": "document",
    "simulate_jaw_document": "jaws",
    "Escape": "label", "SimLabel": "label", "label_run": "label", "predicted_escape": "label",
    "error_label": "label",
    "PartShape": "shape", "part_shape": "shape",
    "PLAN_FORMATS": "plans", "simulate_plan": "plans", "unsimulated": "plans",
    "DIRECTIONS": "protocol", "SimRun": "protocol", "run_protocol": "protocol",
    "Scene": "scene", "build_scene": "scene",
    "SimSettings": "settings", "SIMULATOR": "settings", "HANDS": "settings",
    "SimReport": "simulate", "check_mesh": "simulate", "labelled_document": "simulate",
    "require_sim": "simulate", "simulate_file": "simulate",
    "load_planned_part": "simulate", "balanced_preload": "simulate",
}  # fmt: skip

__all__ = list(_WHERE)


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f"module 'synth.sim' has no attribute {name!r}")
    return getattr(importlib.import_module(f"synth.sim.{_WHERE[name]}"), name)


def __dir__() -> list[str]:
    return sorted(__all__)
