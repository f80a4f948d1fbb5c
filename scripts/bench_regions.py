"""Benchmark: contact regions and placement tolerances for the top 10 grasps of real parts.

For each part: plan (defaults, seed 0, regions off), then time ``synth.contact_regions`` on
the 10 returned grasps, next to the sampled estimate (bisection on random placements, the
route synth takes where it cannot certify) on the same grasps. Target: at most 1 s per part
for the 10 grasps, on one core.

    python scripts/bench_regions.py [--parts N]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import synth
from synth.robust import regions as R

PARTS = [
    ("meshes/bracket.stl", "dm"),
    ("meshes/cube.stl", "dm"),
    ("meshes/corpus/pybullet_stone.obj", None),
    ("meshes/corpus/pybullet_shape_sorter.obj", None),
    ("meshes/corpus/metaworld_coffee_machine_body1.stl", None),
    ("meshes/corpus/metaworld_soccer_goal_collision.obj", None),
    ("meshes/corpus/robosuite_panda_finger_collision.stl", None),
    ("meshes/corpus/robosuite_bread.stl", None),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", type=int, default=len(PARTS))
    args = ap.parse_args()
    print(f"{'part':<40} {'grasps':>6} {'certified':>9} {'time s':>7} {'sampled s':>9} "
          f"{'median tol/L':>12} {'sampled/cert':>12}")
    for path, units in PARTS[: args.parts]:
        part = synth.load_part(path, units=units)
        plan = synth.plan_part(part, synth.PlanParams(top=10, seed=0, regions=False))
        gs = plan.grasps
        t = time.perf_counter()
        res = [synth.contact_regions(part, g.points, g.normals, d_star=g.d_star) for g in gs]
        dt = time.perf_counter() - t
        t = time.perf_counter()
        samp = []
        for g in gs:
            cs = R._contacts(part, g.points, g.normals)
            samp.append(R._sampled(part, g.points, g.normals, cs, part.center_mass,
                                   float(part.length), 0.0, 8, g.d_star, 0))
        ds = time.perf_counter() - t
        tol = np.array([r.tolerance for r in res])
        st = np.array([r.tolerance for r in samp])
        ok = tol > 0
        ratio = f"{np.median(st[ok] / tol[ok]):.3f}" if ok.any() else "-"
        cert = sum(r.certified for r in res)
        print(f"{path.split('/')[-1][:40]:<40} {len(gs):>6} {cert:>9} {dt:>7.2f} {ds:>9.2f} "
              f"{np.median(tol) / part.length:>12.2e} {ratio:>12}", flush=True)


if __name__ == "__main__":
    main()
