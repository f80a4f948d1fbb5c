"""Benchmark: loading and planning at 10^4 to 10^6 faces, beside trimesh's own load and merge.

A closed blob (an icosphere whose radius varies smoothly with direction, so that it has no
axis of revolution and can be held without friction) is written as a binary STL at four
sizes: 20,480, 81,920, 327,680 and 1,310,720 faces (icosphere subdivisions 5 to 8). For each
file, in separate fresh processes, so that each peak memory is that step's alone:

* ``trimesh``: ``trimesh.load(path)`` and ``merge_vertices()``, the baseline;
* ``load``: ``synth.load_part(path)``;
* ``plan``: ``load_part`` then ``plan_part`` at the defaults (seed 0, top 1).

Columns: CPU seconds of the process's work (``time.process_time``, so other load on the
machine does not count; imports excluded) and the system's share of them (``sys``), its peak
resident memory (``VmHWM`` of ``/proc/self/status``, imports included), the plan's
evaluations and first d*, and the ratios to trimesh's time and memory (the targets at 1.3M
faces: load and plan within 2x the time and 1.5x the peak memory); ``x user`` is the ratio
without the system's share.

The system's share is mostly the kernel clearing fresh pages: numpy asks for transparent huge
pages for arrays of 4 MB and more, and on a machine whose kernel then compacts memory on the
spot (``/sys/kernel/mm/transparent_hugepage/defrag``: ``madvise``) its time varies from run
to run, for trimesh's load as for synth's (0.2 to 1.0 s and 0.7 to 2.3 s at 1.3M faces on
the project's VM); ``x user`` does not.

With ``--repeat N`` the three steps run N times in turn and each column is the median; the
ratio is of the medians, and the ratios of the single rounds are printed below it.

``--subdivide FILE ...`` adds rows for other meshes (as sizes 5-8 they are written as binary
STL), each split by trimesh's ``subdivide`` until it has at least ``--faces`` faces (default
700,000): say the corpus's bunny (closed, with ears that block approaches) and its mug (a
closed cup and an open handle: two bodies, a cavity).

    python scripts/bench_scale.py [--sizes 5 6 7 8] [--keep DIR] [--repeat N]
        [--subdivide FILE ...] [--faces N]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import trimesh

__all__ = ["blob", "main"]

_STEP = r"""
import json, os, resource, sys, time
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np, trimesh
from synth import PlanParams, load_part, plan_part
path, what = sys.argv[1], sys.argv[2]
out = {}
r0 = resource.getrusage(resource.RUSAGE_SELF)
c0 = time.process_time()
if what == "trimesh":
    m = trimesh.load(path, process=False)
    m.merge_vertices()
    out["faces"] = len(m.faces)
else:
    part = load_part(path)
    out["faces"] = len(part.mesh.faces)
    out["load"] = time.process_time() - c0
    if what == "plan":
        c1 = time.process_time()
        plan = plan_part(part, PlanParams(seed=0, top=1))
        out["search"] = time.process_time() - c1
        out["evals"] = plan.evaluations
        out["d"] = plan.grasps[0].d_star if plan.grasps else 0.0
        out["cut"] = plan.stopped_by_time
out["cpu"] = time.process_time() - c0
r1 = resource.getrusage(resource.RUSAGE_SELF)
out["sys"] = r1.ru_stime - r0.ru_stime
out["user"] = out["cpu"] - out["sys"]
# the process's own peak: Linux keeps ru_maxrss across fork and exec, so it would start at
# the parent's (which may have built a 1.3M-face blob); /proc's VmHWM starts afresh
try:
    with open("/proc/self/status") as f:
        out["rss"] = next(int(x.split()[1]) for x in f if x.startswith("VmHWM")) * 1024
