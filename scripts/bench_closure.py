"""Benchmark: batched d* vs a per-grasp scipy linprog (HiGHS) loop of the same LP.

Three parts, each on random grasps (fixed seeds) scored both ways in one run, printing
per-grasp times of the batch scorer with the numpy simplex and with the numba kernel (when
numba is installed; ``SYNTH_SIMPLEX`` forces each route, see
``synth.scores.simplex.compiled_for``), of the linprog loop, the speed-ups and the largest
|difference| in d*:

1. frictionless d* (``form_closure_batch``) at 7, 12 and 20 contacts;
2. Trinkle's frictional d* (``frictional_form_closure_batch``, mu = 0.5, 8 cone edges) at 3, 4
   and 7 contacts, against linprog of the same LP (edge intensities, normal intensities in
   [d, 1]);
3. ``synth score`` end to end on 100,000 candidates of 7 contacts (read, score, rank, print the
   top rows, write --out), from NPZ and from JSON, as a separate process.

Each timing is the best of ``--repeat`` runs, interleaved (numpy, numba, loop, numpy, ...),
so load from other jobs on the machine affects every side alike. Usage:

    python scripts/bench_closure.py [--batch 4000] [--loop 300] [--repeat 3] [--no-score]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.optimize import linprog

from synth import BatchScores, form_closure_batch, frictional_form_closure_batch, wrench_matrix

HAVE_NUMBA = importlib.util.find_spec("numba") is not None


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


def linprog_frictional(P: np.ndarray, N: np.ndarray, mu: float, edges: int) -> float:
    """Trinkle's frictional LP of one grasp, one HiGHS call: edge intensities lam >= 0 of
    inscribed cones, d <= sum_j lam_ij <= 1, equilibrium."""
    k = len(P)
    helper = np.where(np.abs(N[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    u = np.cross(N, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(N, u)
    a = 2 * np.pi * np.arange(edges) / edges
    F = N[:, None] + mu * (np.cos(a)[None, :, None] * u[:, None] + np.sin(a)[None, :, None]
                           * v[:, None])
    r = P - P.mean(axis=0)
    G = np.concatenate([F, np.cross(r[:, None], F)], axis=2).reshape(-1, 6).T
    sums = np.kron(np.eye(k), np.ones((1, edges)))
    cost = np.zeros(k * edges + 1)
    cost[-1] = -1.0
    res = linprog(cost, A_ub=np.block([[-sums, np.ones((k, 1))], [sums, np.zeros((k, 1))]]),
                  b_ub=np.r_[np.zeros(k), np.ones(k)], A_eq=np.hstack([G, np.zeros((6, 1))]),
                  b_eq=np.zeros(6), bounds=[(0, None)] * (k * edges + 1), method="highs")
    d = float(res.x[-1])
    return d if d > 1e-9 else 0.0


def contacts(rng: np.random.Generator, B: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Random contacts on the unit sphere with unit normals tilted around the inward normal."""
    P = rng.normal(size=(B, n, 3))
    P /= np.linalg.norm(P, axis=2, keepdims=True)
    N = -P + 0.5 * rng.normal(size=(B, n, 3))
    return P, N / np.linalg.norm(N, axis=2, keepdims=True)


HEADER = (f"{'n':>3} {'closure %':>9} {'numpy us':>9} {'batch us':>9} "
          f"{'linprog us':>11} {'speed-up':>9} {'numpy speed-up':>15} {'max |diff d*|':>14} "
          f"{'fallbacks':>9}")


