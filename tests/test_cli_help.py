"""``synth --help`` and every subcommand's ``--help`` load no heavy library.

A test of imports, not of timings (``scripts/bench_help.py`` times them): building the
parsers must not import numpy, scipy, trimesh, FCL, matplotlib or MuJoCo, so that ``--help``
stays a fraction of a second whatever the machine.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

#: Libraries whose import costs a tenth of a second or more each.
HEAVY = ("numpy", "scipy", "trimesh", "fcl", "matplotlib", "mujoco", "coacd", "h5py",
         "manifold3d")
COMMANDS = ([], ["plan"], ["rank"], ["score"], ["sim"], ["db"], ["db", "build"],
            ["db", "info"], ["db", "top"], ["db", "export"])

_PROBE = """
import contextlib, io, json, sys
from synth.cli import main
heavy = {heavy!r}
found = {{}}
for words in {commands!r}:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            main(words + ["--help"])
        except SystemExit:
            pass
    loaded = sorted(m for m in sys.modules if m.split(".")[0] in heavy)
    if loaded and not found:
        found = {{"command": " ".join(["synth"] + words + ["--help"]), "loaded": loaded}}
    assert "usage: synth" in out.getvalue(), words
print(json.dumps(found))
"""


def test_help_imports_no_heavy_library() -> None:
    """Every ``--help``, in one fresh interpreter, one after the other: the first that loads a
    heavy library is named with what it loaded."""
    code = _PROBE.format(heavy=HEAVY, commands=COMMANDS)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False, timeout=120)
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found == {}, f"{found['command']} imported {found['loaded'][:8]}"


@pytest.mark.parametrize("module", ["synth.plan.params", "synth.plan.gripper_params",
                                    "synth.fingers.builtin", "synth.filetype",
                                    "synth.sim.settings", "synth.database.cli"])
def test_constants_of_the_parsers_come_from_light_modules(module: str) -> None:
    """The modules the parsers take their defaults, ranges and words from import no heavy
    library (each checked alone, so that the one at fault is named)."""
    code = (f"import sys, json; import {module}; print(json.dumps(sorted(m for m in "
            f"sys.modules if m.split('.')[0] in {HEAVY!r})))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False, timeout=60)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == [], f"{module} imports a heavy library"
