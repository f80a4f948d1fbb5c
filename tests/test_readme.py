"""The README's code runs as written.

Every ```python and ```bash block runs from a scratch folder that holds the repository's
``meshes`` (so the files a command writes land there), unless the line before it says
``<!-- illustrative: why -->``. Installation steps (``python3 -m venv``, activating it, ``pip
install``) made the environment these tests run in, so they are the one thing not repeated. A
plain block after ``<!-- output of the block above -->`` must be what the block before it
printed, up to the time taken and the run id (``...`` stands for the rows left out), unless
the machine was too busy to finish the plan within ``--time`` (the plan says so).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
README = (REPO / "README.md").read_text(encoding="utf-8")
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\n", re.S | re.M)
MARK = re.compile(r"^<!-- (illustrative|output of the block above)(?:: (.+?))? -->$")
#: Languages of blocks that claim to run.
RUNNABLE = ("python", "bash", "sh", "shell", "console")
#: Steps that made the test environment.
INSTALL = ("python3 -m venv ", ". .venv/bin/activate", "source .venv/bin/activate",
           "pip install ")


def _blocks() -> list[tuple[int, str, str, str | None, str | None]]:
    """(line, language, code, mark, reason) of every fenced block of the README."""
    out = []
    for m in FENCE.finditer(README):
        before = README[: m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        mark = MARK.match(before)
        out.append((README[: m.start()].count("\n") + 1, m.group(1), m.group(2),
                    mark.group(1) if mark else None, mark.group(2) if mark else None))
    return out


BLOCKS = _blocks()
RUN = [b for b in BLOCKS if b[1] in RUNNABLE and b[3] != "illustrative"]


def _scratch(tmp_path: Path) -> dict[str, str]:
    """The environment of a block run in ``tmp_path``: the meshes, and this Python's
    ``synth`` first on the PATH."""
    (tmp_path / "meshes").symlink_to(REPO / "meshes")
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env.pop("SYNTH_DB_PLANNER", None)
    return env


def _normalised(text: str) -> list[str]:
    text = re.sub(r"in \d+(\.\d+)? s\)", "in <time> s)", text)
    text = re.sub(r"run \d{8}T\d{6}Z-[0-9a-f]{8}", "run <id>", text)
    return [line.rstrip() for line in text.splitlines()]


def test_every_block_that_claims_to_run_is_run_or_says_why() -> None:
    assert {b[1] for b in RUN} == {"bash", "python"}
    for line, lang, _, mark, why in BLOCKS:
        if mark == "illustrative":
            assert lang in RUNNABLE and why, f"README line {line}: say why it is not run"
    for k, (line, lang, _, mark, _) in enumerate(BLOCKS):
        if mark == "output of the block above":
            assert lang == "" and k > 0 and BLOCKS[k - 1] in RUN, f"README line {line}"


@pytest.mark.parametrize("block", [b for b in RUN if b[1] == "bash"], ids=lambda b: f"line{b[0]}")
def test_bash_block_runs(block, tmp_path: Path) -> None:
    line, _, code, _, _ = block
    env = _scratch(tmp_path)
    steps = [step.strip() for cmd in code.strip().splitlines() for step in cmd.split(" && ")]
    run = [s for s in steps if not s.startswith(INSTALL)]
    assert run, f"README line {line}: nothing to run"
    proc = subprocess.run(["bash", "-c", " && ".join(run)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"README line {line}: {proc.stderr[-2000:]}"
    k = BLOCKS.index(block)
    if "stopped at the time limit" in proc.stdout:
        return  # a machine too busy to finish within --time: the output says so, and differs
    if k + 1 < len(BLOCKS) and BLOCKS[k + 1][3] == "output of the block above":
        got = _normalised(proc.stdout)
        for want in _normalised(BLOCKS[k + 1][2]):
            if want.strip() != "...":
                assert want in got, f"README line {BLOCKS[k + 1][0]}: {want!r} not printed"


@pytest.mark.parametrize("block", [b for b in RUN if b[1] == "python"],
                         ids=lambda b: f"line{b[0]}")
def test_python_block_runs(block, tmp_path: Path) -> None:
    line, _, code, _, _ = block
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_scratch(tmp_path),
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"README line {line}: {proc.stderr[-2000:]}"
