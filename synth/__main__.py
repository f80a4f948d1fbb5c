"""``python -m synth``: the synth command line."""

import sys

from synth.interrupt import run

sys.exit(run())
