"""synth: mesh-based grasp synthesis ranked by Trinkle's quantitative form-closure measure d*.

Data flows mesh -> part -> contacts -> grasps -> scores -> fingers -> plan -> database; each
stage is a subpackage. The scorer implements Trinkle, "A Quantitative Test for Form Closure
Grasps", IROS 1992.
"""

from __future__ import annotations

from synth.errors import (
    CandidateError,
    DatabaseError,
    InputError,
    InternalError,
    MeshError,
    SolverError,
    SynthError,
)
from synth.contacts import Contacts, contacts_from_rays, sample_contacts
from synth.database import GraspDatabase, build_database
from synth.fingers import (
    FingerCheck,
    FingerChecker,
    FingerPlacement,
    Fingers,
    check_fingers,
    default_fingers,
    finger_placement,
)
from synth.grasps import Candidate, read_candidates
from synth.part import Part, Region, load_part
from synth.plan import Plan, PlannedGrasp, PlanParams, plan_mesh_file, plan_part
from synth.scores import (
    BatchScores,
    FormClosure,
    FrictionalFormClosure,
    FrictionalSqueeze,
    StrongForceClosure,
    describe_twist,
    form_closure,
    form_closure_batch,
    friction_cone_wrenches,
    frictional_form_closure,
    frictional_form_closure_batch,
    frictional_squeezable,
    squeezable_contacts,
    strong_force_closure,
    wrench_matrix,
)
from synth.scores.quality import conditioning, epsilon_quality

__version__ = "0.1.0"

__all__ = [
    "__version__",
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
    # scores -> fingers
    "Fingers",
    "FingerPlacement",
    "FingerCheck",
    "FingerChecker",
    "check_fingers",
    "default_fingers",
    "finger_placement",
    # fingers -> plan
    "PlanParams",
    "Plan",
    "PlannedGrasp",
    "plan_part",
    "plan_mesh_file",
    # plan -> database
    "GraspDatabase",
    "build_database",
]
