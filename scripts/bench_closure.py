"""Benchmark: batched d* (form_closure_batch) vs a per-grasp scipy linprog (HiGHS) loop.

Both score the same random grasps (fixed seed) in one run; the script prints per-grasp times,
the speed-up and the largest |difference| in d*. Each timing is the best of ``--repeat`` runs,
interleaved (batch, loop, batch, loop, ...), so load from other jobs on the machine affects both
sides alike. Usage:

    python scripts/bench_closure.py [--batch 4000] [--loop 300] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.optimize import linprog

from synth import form_closure_batch, wrench_matrix


def linprog_d_star(W: np.ndarray) -> float:
    """Trinkle's LP (12)-(15) with the box -1 <= c <= 1, one HiGHS call."""
    m, n = W.shape
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    res = linprog(
        cost,
        A_ub=np.hstack([-np.eye(n), np.ones((n, 1))]),
        b_ub=np.zeros(n),
        A_eq=np.hstack([W, np.zeros((m, 1))]),
        b_eq=np.zeros(m),
        bounds=[(-1, 1)] * n + [(0, None)],
        method="highs",
    )
    d = float(res.x[-1])
    return d if d > 1e-9 else 0.0


def grasps(rng: np.random.Generator, B: int, n: int) -> np.ndarray:
    """Random contacts on a sphere, normals tilted around the inward normal (a planner-like mix
    of form-closure and non-closure grasps)."""
    out = np.empty((B, 6, n))
    for b in range(B):
        P = rng.normal(size=(n, 3))
        P /= np.linalg.norm(P, axis=1, keepdims=True)
        N = -P + 0.5 * rng.normal(size=(n, 3))
        out[b] = wrench_matrix(P, N)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=4000, help="grasps scored by the batch scorer")
    ap.add_argument("--loop", type=int, default=300, help="grasps scored by the linprog loop")
    ap.add_argument("--repeat", type=int, default=3, help="timings are the best of this many")
    args = ap.parse_args()
    rng = np.random.default_rng(2024)
    print(f"{'n':>3} {'form-closure %':>15} {'batch us/grasp':>15} {'linprog us/grasp':>17} "
          f"{'speed-up':>9} {'max |diff d*|':>14} {'fallbacks':>9}")
    for n in (7, 12, 20):
        W = grasps(rng, args.batch, n)
        form_closure_batch(W[:10])  # warm up
        t_batch = t_loop = np.inf
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            res = form_closure_batch(W)
            t_batch = min(t_batch, (time.perf_counter() - t0) / args.batch)
            t0 = time.perf_counter()
            ref = np.array([linprog_d_star(w) for w in W[: args.loop]])
            t_loop = min(t_loop, (time.perf_counter() - t0) / args.loop)
        diff = np.abs(res.d_star[: args.loop] - ref).max()
        print(f"{n:>3} {100 * res.closure.mean():>15.1f} {1e6 * t_batch:>15.1f} "
              f"{1e6 * t_loop:>17.1f} {t_loop / t_batch:>8.0f}x {diff:>14.2e} {res.fallback:>9}")


if __name__ == "__main__":
    main()
