"""Benchmark: the planner vs plain random sampling, same time budget, on the sample meshes.

For each mesh, prints the best d* of the planner and of a random-sampling baseline (uniform
random 7-contact sets on the surface, scored in batches, best valid grasp kept, where valid
means form closure, conditioning >= 1e-3, fingertips apart) given the planner's own wall time,
and the time the planner took to reach 99% of its final best (measured by re-running with
growing evaluation budgets). Fixed seeds. Usage:

    python scripts/bench_plan.py [--meshes cube bracket ...]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from synth import PlanParams, form_closure_batch, load_part, plan_part, sample_contacts
from synth.scores.quality import conditioning, scaled_wrenches

MESHES = Path(__file__).resolve().parent.parent / "meshes"


def random_baseline(part, seconds: float, k: int = 7, seed: int = 0) -> tuple[float, int]:
    """Best valid d* of uniformly random k-contact sets within ``seconds``."""
    rng = np.random.default_rng(seed)
    r = 0.025 * part.length
    best, n = 0.0, 0
    t_end = time.perf_counter() + seconds
    while time.perf_counter() < t_end:
        c = sample_contacts(part, 4000 * k, seed=rng, method="uniform")
        single = np.bincount(c.finger)[c.finger] == 1
        P, N = c.points[single], c.normals[single]
        B = len(P) // k
        P, N = P[: B * k].reshape(B, k, 3), N[: B * k].reshape(B, k, 3)
        W = scaled_wrenches(P, N, part.center_mass, part.length)
        res = form_closure_batch(W)
        ok = res.closure.copy()
        if ok.any():
            ok[ok] &= np.asarray(conditioning(W[ok])).reshape(-1) >= 1e-3
        tips = P - r * N
        iu = np.triu_indices(k, 1)
        ok &= np.linalg.norm(tips[:, iu[0]] - tips[:, iu[1]], axis=2).min(1) >= 2 * r
        if ok.any():
            best = max(best, float(res.d_star[ok].max()))
        n += B
    return best, n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", nargs="*", default=["cube", "prism", "bracket", "tee", "nut"])
    args = ap.parse_args()
    print(f"{'mesh':<9} {'planner d*':>10} {'time s':>7} {'t(99%) s':>9} {'random d*':>10} "
          f"{'random sets':>12} {'planner/random':>15}")
    for name in args.meshes:
        part = load_part(MESHES / f"{name}.stl")
        t0 = time.perf_counter()
        plan = plan_part(part, PlanParams(seed=0, top=1))
        t_plan = time.perf_counter() - t0
        best = plan.grasps[0].d_star if plan.grasps else 0.0
        t99 = float("nan")
        for evals in (1000, 2000, 4000, 8000, 12000, 16000, 20000):
            t0 = time.perf_counter()
            p = plan_part(part, PlanParams(seed=0, top=1, evals=evals))
            dt = time.perf_counter() - t0
            if p.grasps and p.grasps[0].d_star >= 0.99 * best:
                t99 = dt
                break
        rb, n = random_baseline(part, t_plan)
        ratio = best / rb if rb > 0 else float("inf")
        print(f"{name:<9} {best:>10.4f} {t_plan:>7.2f} {t99:>9.2f} {rb:>10.4f} {n:>12} "
              f"{ratio:>14.2f}x")


if __name__ == "__main__":
    main()
