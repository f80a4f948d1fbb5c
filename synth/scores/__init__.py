"""Closure scores: Trinkle's three linear programs (1992), single and batched.

Point or soft contacts; also mu_min and the least squeeze that holds a part against gravity.
"""

from synth.scores.batch import BatchScores, form_closure_batch
from synth.scores.escape import describe_twist, escape_twist
from synth.scores.form import FormClosure, form_closure
from synth.scores.friction import (
    FrictionalFormClosure,
    FrictionalSqueeze,
    friction_cone_wrenches,
    frictional_form_closure,
    frictional_squeezable,
)
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.gravity import GravityHold, gravity_hold_batch, least_squeeze_batch
from synth.scores.mu_min import MuMin, mu_min, mu_min_batch
from synth.scores.strong import StrongForceClosure, squeezable_contacts, strong_force_closure
from synth.scores.wrench import numerical_rank, wrench_matrix

__all__ = [
    "BatchScores",
    "FormClosure",
    "FrictionalFormClosure",
    "FrictionalSqueeze",
    "GravityHold",
    "MuMin",
    "StrongForceClosure",
    "describe_twist",
    "escape_twist",
    "form_closure",
    "form_closure_batch",
    "friction_cone_wrenches",
    "frictional_form_closure",
    "frictional_form_closure_batch",
    "frictional_squeezable",
    "gravity_hold_batch",
    "least_squeeze_batch",
    "mu_min",
    "mu_min_batch",
    "numerical_rank",
    "squeezable_contacts",
    "strong_force_closure",
    "wrench_matrix",
]
