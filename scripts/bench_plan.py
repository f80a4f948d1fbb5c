"""Benchmark: the planner on the real-mesh corpus, against random sampling and a slow reference.

For every mesh of ``meshes/corpus`` that plans (all but the flat cloth, which has no volume to
hold), one run prints:

* the planner's best d* at its defaults and its planning time (one core, ``plan_part`` only,
  the mesh already loaded);
* the best valid d* of uniformly random 7-contact sets of the exposed surface given the same
  time (valid: form closure, conditioning >= 1e-3, fingertips two radii apart);
* the best d* of the reference search (``scripts/reference_search.py``: random sets then a
  one-contact hill-climb, 60 s, the better of two seeds), read from
  ``scripts/reference_plan.json`` where it was computed once (the reference does not depend on
  the planner; recompute it with ``python scripts/reference_search.py``);
* the planner/reference ratio, and the time the planner needs to reach 99% of its own final
  best (re-planning with growing evaluation budgets).

Usage:

    python scripts/bench_plan.py [--files a.obj b.stl] [--no-t99] [--cpu N]

The process pins itself to one CPU (the last one by default; Linux) and to one BLAS thread,
so the times are one core's whatever else the machine runs.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads its BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from synth import PlanParams, load_part, plan_part, sample_contacts  # noqa: E402
from synth.fingers import default_fingers  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reference_search import CACHE, CORPUS, valid_d_star  # noqa: E402

__all__ = ["main", "random_baseline"]


def random_baseline(part, seconds: float, k: int = 7, seed: int = 0) -> tuple[float, int]:  # type: ignore[no-untyped-def]
    """Best valid d* of uniformly random k-contact sets within ``seconds``."""
    rng = np.random.default_rng(seed)
    r = default_fingers(part).tip_radius
    best, n = 0.0, 0
    pool = sample_contacts(part, 60_000, seed=rng)
    single = (np.bincount(pool.finger)[pool.finger] == 1) & (pool.features == "face")
    PP, PN, PS = pool.points[single], pool.normals[single], pool.smooth_normals[single]
    t_end = time.perf_counter() + seconds
    while time.perf_counter() < t_end:
        idx = rng.integers(0, len(PP), size=(4096, k))
        d = valid_d_star(part, PP[idx], PN[idx], PS[idx], r)
        best = max(best, float(d.max()))
        n += len(idx)
    return best, n


def _t99(part, best: float, full_evals: int) -> float:  # type: ignore[no-untyped-def]
    for frac in (0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0):
        t0 = time.perf_counter()
        p = plan_part(part, PlanParams(seed=0, top=1, evals=max(100, int(frac * full_evals))))
        dt = time.perf_counter() - t0
        if p.grasps and p.grasps[0].d_star >= 0.99 * best:
            return dt
    return float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", nargs="*", default=None)
    ap.add_argument("--no-t99", action="store_true", help="skip the time-to-99% column")
    ap.add_argument("--cpu", type=int, default=None, help="CPU to run on (default: the last)")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        cpu = max(os.sched_getaffinity(0)) if args.cpu is None else args.cpu
        os.sched_setaffinity(0, {cpu})
        print(f"pinned to CPU {cpu}")
    entries = json.loads((CORPUS / "corpus.json").read_text())
    ref = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    print(f"{'mesh':40s} {'planner d*':>10} {'time s':>7} {'t(99%) s':>8} {'random d*':>9} "
          f"{'reference d*':>12} {'planner/ref':>11}")
    ratios, times = [], []
    for e in entries:
        if e["expect"] != "plan" or (args.files and e["file"] not in args.files):
            continue
        part = load_part(CORPUS / e["file"], units=e["units"])
        prm = PlanParams(seed=0, top=1)
        t0 = time.perf_counter()
        plan = plan_part(part, prm)
        t_plan = time.perf_counter() - t0
        best = plan.grasps[0].d_star if plan.grasps else 0.0
        t99 = float("nan") if args.no_t99 or not best else _t99(part, best, prm.evals)
        rb, _ = random_baseline(part, t_plan)
        r = ref.get(e["file"], {}).get("best")
        ratio = best / r if r else float("nan")
        if r:
            ratios.append(ratio)
        times.append(t_plan)
        print(f"{e['file'][:40]:40s} {best:>10.4f} {t_plan:>7.2f} {t99:>8.2f} {rb:>9.4f} "
              f"{(r if r is not None else float('nan')):>12.4f} {ratio:>10.3f}x", flush=True)
    print(f"{len(times)} parts: planning time median {np.median(times):.2f} s, max "
          f"{max(times):.2f} s; planner/reference median {np.median(ratios):.3f}, min "
          f"{min(ratios):.3f}, parts below the reference: {sum(x < 1 for x in ratios)}")


if __name__ == "__main__":
    main()
