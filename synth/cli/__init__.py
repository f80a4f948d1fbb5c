"""The ``synth`` command line: ``synth score``, ``synth plan``, ``synth rank``, ``synth db``.

Every command returns an exit status instead of raising: 0 on success, 2 for bad input (a
missing or malformed file, a bad option), 1 when the work itself failed. Errors print one
readable line, ``synth: error: ...``, never a traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from synth import __version__
from synth.errors import InputError, SynthError

__all__ = ["main", "build_parser"]

Runner = Callable[[argparse.Namespace], int]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand."""
    parser = argparse.ArgumentParser(
        prog="synth",
        description="Grasp synthesis on triangle meshes, ranked by Trinkle's form-closure "
        "measure d* (Trinkle 1992).",
    )
    parser.add_argument("--version", action="version", version=f"synth {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    from synth.cli import plan, rank, score
    from synth.database.cli import add_db_parser

    score.add_parser(sub)
    plan.add_parser(sub)
    rank.add_parser(sub)
    add_db_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    run: Runner | None = getattr(args, "run", None)
    if run is None:
        parser.print_help()
        return 2
    try:
        return run(args)
    except InputError as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 2
    except SynthError as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("synth: interrupted", file=sys.stderr)
        return 130
    except OSError as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 1
