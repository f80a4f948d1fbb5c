"""``python -m synth.database ARGS`` is ``synth db ARGS`` (also ``python -m synth db ARGS``)."""

from __future__ import annotations

import sys

from synth.cli import main

if __name__ == "__main__":
    sys.exit(main(["db", *sys.argv[1:]]))
