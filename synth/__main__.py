"""``python -m synth``: the synth command line."""

import sys

from synth.cli import main

sys.exit(main())