def compare(n: int, batch: Callable[[], BatchScores], loop: Callable[[], np.ndarray],
            args: argparse.Namespace) -> None:
    """Time one batch scorer on ``args.batch`` grasps with the numpy simplex and with the numba
    kernel (numpy again without numba), and the linprog loop on the first ``args.loop``,
    interleaved; print one row of :data:`HEADER` (times per grasp, best of ``args.repeat``)."""
    routes = {"numpy": np.inf, "batch": np.inf}
    kernel = "numba" if HAVE_NUMBA else "numpy"
    t_loop = np.inf
    for _ in range(args.repeat):
        for route in routes:
            os.environ["SYNTH_SIMPLEX"] = "numpy" if route == "numpy" else kernel
            t0 = time.perf_counter()
            res = batch()
            routes[route] = min(routes[route], (time.perf_counter() - t0) / args.batch)
        t0 = time.perf_counter()
        ref = loop()
        t_loop = min(t_loop, (time.perf_counter() - t0) / args.loop)
    diff = np.abs(res.d_star[: args.loop] - ref).max()
    print(f"{n:>3} {100 * res.closure.mean():>9.1f} {1e6 * routes['numpy']:>9.1f} "
          f"{1e6 * routes['batch']:>9.1f} {1e6 * t_loop:>11.1f} "
          f"{t_loop / routes['batch']:>8.0f}x {t_loop / routes['numpy']:>14.0f}x {diff:>14.2e} "
          f"{res.fallback:>9}")


def frictional(args: argparse.Namespace) -> None:
    """Part 2: the frictional batch scorer against linprog of the same LP."""
    rng = np.random.default_rng(7)
    mu, edges = 0.5, 8
    print(f"\nfrictional d*, mu = {mu}, {edges} cone edges")
    print(HEADER)
    for n in (3, 4, 7):
        P, N = contacts(rng, args.batch, n)
        compare(n, lambda: frictional_form_closure_batch(P, N, mu, edges=edges),  # noqa: B023
                lambda: np.array([linprog_frictional(P[i], N[i], mu, edges)  # noqa: B023
                                  for i in range(args.loop)]), args)


def score_cli() -> None:
    """Part 3: synth score on 100,000 candidates, from NPZ and from JSON."""
    rng = np.random.default_rng(3)
    B = 100_000
    P, N = contacts(rng, B, 7)
    names = [f"g{i}" for i in range(B)]
    print(f"\nsynth score, {B} candidates of 7 contacts (read, score, rank, print the top 20, "
          "write --out; a new process)")
    with tempfile.TemporaryDirectory() as tmp:
        npz, js, out = Path(tmp) / "c.npz", Path(tmp) / "c.json", Path(tmp) / "out.json"
        np.savez(npz, points=P, normals=N, names=np.array(names))
        js.write_text(json.dumps([{"name": a, "points": p, "normals": q}
                                  for a, p, q in zip(names, P.tolist(), N.tolist(), strict=True)]))
        for path in (npz, js):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "synth", "score", str(path), "--out",
                                   str(out)], capture_output=True, text=True)
            dt = time.perf_counter() - t0
            print(f"{path.suffix[1:]:>4} ({path.stat().st_size / 1e6:5.1f} MB): {dt:6.2f} s, "
                  f"exit {proc.returncode}: {proc.stderr.strip().splitlines()[-1]}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=4000, help="grasps scored by the batch scorer")
    ap.add_argument("--loop", type=int, default=300, help="grasps scored by the linprog loop")
    ap.add_argument("--repeat", type=int, default=3, help="timings are the best of this many")
    ap.add_argument("--no-score", action="store_true", help="skip the synth score part")
    args = ap.parse_args()
    rng = np.random.default_rng(2024)
    kernel = "the numba kernel" if HAVE_NUMBA else "numpy (numba is not installed)"
    print(f"batch: {kernel}; numpy: the numpy simplex; times per grasp\n")
    print("frictionless d*")
    print(HEADER)
    for n in (7, 12, 20):
        W = grasps(rng, args.batch, n)
        compare(n, lambda: form_closure_batch(W),  # noqa: B023
                lambda: np.array([linprog_d_star(w) for w in W[: args.loop]]), args)  # noqa: B023
    frictional(args)
    if not args.no_score:
        score_cli()


if __name__ == "__main__":
    main()
