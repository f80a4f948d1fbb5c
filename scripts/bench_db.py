"""Benchmark ``synth db build``: throughput with 1 and 2 workers and the database's overhead.

Generates small meshes in a temporary folder (fixed seed), plans them once by calling the
planner function directly in a loop (the baseline), then builds a database with 1 and with 2
worker processes, and prints meshes per minute, grasps per second, the speed-up of the second
worker (target >= 1.7x on 2 cores) and the overhead of the database over the direct loop
(target < 5%). Uses the synth planner if ``synth.plan.plan_mesh_file`` imports, else the test
planner ``tests.db_fakeplanner`` (through the ``SYNTH_DB_PLANNER`` hook), and says which.

With ``--corpus``, the meshes are the corpus parts of ``meshes/corpus`` that load (robot
links, scans, convex decompositions) instead of generated ones, in name order; past the
corpus's size the parts come again turned by a fixed rotation (PLY files: the database plans
only one of identical files, and 44 parts are too few to amortise starting the workers).

Usage: ``python scripts/bench_db.py [--meshes 16] [--evals 10000] [--corpus]``
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # for tests.db_fakeplanner

from synth.database import GraspDatabase, build_database  # noqa: E402
from synth.database.build import normalize_params  # noqa: E402
from synth.database.worker import load_planner  # noqa: E402


def _make_meshes(folder: Path, n: int, seed: int = 0) -> list[Path]:
    rng = np.random.default_rng(seed)
    paths = []
    for i in range(n):
        kind = i % 3  # shapes that admit frictionless form closure (no surface of revolution)
        if kind == 0:
            mesh = trimesh.creation.box(extents=rng.uniform(0.5, 2.0, 3))
        elif kind == 1:
            mesh = trimesh.convex.convex_hull(rng.normal(size=(int(rng.integers(12, 30)), 3)))
        else:
            angles = np.sort(rng.uniform(0, 2 * np.pi, int(rng.integers(5, 9))))
            radii = rng.uniform(0.5, 1.0, len(angles))
            ring = np.c_[radii * np.cos(angles), radii * np.sin(angles)]
            height = rng.uniform(0.3, 1.5)
            prism = np.r_[np.c_[ring, np.zeros(len(ring))], np.c_[ring, np.full(len(ring), height)]]
            mesh = trimesh.convex.convex_hull(prism)
        path = folder / f"part{i:03d}.{('stl', 'obj', 'ply')[kind]}"
        mesh.export(path)
        paths.append(path)
    return paths


def _corpus_meshes(folder: Path, n: int, seed: int = 0) -> list[Path]:
    """``n`` corpus parts that load, in name order, copied into ``folder``; the parts come
    again turned by a fixed random rotation, as often as needed."""
    from synth import load_part
    from synth.errors import SynthError

    corpus = Path(__file__).resolve().parents[1] / "meshes" / "corpus"
    usable = []
    for path in sorted(corpus.iterdir()):
        if path.suffix.lower() not in (".stl", ".obj", ".ply"):
            continue
        try:
            load_part(path)
        except SynthError:
            continue
        usable.append(path)
    rng = np.random.default_rng(seed)
    paths = []
    for i in range(n):
        src = usable[i % len(usable)]
        if i < len(usable):
            paths.append(folder / src.name)
            shutil.copyfile(src, paths[-1])
            continue
        turn = trimesh.transformations.random_rotation_matrix(rng.random(3))
        mesh = trimesh.load(src, force="mesh")
        mesh.apply_transform(turn)
        paths.append(folder / f"{i // len(usable)}_{src.stem}.ply")
        mesh.export(paths[-1])
    return paths


def _cpu() -> float:
    """CPU seconds of this process and its finished children (robust to a busy machine)."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> int:
    """Run the benchmark and print its figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", type=int, default=16)
    ap.add_argument("--evals", type=int, default=10000)
    ap.add_argument("--corpus", action="store_true",
                    help="plan the corpus parts that load instead of generated meshes")
    args = ap.parse_args()
    try:
        from synth.plan import plan_mesh_file  # noqa: F401

        planner = "synth.plan:plan_mesh_file"
    except ImportError:
        planner = "tests.db_fakeplanner:plan_mesh_file"
        os.environ["PYTHONPATH"] = os.pathsep.join(
            [str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")]
        )
    params = normalize_params({"evals": args.evals})
    print(f"planner: {planner}  params: {params}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "meshes"
        folder.mkdir()
        paths = (_corpus_meshes if args.corpus else _make_meshes)(folder, args.meshes)
        print(f"cpus: {len(os.sched_getaffinity(0))}  meshes: {len(paths)}"
              f"{' (corpus)' if args.corpus else ' (generated)'}")
        fn = load_planner(planner)
        fn(str(paths[0]), params)  # warm imports and caches, as a worker would be
        t, c = time.perf_counter(), _cpu()
        n_grasps = sum(len(fn(str(p), params)["grasps"]) for p in paths)
        direct, direct_cpu = time.perf_counter() - t, _cpu() - c
        print(f"direct loop     : {direct:7.2f} s  {len(paths) / direct * 60:7.1f} meshes/min"
              f"  {n_grasps / direct:7.1f} grasps/s  cpu {direct_cpu:6.2f} s")  # fmt: skip
        times, cpus = {}, {}
        for workers in (1, 2):
            out = Path(tmp) / f"w{workers}.sqlite"
            t, c = time.perf_counter(), _cpu()
            report = build_database(
                [folder], out, params, workers=workers, planner=planner, quiet=True
            )
            times[workers], cpus[workers] = time.perf_counter() - t, _cpu() - c
            with GraspDatabase(out) as db:
                stored = db.info().grasps
            print(f"db build {workers} worker: {times[workers]:7.2f} s  "
                  f"{report.planned / times[workers] * 60:7.1f} meshes/min  "
                  f"{stored / times[workers]:7.1f} grasps/s  ({report.done} done, "
                  f"{report.failed} failed)  cpu {cpus[workers]:6.2f} s")  # fmt: skip
    print(f"speed-up from the second worker: {times[1] / times[2]:.2f}x (target >= 1.7x)")
    print(f"database overhead, 1 worker vs direct loop: {(times[1] / direct - 1) * 100:+.1f}% "
          "(target < 5%)")  # fmt: skip
    print("database CPU overhead, 1 worker vs direct loop: "
          f"{(cpus[1] / direct_cpu - 1) * 100:+.1f}%"
          " (includes starting the worker process; robust to other load on the machine)")
    print(f"load average now: {os.getloadavg()[0]:.2f} on {len(os.sched_getaffinity(0))} cpus "
          "(wall-clock figures are only meaningful on an otherwise idle machine)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