except (OSError, StopIteration):
    out["rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps(out))
"""


def blob(subdivisions: int) -> trimesh.Trimesh:
    """A closed, smooth, lumpy sphere of ``20 * 4**subdivisions`` faces (fixed shape)."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = np.asarray(m.vertices)
    x, y, z = v.T
    r = 1.0 + 0.25 * x * y + 0.2 * np.sin(2.0 * z + 0.5) * x + 0.15 * y * z * z + 0.3 * x
    return trimesh.Trimesh(v * r[:, None] * [1.0, 0.8, 0.6], m.faces, process=False)


def _run(path: Path, what: str) -> dict[str, float]:
    res = subprocess.run([sys.executable, "-c", _STEP, str(path), what], capture_output=True,
                         text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[5, 6, 7, 8],
                    help="icosphere subdivisions (5: 20k faces ... 8: 1.3M)")
    ap.add_argument("--keep", default=None, help="folder to keep the STL files in")
    ap.add_argument("--repeat", type=int, default=1,
                    help="rounds of the three steps, interleaved; each column is the median "
                         "(trimesh's own time varies up to 2x from run to run here)")
    ap.add_argument("--subdivide", nargs="*", default=[], metavar="FILE",
                    help="other meshes, subdivided to at least --faces faces")
    ap.add_argument("--faces", type=int, default=700_000,
                    help="faces the --subdivide meshes reach at least (default 700,000)")
    args = ap.parse_args()
    if args.keep:
        folder = Path(args.keep)
        folder.mkdir(parents=True, exist_ok=True)
        _table(args, folder)
    else:
        with tempfile.TemporaryDirectory(prefix="synth-scale-") as tmp:
            _table(args, Path(tmp))


def _table(args: argparse.Namespace, folder: Path) -> None:
    """Write the meshes into `folder` (unless already there) and print one row for each (a
    subdivided mesh's row under its name)."""
    print("CPU seconds (time.process_time) and peak RSS of one fresh process per step")
    print(f"{'faces':>9} {'trimesh s':>9} {'sys':>5} {'MB':>6} {'load s':>7} {'MB':>6} "
          f"{'plan s':>7} {'sys':>5} {'search s':>8} {'MB':>6} {'evals':>6} {'d*':>6} "
          f"{'x time':>6} {'x user':>6} {'x mem':>6}")
    paths = []
    for s in args.sizes:
        path = folder / f"blob{s}.stl"
        if not path.exists():
            blob(s).export(path)
        paths.append((None, path))
    for name in args.subdivide:
        path = folder / f"{Path(name).stem}_fine.stl"
        if not path.exists():
            mesh = trimesh.load(name, force="mesh")
            while len(mesh.faces) < args.faces:
                mesh = mesh.subdivide()
            mesh.export(path)
        paths.append((Path(name).name, path))
    for label, path in paths:
        if label:
            print(f"{label}, subdivided:", flush=True)
        rounds = [(_run(path, "trimesh"), _run(path, "load"), _run(path, "plan"))
                  for _ in range(args.repeat)]
        t, ld, pl = (_median([r[i] for r in rounds]) for i in range(3))
        user = pl["user"] / t["user"]
        print(f"{pl['faces']:>9,} {t['cpu']:>9.2f} {t['sys']:>5.2f} {t['rss'] / 1e6:>6.0f} "
              f"{ld['cpu']:>7.2f} {ld['rss'] / 1e6:>6.0f} {pl['cpu']:>7.2f} {pl['sys']:>5.2f} "
              f"{pl['search']:>8.2f} {pl['rss'] / 1e6:>6.0f} {pl['evals']:>6} {pl['d']:>6.3f} "
              f"{pl['cpu'] / t['cpu']:>6.1f} {user:>6.1f} {pl['rss'] / t['rss']:>6.2f}"
              f"{'  (cut by the time cap)' if pl['cut'] else ''}", flush=True)
        if args.repeat > 1:
            each = sorted(r[2]["cpu"] / r[0]["cpu"] for r in rounds)
            print(f"{'':>9} medians of {args.repeat} rounds; x time round by round: "
                  + ", ".join(f"{x:.1f}" for x in each), flush=True)


def _median(runs: list[dict[str, float]]) -> dict[str, float]:
    """The times' and memories' medians over the rounds; the rest (faces, evaluations, d*,
    cut) from the first round (a plan at a fixed seed and budget does not vary)."""
    timed = ("cpu", "sys", "user", "rss", "load", "search")
    return {k: float(np.median([r[k] for r in runs])) if k in timed else v
            for k, v in runs[0].items()}


if __name__ == "__main__":
    main()
