"""Benchmark: how long ``synth --help`` and every subcommand's ``--help`` take.

Each command runs ``--repeat`` times (default 15) as a fresh process, as a user types it, and
its CPU time (user + system, of the child alone) and wall time are printed beside two
baselines: ``python -c pass`` (the interpreter's own start) and ``python -c "import numpy"``
(what one heavy import costs). The median is printed, and the minimum (the figure least
disturbed by other work on the machine). On a shared, loaded machine read the CPU column: wall
time then includes waiting for a core. The target of issue 33 is 0.3 s.

Run: ``python scripts/bench_help.py [--repeat N]``. The command is the ``synth`` script next
to this interpreter when it is installed, else ``python -m synth``.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

#: The commands timed, after the baselines.
COMMANDS: tuple[tuple[str, ...], ...] = (
    (), ("plan",), ("rank",), ("score",), ("sim",), ("db",), ("db", "build"), ("db", "info"),
    ("db", "top"), ("db", "export"),
)
#: The target of issue 33, seconds.
TARGET = 0.3


def _synth() -> list[str]:
    script = Path(sys.executable).with_name("synth")
    if script.is_file():
        return [str(script)]
    found = shutil.which("synth")
    return [found] if found else [sys.executable, "-m", "synth"]


def _time(argv: list[str], repeat: int) -> tuple[list[float], list[float]]:
    """CPU and wall seconds of ``repeat`` runs of ``argv``."""
    cpu, wall = [], []
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        done = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              check=False)
        wall.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        if done.returncode != 0:
            sys.exit(f"{' '.join(argv)}: exit status {done.returncode}: "
                     f"{done.stderr.decode(errors='replace').strip()}")
    return cpu, wall


def main() -> int:
    """Time the baselines and every command's ``--help``; print one row each."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=15, help="runs per command (default 15)")
    repeat = max(1, ap.parse_args().repeat)
    synth = _synth()
    rows = [("python -c pass", [sys.executable, "-c", "pass"]),
            ("python -c 'import numpy'", [sys.executable, "-c", "import numpy"])]
    rows += [(" ".join(["synth", *c, "--help"]), [*synth, *c, "--help"]) for c in COMMANDS]
    load = os.getloadavg()[0]
    print(f"{repeat} runs each; {os.cpu_count()} cores, load average {load:.1f}; "
          f"command: {' '.join(synth)}")
    print(f"{'command':<28} {'cpu median':>10} {'cpu min':>8} {'wall median':>11} "
          f"{'wall min':>8}")
    worst = 0.0
    for name, argv in rows:
        cpu, wall = _time(argv, repeat)
        print(f"{name:<28} {statistics.median(cpu):>9.3f}s {min(cpu):>7.3f}s "
              f"{statistics.median(wall):>10.3f}s {min(wall):>7.3f}s")
        if name.startswith("synth"):
            worst = max(worst, statistics.median(cpu))
    print(f"slowest --help: {worst:.3f} s CPU (median); target {TARGET} s: "
          f"{'met' if worst <= TARGET else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
