"""The README's and the docs' code runs as written.

Every page (``README.md`` and ``docs/*.md``) is run the way a reader runs it: its ```bash and
```python blocks in order, in one scratch folder that holds the repository's ``meshes``, so a
block may read the files an earlier block of the same page wrote. A block is not run when the
line before it says ``<!-- illustrative: why -->``. Installation steps (``python3 -m venv``,
activating it, ``pip install``) made the environment these tests run in, so they are the one
thing not repeated. A plain block after ``<!-- output of the block above -->`` must be what
the block before it printed, line by line and in order (``...`` stands for the lines left
out), up to the time taken and the run id, unless the machine was too busy to finish the plan
within ``--time`` (the plan says so; the test is then skipped, saying why).

Regenerating an expected output (after a change to the planner, say)::

    python tests/test_readme.py README.md          # or docs/cli.md, ...

runs the page's blocks as the test does and prints what each printed, with its line; paste
it under the block, keeping the rows the page shows and ``...`` for the rest. The quick
start's picture is ``synth plan meshes/bracket.stl --units dm --png docs/bracket.png`` (run
from a scratch folder with a link to ``meshes``; it also writes the plan's JSON and GLB there).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PAGES = ["README.md", *sorted(p.relative_to(REPO).as_posix() for p in (REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\n", re.S | re.M)
MARK = re.compile(r"^<!-- (illustrative|output of the block above)(?:: (.+?))? -->$")
#: Languages of blocks that claim to run; only bash and python blocks are run.
RUNNABLE = ("python", "bash", "sh", "shell", "console")
#: Steps that made the test environment.
INSTALL = ("python3 -m venv ", ". .venv/bin/activate", "source .venv/bin/activate",
           "pip install ")
#: Seconds a page may take before the test gives up on it.
TIMEOUT = 900


@dataclass(frozen=True)
class Block:
    """A fenced block of a page: where it starts, its language, its text and its mark."""

    page: str
    line: int
    lang: str
    code: str
    mark: str | None
    why: str | None

    @property
    def runs(self) -> bool:
        """Whether the tests run this block (bash or python, not marked illustrative)."""
        return self.lang in ("bash", "python") and self.mark != "illustrative"


def _blocks(page: str) -> list[Block]:
    text = (REPO / page).read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        before = text[: m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        mark = MARK.match(before)
        out.append(Block(page, text[: m.start()].count("\n") + 1, m.group(1), m.group(2),
                         mark.group(1) if mark else None, mark.group(2) if mark else None))
    return out


BLOCKS = {page: _blocks(page) for page in PAGES}


def _scratch(folder: Path) -> dict[str, str]:
    """The environment of a page run in ``folder``: the meshes, and this Python's ``synth``
    first on the PATH."""
    (folder / "meshes").symlink_to(REPO / "meshes")
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env.pop("SYNTH_DB_PLANNER", None)
    return env


def _script(block: Block) -> str:
    """A bash block as a script that stops at the first failing command, without the
    installation steps."""
    lines = []
    for line in block.code.splitlines():
        steps = [s.strip() for s in line.split(" && ")]
        kept = [s for s in steps if not s.startswith(INSTALL)]
        if kept != steps and not any(kept):
            continue
        lines.append(" && ".join(kept) if kept != steps else line)
    return "set -eo pipefail\n" + "\n".join(lines) + "\n"


def _run(block: Block, folder: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    argv = (["bash", "-c", _script(block)] if block.lang == "bash"
            else [sys.executable, "-c", block.code])
    return subprocess.run(argv, cwd=folder, env=env, capture_output=True, text=True,
                          timeout=TIMEOUT)


def _normalised(text: str) -> list[str]:
    text = re.sub(r"in \d+(\.\d+)? s\)", "in <time> s)", text)
    text = re.sub(r"run \d{8}T\d{6}Z-[0-9a-f]{8}", "run <id>", text)
    return [line.rstrip() for line in text.splitlines()]


def _missing(want: str, got: str) -> str | None:
    """The first expected line not printed in order after the one before it, else None."""
    lines, at = _normalised(got), 0
    for line in _normalised(want):
        if line.strip() == "...":
            continue
        try:
            at = lines.index(line, at) + 1
        except ValueError:
            return line
    return None


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading."""
    text = re.sub(r"[`*]|\\", "", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def _anchors(page: str) -> set[str]:
    text = re.sub(r"^```.*?^```\n", "", (REPO / page).read_text(encoding="utf-8"),
                  flags=re.S | re.M)
    seen: dict[str, int] = {}
    out = set(re.findall(r'<a id="([^"]+)"', text))
    for heading in re.findall(r"^#+ (.+)$", text, re.M):
        slug = _slug(heading)
        out.add(slug if slug not in seen else f"{slug}-{seen[slug]}")
        seen[slug] = seen.get(slug, 0) + 1
    return out


@pytest.mark.parametrize("page", PAGES)
def test_every_block_that_claims_to_run_is_run_or_says_why(page: str) -> None:
    blocks = BLOCKS[page]
    for n, line in enumerate((REPO / page).read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith(("<!-- illustrative", "<!-- output")):
            assert MARK.match(line), f"{page} line {n}: a mark is one whole line"
    for k, b in enumerate(blocks):
        where = f"{page} line {b.line}"
        if b.mark == "illustrative":
            assert b.lang in RUNNABLE and b.why, f"{where}: say why it is not run"
        elif b.lang in RUNNABLE:
            assert b.runs, f"{where}: a {b.lang} block is not run; write bash, or mark it"
        if b.mark == "output of the block above":
            assert b.lang == "" and k > 0 and blocks[k - 1].runs, where


def test_the_readme_is_a_guide() -> None:
    """At most 400 lines, and the jobs it promises each have a block that runs."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 400
    run = "\n".join(b.code for b in BLOCKS["README.md"] if b.runs)
    for command in ("synth plan ", "--gripper franka", "synth rank ", "synth score ",
                    "synth sim ", "--sim", "synth db build ", "synth db info ", "synth db top ",
                    "synth db export ", "import synth"):
        assert command in run, command
    checked = [BLOCKS["README.md"][k - 1].code for k, b in enumerate(BLOCKS["README.md"])
               if b.mark == "output of the block above"]
    assert any("synth plan meshes/bracket.stl" in c for c in checked)
    assert any("--gripper franka" in c for c in checked)


@pytest.mark.parametrize("page", PAGES)
def test_links_resolve(page: str) -> None:
    """Every relative link and picture of a page names a file of the repository, and every
    anchor a heading of its page."""
    text = re.sub(r"^```.*?^```\n", "", (REPO / page).read_text(encoding="utf-8"),
                  flags=re.S | re.M)
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):
            continue
        path, _, anchor = target.partition("#")
        file = ((REPO / page).parent / path).resolve() if path else REPO / page
        assert file.exists(), f"{page}: link to {target}: no such file"
        if anchor:
            name = file.relative_to(REPO).as_posix()
            assert anchor in _anchors(name), f"{page}: link to {target}: no such heading"


def test_the_pictures_are_small() -> None:
    pictures = list((REPO / "docs").glob("*.png"))
    assert pictures
    for picture in pictures:
        assert picture.stat().st_size < 200_000, picture.name


@pytest.mark.parametrize("page", [p for p in PAGES if any(b.runs for b in BLOCKS[p])])
def test_page_runs_as_written(page: str, tmp_path: Path) -> None:
    env = _scratch(tmp_path)
    blocks, busy = BLOCKS[page], []
    for k, block in enumerate(blocks):
        if not block.runs:
            continue
        proc = _run(block, tmp_path, env)
        where = f"{page} line {block.line}"
        assert proc.returncode == 0, f"{where}: exit {proc.returncode}: {proc.stderr[-2000:]}"
        if k + 1 < len(blocks) and blocks[k + 1].mark == "output of the block above":
            if "stopped at the time limit" in proc.stdout:
                busy.append(where)  # a machine too busy to finish within --time
                continue
            line = _missing(blocks[k + 1].code, proc.stdout)
            assert line is None, (f"{page} line {blocks[k + 1].line}: {line!r} not printed "
                                  f"(in order); printed:\n{proc.stdout}")
    if busy:
        pytest.skip(f"every block ran, but the output of {', '.join(busy)} was not checked: "
                    "the plan stopped at its time limit")


def main(argv: list[str]) -> int:
    """Run the pages named (all by default) as the test does and print what each block
    printed, to paste under it."""
    import tempfile
    import time

    for page in argv or PAGES:
        with tempfile.TemporaryDirectory() as folder:
            env = _scratch(Path(folder))
            for block in BLOCKS[page]:
                if block.runs:
                    t0 = time.perf_counter()
                    proc = _run(block, Path(folder), env)
                    print(f"--- {page} line {block.line}: exit {proc.returncode}, "
                          f"{time.perf_counter() - t0:.1f} s")
                    print(proc.stdout, end="")
                    if proc.returncode:
                        print(proc.stderr, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
