"""The one exception tree of synth.

Every error synth raises on purpose is a :class:`SynthError`. Errors caused by what a user
handed in (a file, a field, an array) are :class:`InputError`, which is also a ``ValueError``
so ordinary ``except ValueError`` code keeps working. Messages name the file or the field,
what was expected and what was found.
"""

from __future__ import annotations

__all__ = [
    "SynthError",
    "InputError",
    "MeshError",
    "CandidateError",
    "SolverError",
    "DatabaseError",
]


class SynthError(Exception):
    """Base class of every error raised by synth."""


class InputError(SynthError, ValueError):
    """An argument, array or file field is not what synth expects."""


class MeshError(InputError):
    """A mesh file cannot be turned into a usable part (missing, unreadable, not a surface)."""


class CandidateError(InputError):
    """A candidate grasp (points and normals read from a file or given by a caller) is malformed."""


class SolverError(SynthError):
    """A linear program could not be solved to a trustworthy optimum."""


class DatabaseError(SynthError):
    """A grasp database is missing, locked, of another version or not a synth database."""
