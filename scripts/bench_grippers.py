"""Benchmark of gripper grasps (printed, not asserted): synth's planner beside a plain
antipodal sampler, Franka Hand, on every corpus part with a known unit.

Per part: distinct collision-free grasps found by ``plan_gripper`` asked for the top 100 (in
frictional form closure, as the planner returns them), its planning time, distinct grasps per
second, and the best (least) squeeze per weight; then a plain antipodal sampler (Dex-Net's
method: a random surface point, a ray along the inward normal, the friction-cone test, one
random approach angle about the pair) given the same time, closing the same jaws, checked by
the same collision checker, counted only in frictional form closure as the planner's are, and
scored by the same gravity measure. Run it on one core:
``taskset -c 0 python scripts/bench_grippers.py``. A part "fits" when either finds a grasp.
Margins assume a 0.5 kg part (70 N rated force).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

from synth.errors import SynthError
from synth.fingers.gripper import load_gripper
from synth.fingers.gripper_collide import CLEAR, GripperChecker
from synth.fingers.jaws import LANDED, close_jaws
from synth.part import load_part
from synth.plan.gripper import (DISTINCT_RTOL, PREGRASP_M, TORSION_M, GripperParams,
                                _distinct, _poses, _sample_pairs, plan_gripper)
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.gravity import GRAVITY, gravity_hold_batch

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "meshes" / "corpus"
MASS = 0.5


def baseline(part, seconds: float, seed: int) -> tuple[int, float]:
    """Distinct collision-free closure grasps and the best squeeze per weight of the plain
    sampler."""
    scale = float(trimesh.units.unit_conversion("meters", part.units))
    g = load_gripper("franka").scaled(scale)
    checker = GripperChecker(part, g, PREGRASP_M * scale, max(1e-3 * part.length,
                                                                10 * part.precision))
    rng = np.random.default_rng(seed)
    mesh = part.mesh
    found_p, found_n = [], []
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        p, q, axis = _sample_pairs(part, 20, 0.5, rng)
        if not len(p):
            continue
        poses = _poses(p, q, axis, g.tcp, 8)
        pick = np.arange(len(p)) * 8 + rng.integers(0, 8, len(p))  # one of 8 approaches
        jaws = close_jaws(np.asarray(mesh.vertices), np.asarray(mesh.faces),
                          np.asarray(mesh.face_normals), poses[pick], g, part.surface_tolerance)
        ok = np.flatnonzero(jaws.status == LANDED)
        ok = ok[checker.check(jaws.poses[ok], jaws.width[ok]) == CLEAR]
        found_p += list(jaws.points[ok])
        found_n += list(jaws.normals[ok])
    if not found_p:
        return 0, float("nan")
    P, N = np.array(found_p), np.array(found_n)
    # as the planner counts: grasps in frictional form closure (two pads that cannot squeeze,
    # their line outside a friction cone, hold nothing), pairwise distinct
    fc = frictional_form_closure_batch(P, N, 0.5, center=part.center_mass, compiled=False,
                                       torsion=TORSION_M * scale)
    P, N = P[fc.closure], N[fc.closure]
    if not len(P):
        return 0, float("nan")
    keep = _distinct(P, np.arange(len(P)), DISTINCT_RTOL * part.length, len(P))
    hold = gravity_hold_batch(P[keep], N[keep], 0.5, TORSION_M * scale, part.center_mass,
                              part.length, compiled=False)
    return len(keep), float(np.min(hold.squeeze_per_weight))


def main() -> None:
    """Print one row per part and the medians.

    Options: ``--no-sampler`` leaves the plain sampler out (the planner alone); ``--save
    FILE`` writes the planner's rows as JSON; ``--against FILE`` prints the rows of such a
    file (a baseline: the same script run on another version of synth, e.g. with
    ``PYTHONPATH=/path/to/main``) beside this run's. Times are CPU seconds of this process
    (``time.process_time``: other work on a shared machine does not inflate them) and wall
    seconds.
    """
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("parts", nargs="*")
    ap.add_argument("--no-sampler", action="store_true")
    ap.add_argument("--save", default=None)
    ap.add_argument("--against", default=None)
    args = ap.parse_args()
    records = json.loads((CORPUS / "corpus.json").read_text())
    names = args.parts or [r["file"] for r in records if r["units"]]
    units = {r["file"]: r["units"] for r in records}
    base = json.loads(Path(args.against).read_text()) if args.against else {}
    print(f"{'part':<44} {'found':>5} {'cpu s':>6} {'wall s':>6} {'best N/W':>8} "
          f"{'margin':>7}" + (f" | {'base found':>10} {'cpu s':>6} {'best N/W':>8}"
                              if base else "")
          + ("" if args.no_sampler else f" | {'sampler':>7} {'grasps/s':>8} {'best N/W':>8}"))
    times, rows, saved = [], 0, {}
    few, base_few, base_times = [], [], []
    for name in names:
        try:
            part = load_part(CORPUS / name, units=units[name])
        except SynthError as e:
            print(f"{name:<44} not a part: {str(e)[-60:]}")
            continue
        c0, t0 = time.process_time(), time.perf_counter()
        plan = plan_gripper(part, GripperParams(top=100, samples=800, mass=MASS))
        cpu, dt = time.process_time() - c0, time.perf_counter() - t0
        n = len(plan.grasps)
        bn, bbest = (0, float("nan")) if args.no_sampler else baseline(part, dt, 1)
        if n == 0 and bn == 0:
            print(f"{name:<44} does not fit: {plan.message[:70]}")
            continue
        rows += 1
        times.append(cpu)
        few += [name] * (n < 20)
        best = min((g.squeeze_per_weight for g in plan.grasps), default=float("nan"))
        margin = 70.0 / (best * MASS * GRAVITY) if n else float("nan")
        saved[name] = {"found": n, "cpu_s": cpu, "wall_s": dt, "best": best}
        line = f"{name:<44} {n:>5} {cpu:>6.2f} {dt:>6.2f} {best:>8.3f} {margin:>7.1f}"
        if base:
            b = base.get(name)
            if b is None:
                line += f" | {'-':>10} {'-':>6} {'-':>8}"
            else:
                line += f" | {b['found']:>10} {b['cpu_s']:>6.2f} {b['best']:>8.3f}"
                base_times.append(b["cpu_s"])
                base_few += [name] * (b["found"] < 20)
        if not args.no_sampler:
            line += f" | {bn:>7} {bn / dt:>8.1f} {bbest:>8.3f}"
        print(line)
    if times:
        print(f"{rows} parts fit: planning CPU time (top 100) median {np.median(times):.2f} s, "
              f"max {np.max(times):.2f} s; {len(few)} with fewer than 20 grasps"
              + (f" ({', '.join(few)})" if few else ""))
    if base_times:
        print(f"baseline ({args.against}): median {np.median(base_times):.2f} s, max "
              f"{np.max(base_times):.2f} s; {len(base_few)} with fewer than 20 grasps")
    if args.save:
        Path(args.save).write_text(json.dumps(saved, indent=1))


if __name__ == "__main__":
    main()
