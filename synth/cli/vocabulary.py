"""The words every command shares, defined once (the table is ``docs/vocabulary.md``).

``--quiet``, ``--json``, ``--out`` and ``--top`` mean one thing in every command that takes
them, and every ``--help`` ends with the exit statuses:

* ``--quiet``: results and errors only; no progress bar, no loading notes, no tallies of
  candidates by status, no list of files written: each command's help says which of these it
  has (:data:`QUIET_HELPS`).
* ``--json``: the result as one JSON document on stdout instead of the table (the document
  ``--out`` writes, where there is one); it implies ``--quiet`` where the command has one.
* ``--out FILE``: the result written to FILE, checked before any work and written whole or
  not at all; the table is printed too, and a ``wrote FILE`` line unless ``--quiet``.
* ``--top N``: the N best. Where the command finds them (``plan``, ``db build``) it keeps N,
  1 to :data:`synth.limits.MAX_TOP`; where it lists what it was given or has stored
  (``rank``, ``score``, ``db top``) it prints N rows, 0 for all (``--out`` and ``--json``
  hold every row of ``rank`` and ``score``).
"""

from __future__ import annotations

import argparse
from typing import Any

from synth.cli.checks import integer
from synth.limits import MAX_TOP

__all__ = ["DEFAULT_ROWS", "QUIET_HELP", "QUIET_HELPS", "add_quiet", "add_json", "add_out",
           "top_help", "add_top", "check_top", "exit_epilog"]

#: Rows ``synth rank`` and ``synth score`` print when ``--top`` is not given.
DEFAULT_ROWS = 20
#: What ``--quiet`` does in ``synth plan`` (point fingers and ``--gripper``).
QUIET_HELP = ("print the results and errors only (the table of grasps and its summary line): "
              "no progress bar, no loading notes, no list of files written")
#: What ``--quiet`` does in each command that takes it: one meaning (results and errors
#: only), and what the command has to silence, exactly (read from each command's code).
QUIET_HELPS: dict[str, str] = {
    "plan": QUIET_HELP,
    "rank": "print the results and errors only (the table of candidates): no loading notes "
            "(a dropped body is still said), no notes of the unit or mass taken from the "
            "candidate file or of how gripper poses were brought to the mesh, no tally of "
            "candidates by status, no 'wrote FILE' line",
    "score": "print the results and errors only (the table of candidates): no count of "
             "candidates scored, no 'wrote FILE' line",
    "sim": "print the results and errors only (the table of grasps and its summary line): no "
           "progress bar, no 'wrote FILE' line",
    "db build": "print errors only: no progress bar, no summary of the meshes planned and the "
                "grasps stored",
    "db export": "print errors only: no line naming the files written",
}


def add_quiet(p: argparse.ArgumentParser | Any, command: str = "plan") -> None:
    """``--quiet`` of ``command`` (see :data:`QUIET_HELPS`)."""
    p.add_argument("--quiet", action="store_true", help=QUIET_HELPS[command])


def add_json(p: argparse.ArgumentParser | Any, what: str, out: bool = True,
             quiet: bool = True) -> None:
    """``--json``: print ``what`` as JSON instead of the table; ``out``: the command has an
    ``--out`` that writes the same document; ``quiet``: it has a ``--quiet``, which
    :func:`synth.cli.main` makes ``--json`` imply (the help says so only then)."""
    p.add_argument("--json", action="store_true",
                   help=f"print {what} as one JSON document instead of the table"
                   + (" (the document --out writes)" if out else "")
                   + ("; implies --quiet" if quiet else ""))


def add_out(p: argparse.ArgumentParser | Any, what: str, default: str | None = None,
            suffix: str = ".json", metavar: str = "JSON") -> None:
    """``--out``: the file the result is written to, ending in ``suffix``."""
    p.add_argument("--out", default=None, metavar=metavar,
                   help=f"write {what} to this file, ending in {suffix}, whole or not at all"
                   + (f" (default: {default})" if default else "") + "; the table is "
                   "printed too")


def top_help(what: str, default: int, listing: bool, note: str = "") -> str:
    """The help of ``--top``: ``listing`` commands print the best N rows of what they were
    given or have stored (0 for all); the others keep the best N they find. ``note``: more
    words, after a semicolon."""
    if listing:
        text = f"print the best N {what}, 1 to {MAX_TOP:,}, or 0 for all (default {default})"
    else:
        text = f"keep the best N {what}, 1 to {MAX_TOP:,} (default {default})"
    return text + (f"; {note}" if note else "")


def add_top(p: argparse.ArgumentParser | Any, what: str, default: int, listing: bool,
            note: str = "") -> None:
    """``--top N`` (see :func:`top_help`)."""
    p.add_argument("--top", type=int, default=default, metavar="N",
                   help=top_help(what, default, listing, note))


def check_top(value: int | None, listing: bool) -> None:
    """Refuse a ``--top`` outside its range (0 for all only where ``listing``)."""
    integer("--top", value, 0 if listing else 1, MAX_TOP)


def exit_epilog(ok: str, failed: str | None, bad: str = "") -> str:
    """The exit statuses of a command, as every ``--help`` ends: 0 ``ok``; 1 ``failed`` (None:
    a file could not be written or the system refused); 2 bad input (``bad``: what else);
    3 internal error."""
    one = failed or "a file could not be written, or the system refused"
    return (f"exit status: 0 {ok}; 1 {one}; 2 bad input (the line says what is wrong"
            + (f"; {bad}" if bad else "") + "); 3 internal error, a bug in synth "
            "(SYNTH_TRACEBACK=1 prints the traceback)")
