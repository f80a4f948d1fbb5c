"""Checks of command-line values, made before any file is read or written.

Every numeric option is checked against its documented range (the limits of
:mod:`synth.limits`), and every output path for its suffix and its folder, so a bad
command line fails at once with one line naming the option, instead of after a long search or
with a file half written.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

from synth.errors import OptionError, OutputError, shown
from synth.files import wrote_by_synth

__all__ = ["integer", "real", "output_path", "given", "GIVEN"]

#: The namespace attribute where the parser records the options the command line gave.
GIVEN = "_given"


def given(args: object, dest: str) -> bool:
    """Whether the command line gave the option stored in ``dest`` (even at its default
    value: a default the user typed beside an option that excludes it is refused too)."""
    return dest in getattr(args, GIVEN, ())


def integer(option: str, value: int | None, lo: int, hi: int | None = None,
            hi_text: str | None = None) -> None:
    """Refuse an integer option outside ``lo..hi`` (``hi`` None: no upper bound; a value of
    None, an option not given, passes); ``hi_text`` writes ``hi`` in the message.

    Examples
    --------
    >>> integer("--contacts", 1000, 2, 64)
    Traceback (most recent call last):
    synth.errors.OptionError: --contacts: expected an integer from 2 to 64, got 1000
    """
    if value is None or (lo <= value and (hi is None or value <= hi)):
        return
    expected = f"an integer >= {lo}" if hi is None else \
        f"an integer from {lo:,} to {hi_text or format(hi, ',')}"
    raise OptionError(f"{option}: expected {expected}, got {shown(value)}")


def real(option: str, value: float | None, lo: float, hi: float, *, open_lo: bool = False,
         open_hi: bool = False, unit: str = "") -> None:
    """Refuse a number option that is not finite or lies outside the interval from ``lo`` to
    ``hi`` (closed unless ``open_lo`` / ``open_hi``); None, an option not given, passes.

    Examples
    --------
    >>> real("--min-d-star", float("nan"), 0, 1)
    Traceback (most recent call last):
    synth.errors.OptionError: --min-d-star: expected a number in [0, 1], got nan
    """
    if value is None:
        return
    above = value > lo if open_lo else value >= lo
    below = value < hi if open_hi else value <= hi
    if math.isfinite(value) and above and below:
        return
    interval = f"{'(' if open_lo else '['}{lo:g}, {hi:g}{')' if open_hi else ']'}"
    raise OptionError(f"{option}: expected a number in {interval}{unit}, got {shown(value)}")


def output_path(option: str, path: str | os.PathLike[str], suffix: str,
                inputs: Sequence[str | os.PathLike[str] | None] = (),
                in_place: bool = False) -> Path:
    """An output file named on the command line, checked before any work is done.

    synth replaces only files it wrote itself: an output may not be one of the command's
    input files, nor an existing file that is not one of synth's outputs (a JSON document
    whose ``format`` is synth's, a PNG or GLB carrying a synth run id).

    Parameters
    ----------
    option : str
        The option that named it, for the message.
    path : str or path
    suffix : str
        The suffix its format needs, such as ``".png"`` (any letter case).
    inputs : sequence of str or path
        The files the command reads (None entries are skipped).
    in_place : bool
        The file is the document the command read and writes back (``synth sim``'s labels):
        replaced whatever its first bytes.

    Returns
    -------
    Path

    Raises
    ------
    OptionError
        The name has another suffix, is one of ``inputs``, or is a file synth did not write.
    OutputError
        Its folder does not exist or cannot be written, or the name is a folder.
    """
    out = Path(path)
    if "\0" in str(out) or out.suffix.lower() != suffix:
        raise OptionError(f"{option}: expected a file name ending in {suffix}, got "
                         f"{shown(str(out), 80)}")
    if out.is_file():
        for given in inputs:
            if given is not None and Path(given).exists() and os.path.samefile(out, given):
                raise OptionError(f"{option}: {out} is also an input of this command; give "
                                  "the output another name")
        if not in_place and not wrote_by_synth(out):
            raise OptionError(f"{option}: {out} exists and synth did not write it (synth "
                              "replaces only its own outputs); give another name or move it")
    folder = out.parent
    if not folder.is_dir():
        raise OutputError(f"{out}: cannot write here (no such folder {str(folder)!r})")
    if out.is_dir():
        raise OutputError(f"{out}: cannot write here (it is a folder)")
    if not os.access(folder, os.W_OK):
        raise OutputError(f"{out}: cannot write here (no permission to write in "
                          f"{str(folder)!r})")
    return out

