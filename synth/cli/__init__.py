"""The ``synth`` command line: ``synth score``, ``synth plan``, ``synth rank``, ``synth sim``,
``synth db``.

Every command returns an exit status instead of raising:

=====  ======================================================================================
0      success
1      the work found nothing (``synth plan``: no grasp), or the system refused (a file that
       cannot be written, a locked database)
2      the input is bad (a missing or malformed file, a bad option); the line says what is wrong
3      an internal error: synth failed on input it accepted. This is a bug in synth; the line
       says so and how to report it (``SYNTH_TRACEBACK=1`` prints the traceback)
130    interrupted (Ctrl-C)
141    the reader of the output went away (``synth score ... | head``); nothing is printed
143    stopped by SIGTERM (``synth db build``: the workers are stopped, finished meshes kept)
=====  ======================================================================================

Errors print one readable line, ``synth: error: ...``, never a traceback; a bad command line
(an unknown option, a value that is not a number) is bad input too: one line, status 2.
Numeric options are checked against their documented ranges (:mod:`synth.limits`) before any
file is read or written (:mod:`synth.cli.checks`; ``synth db`` checks its own as they are
parsed).
"""

from __future__ import annotations

import argparse
import errno
import os
import signal
import sys
import traceback
from collections.abc import Callable, Sequence
from typing import Any, NoReturn

from synth import __version__, interrupt
from synth.cli.checks import GIVEN
from synth.errors import InputError, InternalError, OptionError, SolverError, SynthError, shown

__all__ = ["main", "build_parser", "command_words", "EXIT_OK", "EXIT_FAILED", "EXIT_INPUT",
           "EXIT_INTERNAL", "EXIT_PIPE"]

EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3
#: The reader of the output went away (``| head``): 128 + SIGPIPE, as a tool SIGPIPE ends.
EXIT_PIPE = 141

Runner = Callable[[argparse.Namespace], int]

#: Longest error line printed; longer messages (a value of thousands of characters) are cut.
_MAX_LINE = 400


class _Stored(argparse._StoreAction):
    """argparse's store action, which also records the option's destination in the
    namespace's :data:`synth.cli.checks.GIVEN` set (read by :func:`synth.cli.checks.given`)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None
                 ) -> None:
        super().__call__(parser, namespace, values, option_string)
        setattr(namespace, GIVEN, getattr(namespace, GIVEN, frozenset()) | {self.dest})


class _Parser(argparse.ArgumentParser):
    """An argument parser that raises :class:`InputError` on a bad command line instead of
    printing its usage and exiting, so that ``main`` reports it as one line, and records
    which options were given (its subcommands' parsers are of this class too)."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.register("action", None, _Stored)
        self.register("action", "store", _Stored)

    def error(self, message: str) -> NoReturn:
        """Raise the parse error as bad input, pointing at the command's help."""
        raise InputError(f"{message} (see '{self.prog} --help')")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand."""
    parser = _Parser(
        prog="synth",
        description="Grasp synthesis on triangle meshes, ranked by the quantitative "
        "form-closure measure d* of Trinkle (1992).",
        epilog="exit status: 0 done; 1 nothing found or the system refused; 2 bad input (the "
        "line says what is wrong); 3 internal error, a bug in synth (SYNTH_TRACEBACK=1 "
        "prints the traceback).",
    )
    parser.add_argument("--version", action="version", version=f"synth {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    from synth.cli import plan, rank, score, sim
    from synth.database.cli import add_db_parser

    plan.add_parser(sub)
    rank.add_parser(sub)
    score.add_parser(sub)
    sim.add_parser(sub)
    add_db_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    previous = None
    try:
        previous = interrupt.install()
        return _main(argv)
    except KeyboardInterrupt:  # Ctrl-C anywhere in the command
        return _interrupted()
    finally:
        interrupt.clear()
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


def _main(argv: Sequence[str] | None) -> int:
    args = None
    try:
        # in the try: building the parser imports most of the command line's modules, and a
        # Ctrl-C there (the first 0.1 s) is an interruption like any other
        parser = build_parser()
        args = _parse(parser, argv)
        if getattr(args, "json", False):  # stdout holds the JSON alone (synth.cli.vocabulary)
            args.quiet = True
        run: Runner | None = getattr(args, "run", None)
        if run is None:
            parser.print_help()
            return EXIT_INPUT
        return run(args)
    except OptionError as e:
        print(f"synth: error: {_line(e)} (see '{_prog(args)} --help')", file=sys.stderr)
        return EXIT_INPUT
    except InputError as e:
        print(f"synth: error: {_line(e)}", file=sys.stderr)
        return EXIT_INPUT
    except BrokenPipeError:
        return _reader_gone()
    except (InternalError, SolverError) as e:
        return _internal(e)
    except (SynthError, OSError) as e:
        if isinstance(e, OSError) and e.filename is None and e.errno in _WRITE_ERRORS:
            # no file named: a write to standard output (a full disk, a device error)
            print(f"synth: error: cannot write the output: {e.strerror}", file=sys.stderr)
            return EXIT_FAILED
        print(f"synth: error: {_line(e)}", file=sys.stderr)
        return EXIT_FAILED
    except Exception as e:  # anything else is a bug in synth: one line, never a traceback
        if interrupt.pending():  # an import cut short by Ctrl-C failing later: interrupted
            return _interrupted()
        return _internal(e)


def _interrupted() -> int:
    """Report a Ctrl-C (exit status 130, as a shell reports SIGINT)."""
    print("synth: interrupted", file=sys.stderr)
    return 130


def _parse(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse the command line; a file name after ``--json`` (which takes none) is pointed to
    ``--out``, the option that writes the JSON to a file."""
    words = list(sys.argv[1:] if argv is None else argv)
    try:
        return parser.parse_args(words)
    except InputError as e:
        at = [i for i, w in enumerate(words[:-1]) if w == "--json"]
        extra = str(e).partition("unrecognized arguments: ")[2].split(" (see ")[0].split()
        command = " ".join(words[:2] if words[:1] == ["db"] else words[:1]) \
            if words and words[0] in _COMMANDS else ""
        see = f"(see 'synth {command} --help')" if command else "(see 'synth --help')"
        if at and str(words[at[-1] + 1]) in extra:
            raise InputError("--json takes no file name: it prints the JSON, as every "
                             "command's --json does; write it to a file with --out "
                             f"{shown(str(words[at[-1] + 1]), 60)} {see}") from None
        if extra and command:  # the top parser says them: point to the command's help
            raise InputError(str(e).replace("(see 'synth --help')", see)) from None
        raise


#: The subcommands (``db`` has its own: ``db build``, ...).
_COMMANDS = ("plan", "rank", "score", "sim", "db")


def _prog(args: argparse.Namespace | None) -> str:
    """The command line's command, such as ``synth db build``."""
    words = ["synth", getattr(args, "command", None), getattr(args, "db_command", None)]
    return " ".join(w for w in words if w)


def _reader_gone() -> int:
    """The reader of stdout went away (``synth score ... | head``): end quietly, as other
    command-line tools do when SIGPIPE ends them (status 128 + SIGPIPE), and point stdout at
    the null device so the interpreter's last flush does not fail again."""
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)
    except (OSError, ValueError):  # no file descriptor behind stdout (a test's capture)
        pass
    return EXIT_PIPE


