"""synth: mesh-based grasp synthesis ranked by Trinkle's quantitative form-closure measure d*.

Data flows mesh -> part -> contacts -> grasps -> scores -> fingers -> plan -> database; each
stage is a subpackage. The scorer implements Trinkle, "A Quantitative Test for Form Closure
Grasps", IROS 1992.
"""

from __future__ import annotations

from synth import limits  # the documented input limits (no dependencies)
from synth.errors import (
    CandidateError,
    DatabaseError,
    InputError,
    InternalError,
    MeshError,
    SolverError,
    SynthError,
)
from synth.lazy import lazy_attributes

# Everything past the exception tree is imported on first use (PEP 562), so that a command
# that needs no mesh (``synth score``, ``synth --help``) does not pay for trimesh and FCL.
_LAZY: dict[str, str] = {
    **dict.fromkeys(["Contacts", "contacts_from_rays", "sample_contacts"], "synth.contacts"),
    **dict.fromkeys(["GraspDatabase", "build_database"], "synth.database"),
    **dict.fromkeys(["FingerCheck", "FingerChecker", "FingerPlacement", "Fingers",
                     "check_fingers", "default_fingers", "finger_placement"], "synth.fingers"),
    **dict.fromkeys(["Gripper", "load_gripper"], "synth.fingers.gripper"),
    **dict.fromkeys(["GripperParams", "GripperPlan", "plan_gripper"], "synth.plan.gripper"),
    **dict.fromkeys(["Candidate", "read_candidates"], "synth.grasps"),
    **dict.fromkeys(["Part", "Region", "load_part"], "synth.part"),
    **dict.fromkeys(["Plan", "PlannedGrasp", "PlanParams", "plan_mesh_file", "plan_part"],
                    "synth.plan"),
    **dict.fromkeys(["BatchScores", "FormClosure", "FrictionalFormClosure",
                     "FrictionalSqueeze", "StrongForceClosure", "describe_twist",
                     "form_closure", "form_closure_batch", "friction_cone_wrenches",
                     "frictional_form_closure", "frictional_form_closure_batch",
                     "frictional_squeezable", "squeezable_contacts", "strong_force_closure",
                     "wrench_matrix", "GravityHold", "MuMin", "gravity_hold_batch", "mu_min",
                     "mu_min_batch"], "synth.scores"),
    **dict.fromkeys(["conditioning", "epsilon_quality"], "synth.scores.quality"),
    **dict.fromkeys(["ContactRegions", "contact_regions", "certify_regions"], "synth.robust"),
}


__getattr__ = lazy_attributes(__name__, _LAZY)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__version__ = "0.1.0"

__all__ = [
    "__version__",
    "limits",
    "SynthError",
    "InputError",
    "InternalError",
    "MeshError",
    "CandidateError",
    "SolverError",
    "DatabaseError",
    # mesh -> part
    "load_part",
    "Part",
    "Region",
    # part -> contacts
    "Contacts",
    "sample_contacts",
    "contacts_from_rays",
    # contacts -> grasps
    "Candidate",
    "read_candidates",
    # grasps -> scores
    "BatchScores",
    "FormClosure",
    "FrictionalFormClosure",
    "FrictionalSqueeze",
    "StrongForceClosure",
    "describe_twist",
    "form_closure",
    "form_closure_batch",
    "friction_cone_wrenches",
    "frictional_form_closure",
    "frictional_form_closure_batch",
    "frictional_squeezable",
    "squeezable_contacts",
    "strong_force_closure",
    "wrench_matrix",
    "conditioning",
    "epsilon_quality",
    "GravityHold",
    "MuMin",
    "gravity_hold_batch",
    "mu_min",
    "mu_min_batch",
    # scores -> robust (contact regions, placement tolerance)
    "ContactRegions",
    "contact_regions",
    "certify_regions",
    # scores -> fingers
    "Fingers",
    "FingerPlacement",
    "FingerCheck",
    "FingerChecker",
    "check_fingers",
    "default_fingers",
    "finger_placement",
    "Gripper",
    "load_gripper",
    # fingers -> plan
    "PlanParams",
    "Plan",
    "PlannedGrasp",
    "plan_part",
    "plan_mesh_file",
    "GripperParams",
    "GripperPlan",
    "plan_gripper",
    # plan -> database
    "GraspDatabase",
    "build_database",
]
