"""Benchmark: the physical floor's least squeeze of grasps of more than seven contacts.

The planner asks of every closure grasp whether its least squeeze per weight (the stiff hand
of ``synth.scores.hold``) is within the floor (``--max-squeeze``, default 4). With more than
seven contacts that squeeze is an LP. For each contact count, on closure grasps of random
contacts on a corpus part (file normals, fixed seed), this times side by side, best of
``--repeat`` runs interleaved:

* ``exact``: ``stiff_hold_batch`` without a bound (every squeeze the LP's least: the batched
  simplex where the all-ones squeeze gives a start, scipy's HiGHS one grasp at a time for the
  rest);
* ``bound``: with ``at_most`` the floor, without the forces (the all-ones start only: no LP
  where it is within the floor, scipy where it has an entry that is not positive), as the
  planner asked before the d* LP's forces were passed on;
* ``forces``: with the floor and the d* LP's forces (``BatchScores.forces``), as the planner
  asks now: the better of two starts, and no grasp left to scipy for want of one.

It prints microseconds a grasp, the share of grasps whose all-ones start has an entry that is
not positive (found here with numpy's SVD), and whether ``bound`` and ``forces`` decide every
grasp as ``exact`` does (within the floor or not). With ``--plans``, whole ``synth plan``
runs of the part at each count follow (CPU seconds, first d*).

    python scripts/bench_hold.py [--part meshes/corpus/pybullet_duck_vhacd.obj]
        [--contacts 8 9 12] [--grasps 2000] [--repeat 3] [--plans]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import trimesh

from synth import PlanParams, load_part, plan_part
from synth.scores.batch import form_closure_batch
from synth.scores.hold import stiff_hold_batch
from synth.scores.quality import scaled_wrenches

ROOT = Path(__file__).resolve().parents[1]


def grasps(mesh: trimesh.Trimesh, k: int, n: int, rng: np.random.Generator):
    """``n`` closure grasps of ``k`` random contacts on ``mesh`` (inward face normals), their
    centre and size, and the d* LP's forces."""
    center, length = mesh.bounds.mean(axis=0), float(np.linalg.norm(np.ptp(mesh.bounds, axis=0)))
    P, N, F = [], [], []
    while sum(len(p) for p in P) < n:
        pts, face = trimesh.sample.sample_surface(mesh, 20 * n * k, seed=int(rng.integers(2**31)))
        p, nn = pts.reshape(-1, k, 3), -mesh.face_normals[face].reshape(-1, k, 3)
        res = form_closure_batch(scaled_wrenches(p, nn, center, length))
        P.append(p[res.closure])
        N.append(nn[res.closure])
        F.append(res.forces[res.closure])
    P, N, F = (np.concatenate(x)[:n] for x in (P, N, F))
    return P, N, F, center, length


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default=str(ROOT / "meshes/corpus/pybullet_duck_vhacd.obj"))
    ap.add_argument("--contacts", type=int, nargs="*", default=[8, 9, 12])
    ap.add_argument("--grasps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--floor", type=float, default=PlanParams().max_squeeze)
    ap.add_argument("--plans", action="store_true", help="also time whole plans (seed 0)")
    args = ap.parse_args()
    mesh = trimesh.load(args.part, force="mesh")
    rng = np.random.default_rng(0)
    print(f"{Path(args.part).name}: {args.grasps} closure grasps of random contacts per count, "
          f"floor {args.floor}; us a grasp, best of {args.repeat}")
    print(f"{'k':>3} {'exact':>8} {'bound':>8} {'forces':>8} {'no 1-start':>10} "
          f"{'same decisions':>15}")
    for k in args.contacts:
        P, N, F, c, L = grasps(mesh, k, args.grasps, rng)
        runs = {"exact": {}, "bound": {"at_most": args.floor},
                "forces": {"at_most": args.floor, "forces": F}}
        best = {name: np.inf for name in runs}
        out = {}
        for _ in range(args.repeat):
            for name, options in runs.items():
                t = time.process_time()
                out[name] = stiff_hold_batch(P, N, c, L, **options).squeeze_per_weight
                best[name] = min(best[name], time.process_time() - t)
        W = scaled_wrenches(P, N, c, L)
        Z = np.swapaxes(np.linalg.svd(W)[2][:, 6:], 1, 2)
        no_start = float((np.einsum("bkn,bn->bk", Z, Z.sum(axis=1)).min(axis=1) <= 0).mean())
        within = out["exact"] <= args.floor
        same = all(np.array_equal(out[name] <= args.floor, within) for name in ("bound", "forces"))
        us = {name: 1e6 * t / len(P) for name, t in best.items()}
        print(f"{k:>3} {us['exact']:>8.0f} {us['bound']:>8.0f} {us['forces']:>8.0f} "
              f"{no_start:>10.0%} {'yes' if same else 'NO':>15}", flush=True)
    if args.plans:
        part = load_part(args.part)
        for k in args.contacts:
            t = time.process_time()
            plan = plan_part(part, PlanParams(seed=0, contacts=k, time=600.0))
            print(f"synth plan --contacts {k}: {time.process_time() - t:.2f} s CPU, "
                  f"{plan.evaluations} evaluations, first d* {plan.grasps[0].d_star:.6f}",
                  flush=True)


if __name__ == "__main__":
    main()
