"""``python -m synth.database ARGS`` is ``synth db ARGS`` (also ``python -m synth db ARGS``)."""

from __future__ import annotations

import argparse
import sys

from synth.database.cli import add_db_parser, run_db


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv`` as the arguments of ``synth db`` and run it."""
    parser = argparse.ArgumentParser(prog="synth")
    add_db_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["db", *(sys.argv[1:] if argv is None else argv)])
    return run_db(args)


if __name__ == "__main__":
    sys.exit(main())
