"""The one exception tree of synth.

Every error synth raises on purpose is a :class:`SynthError`. Errors caused by what a user
handed in (a file, a field, an array) are :class:`InputError`, which is also a ``ValueError``
so ordinary ``except ValueError`` code keeps working. Messages name the file or the field,
what was expected and what was found. A failure of synth itself (a broken internal promise,
such as the planner's own contacts being refused by its own part model) is an
:class:`InternalError`: a bug to report, never the user's fault.
"""

from __future__ import annotations

__all__ = [
    "SynthError",
    "InputError",
    "OptionError",
    "MeshError",
    "CandidateError",
    "SolverError",
    "DatabaseError",
    "DatabaseFileError",
    "OutputError",
    "SimulationError",
    "InternalError",
    "shown",
]


class SynthError(Exception):
    """Base class of every error raised by synth."""


class InputError(SynthError, ValueError):
    """An argument, array or file field is not what synth expects."""


class OptionError(InputError):
    """A command-line option's value is outside its documented range or of the wrong form."""


class MeshError(InputError):
    """A mesh file cannot be turned into a usable part (missing, unreadable, not a surface)."""


class CandidateError(InputError):
    """A candidate grasp (points and normals read from a file or given by a caller) is malformed."""


class SolverError(SynthError):
    """A linear program could not be solved to a trustworthy optimum."""


class DatabaseError(SynthError):
    """A grasp database is missing, locked, of another version or not a synth database."""


class DatabaseFileError(DatabaseError, InputError):
    """The file named as a grasp database cannot be used as one: it does not exist, is a
    folder, is not a synth database or is damaged, is of a newer schema, or was built with
    other parameters than those asked. Bad input (exit status 2), unlike a database that is
    busy or cannot be read or written, which the system refused (1)."""


class OutputError(SynthError):
    """A result could not be written (no such folder, no permission, disk full); the file it
    was to replace is left as it was."""


class SimulationError(SynthError):
    """The simulator could not build or run a grasp's scene (a convex decomposition, a MuJoCo
    compile): synth's own failure, recorded in that grasp's ``sim`` label with its reason,
    never blamed on the input and never a reason to discard a plan."""


class InternalError(SynthError):
    """synth failed on input it accepted: a bug in synth, not a problem with the input."""


def shown(value: object, width: int = 40) -> str:
    """``repr(value)`` cut to ``width`` characters, for error messages (a 400-digit number
    must not make the line unreadable).

    Examples
    --------
    >>> shown(10**50, width=12)
    '100000000...'
    """
    text = repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."