#: What only a failed write says (no space, quota, file too large).
_WRITE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


def _line(e: BaseException) -> str:
    """An error message as one line: the Python API's names left out (:func:`command_words`),
    line breaks made spaces, and cut to ``_MAX_LINE`` characters."""
    text = " ".join(command_words(str(e)).split())
    return text if len(text) <= _MAX_LINE else text[: _MAX_LINE - 3] + "..."


def command_words(message: str) -> str:
    """``message`` without the words meant for a Python caller: an API error names the
    option and its keyword, ``--units (Python: units=)`` or ``(--decimate N, Python:
    decimate=N)``; on the command line only the option is said.

    Examples
    --------
    >>> command_words("--workers (Python: workers=): expected an integer")
    '--workers: expected an integer'
    >>> command_words("give --units (mm, m; Python: load_part(path, units=...)) first")
    'give --units (mm, m) first'
    """
    out = message
    while True:
        at = min((i for i in (out.find(" (Python: "), out.find(", Python: "),
                              out.find("; Python: ")) if i >= 0), default=-1)
        if at < 0:
            return out
        own = out.startswith(" (", at)  # a group of its own, else the end of an open one
        depth, end = (1 if own else 0), at + 2
        while end < len(out):
            if out[end] == ";" and depth == 0 and not own:  # the open group's next clause
                break
            if out[end] == "(":
                depth += 1
            elif out[end] == ")":
                if depth == 0:  # the open group's end: kept
                    break
                depth -= 1
                if depth == 0 and own:
                    end += 1  # its own closing parenthesis goes too
                    break
            end += 1
        out = out[:at] + out[end:]


def _internal(e: BaseException) -> int:
    """Report a failure of synth itself (exit status 3)."""
    if os.environ.get("SYNTH_TRACEBACK"):
        traceback.print_exception(e)
    what = _line(e)
    print(f"synth: internal error: {type(e).__name__}{': ' + what if what else ''} -- this is a "
          f"bug in synth {__version__}, not a problem with your input; please report it with "
          "the command line and the input files (SYNTH_TRACEBACK=1 prints the traceback)",
          file=sys.stderr)
    return EXIT_INTERNAL
