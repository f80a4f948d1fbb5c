"""synth: mesh-based grasp synthesis ranked by Trinkle's quantitative form-closure measure d*."""

from __future__ import annotations

from synth.errors import (
    CandidateError,
    DatabaseError,
    InputError,
    MeshError,
    SolverError,
    SynthError,
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
]
