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
    MeshError,
    SolverError,
    SynthError,
)
from synth.grasps import Candidate, read_candidates
from synth.scores import (
    BatchScores,
    FormClosure,
    FrictionalFormClosure,
    StrongForceClosure,
    describe_twist,
    form_closure,
    form_closure_batch,
    friction_cone_wrenches,
    frictional_form_closure,
    squeezable_contacts,
    strong_force_closure,
    wrench_matrix,
)

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "SynthError",
    "InputError",
    "MeshError",
    "CandidateError",
    "SolverError",
    "DatabaseError",
    "Candidate",
    "read_candidates",
    "BatchScores",
    "FormClosure",
    "FrictionalFormClosure",
    "StrongForceClosure",
    "describe_twist",
    "form_closure",
    "form_closure_batch",
    "friction_cone_wrenches",
    "frictional_form_closure",
    "squeezable_contacts",
    "strong_force_closure",
    "wrench_matrix",
]
