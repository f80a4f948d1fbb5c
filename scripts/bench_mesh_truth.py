"""Benchmark: does the d* synth reports hold on the mesh as given?

For every mesh of ``meshes/corpus`` that plans, the planner runs at its defaults (seed 0) twice:
with ``--surface smooth`` (interpolated normals on tessellated patches: synth's model before the
``both`` default) and with the default ``--surface both``. Each returned grasp is re-scored by
the independent check of the tests (``tests/independent_check.py``: a plain scipy LP with the
normals of the file's own triangles, read with trimesh; at an edge or vertex the reported normal,
checked to lie in the touched facets' cone). Per part and model it prints:

* ``fc``: how many of the top grasps are form closure with the file's own normals, of how many;
* ``rep``: the reported d* of the best grasp, and ``facet`` its d* with the file's normals;
* ``worst``: the smallest ratio facet d* / reported d* over the top grasps (1 when every grasp
  holds on the facets at least as well as reported);
* ``held`` (with ``--sim``): how many of the top grasps hold in MuJoCo (``synth sim`` at its
  defaults: the file's own mesh as convex pieces, frictionless point fingers on stiff servos
  limited to 10 N, gravity, pushes and torques along the six directions, a shake);
* the planning time.

Usage:

    python scripts/bench_mesh_truth.py [--files a.obj b.stl] [--top 10] [--evals 50000] [--sim]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from synth import PlanParams, load_part, plan_part

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from tests.independent_check import Pieces, _in_cone, lp_d_star  # noqa: E402

CORPUS = ROOT / "meshes" / "corpus"


def facet_d_star(pieces: Pieces, points: np.ndarray, normals: np.ndarray) -> tuple[float, bool]:
    """d* with the file's own normals at the contacts, and whether that is form closure (rank
    6, d* > 0). A contact inside a facet takes the facet's normal; on an edge or a vertex the
    reported normal if it lies in the touched facets' cone (else the grasp does not count)."""
    own = normals.copy()
    for j, p in enumerate(points):
        faces = pieces.touched(p)
        if not len(faces):
            continue
        inward = -pieces.normals[faces]
        if np.all(inward @ inward[0] >= np.cos(1e-6)):
            own[j] = inward[0] / np.linalg.norm(inward[0])
        elif not _in_cone(normals[j], inward):
            return 0.0, False
    d, rank = lp_d_star(points, own)
    return d, bool(rank == 6 and d > 1e-9)


def held_in_mujoco(plan) -> int:  # type: ignore[no-untyped-def]
    """How many of a plan's grasps hold in MuJoCo (``synth sim`` at its defaults)."""
    from synth.sim import check_document, simulate_file

    if not plan.grasps:
        return 0
    report = simulate_file(check_document(plan.to_json(), "plan"))
    return sum(lab.held for lab in report.labels)


def _row(pieces: Pieces, plan) -> tuple[str, float, float, float, int, int]:  # type: ignore[no-untyped-def]
    n_fc, worst, rep, facet = 0, 1.0, 0.0, 0.0
    for i, g in enumerate(plan.grasps):
        d, fc = facet_d_star(pieces, np.asarray(g.points), np.asarray(g.normals))
        n_fc += fc
        worst = min(worst, (d if fc else 0.0) / g.d_star)
        if i == 0:
            rep, facet = g.d_star, d if fc else 0.0
    return f"{n_fc:>2}/{len(plan.grasps):<2}", rep, facet, worst, n_fc, len(plan.grasps)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", nargs="*", default=None)
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--evals", type=int, default=PlanParams().evals)
    ap.add_argument("--sim", action="store_true", help="simulate every grasp in MuJoCo")
    args = ap.parse_args()
    entries = [e for e in json.loads((CORPUS / "corpus.json").read_text())
               if e["expect"] == "plan" and (not args.files or e["file"] in args.files)]
    sim = f" {'held':>5}" if args.sim else ""
    print(f"{'part':40s} | {'smooth: fc':>10} {'rep':>6} {'facet':>6} {'worst':>6}{sim} {'s':>5} | "
          f"{'both: fc':>8} {'rep':>6} {'facet':>6} {'worst':>6}{sim} {'s':>5}")
    # form closure on the facets, grasps, parts with a grasp that is not, held in MuJoCo
    totals = {"smooth": [0, 0, 0, 0], "both": [0, 0, 0, 0]}
    for e in entries:
        part = load_part(CORPUS / e["file"], units=e["units"])
        pieces = Pieces(CORPUS / e["file"])
        cells = []
        for surface in ("smooth", "both"):
            t0 = time.perf_counter()
            # a time cap far above the work: the budget and the seed decide the grasps
            plan = plan_part(part, PlanParams(seed=0, top=args.top, evals=args.evals,
                                              surface=surface, time=600.0))
            dt = time.perf_counter() - t0
            fc, rep, facet, worst, n_fc, n = _row(pieces, plan)
            totals[surface][0] += n_fc
            totals[surface][1] += n
            totals[surface][2] += bool(n) and n_fc < n
            held = ""
            if args.sim:
                h = held_in_mujoco(plan)
                totals[surface][3] += h
                held = f" {h:>2}/{n:<2}"
            cells.append(f"{fc:>10} {rep:6.3f} {facet:6.3f} {worst:6.3f}{held} {dt:5.2f}")
        print(f"{e['file'][:40]:40s} | {cells[0]} | {cells[1]}", flush=True)
    for surface, (n_fc, n, bad, held) in totals.items():
        print(f"{surface}: {n_fc} of {n} top grasps are form closure with the file's own "
              f"normals; parts with a grasp that is not: {bad}"
              + (f"; held in MuJoCo: {held} of {n}" if args.sim else ""))


if __name__ == "__main__":
    main()
