"""Benchmark: which of synth's measures predicts what holds in MuJoCo.

For every mesh of ``meshes/corpus`` that plans, the planner's top grasps (defaults, seed 0)
are simulated with ``synth.sim`` at several finger stiffnesses and grip forces. Printed (not
asserted):

* per part: grasps, convex pieces (and how many bodies CoACD decomposed, with its volume
  error), and how many of the grasps hold at each setting;
* the share of grasps that hold at each setting;
* the share that holds in bands of conditioning (the planner's floor is 1e-3);
* at each setting, the Spearman rank correlation between each measure the plan reports
  (d*, conditioning, epsilon, and tolerance, d* on the facets and on the smooth surface when
  the plan has them) and the weakest push held (``force_min``, over the grip force; 0 for a
  grasp that did not hold under gravity) and the weakest torque held: pooled over every
  grasp, and the median over parts of the correlation within each part (what a ranking of
  one part's grasps needs);
* grasps that should fail: the best grasp of each part with one contact (and its finger)
  removed, three times at random: how many still hold, and the cosine between the motion
  at failure and synth's predicted escape twist;
* time per grasp.

Usage:

    python scripts/bench_sim.py [--files a.obj b.stl] [--evals N] [--top N]
    python scripts/bench_sim.py --part 1/2 --dump a.json &  # two processes, then
    python scripts/bench_sim.py --part 2/2 --dump b.json
    python scripts/bench_sim.py --merge a.json b.json

Convex decompositions are cached (see ``synth.sim.cache_dir``); the first run decomposes
every non-convex body with CoACD, which takes minutes.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads its BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.stats import spearmanr  # noqa: E402

from synth import PlanParams, load_part, plan_part  # noqa: E402
from synth.sim import SimSettings, check_document, simulate_file  # noqa: E402

__all__ = ["main", "SETTINGS"]

CORPUS = Path(__file__).resolve().parent.parent / "meshes" / "corpus"

#: (label, settings): the default hand first.
SETTINGS: tuple[tuple[str, SimSettings], ...] = (
    ("1e5 N/m, 10 N", SimSettings()),
    ("1e5 N/m,  2 N", SimSettings(grip=2.0)),
    ("2e3 N/m,  2 N", SimSettings(stiffness=2e3, grip=2.0)),
)
MEASURES = ("d_star", "conditioning", "epsilon", "tolerance", "d_star_mesh", "d_star_smooth")


def _without(doc: dict, grasp: dict, drop: int) -> dict:
    """A document holding one grasp with contact ``drop`` and its finger removed."""
    f = grasp["fingers"]
    finger = f["contact_finger"][drop]
    keep = [i for i in range(len(grasp["points"])) if f["contact_finger"][i] != finger]
    fingers = [j for j in range(len(f["tip_centers"])) if j != finger]
    g = dict(grasp)
    g["points"] = [grasp["points"][i] for i in keep]
    g["normals"] = [grasp["normals"][i] for i in keep]
    g["fingers"] = dict(f, tip_centers=[f["tip_centers"][j] for j in fingers],
                        approach=[f["approach"][j] for j in fingers])
    return dict(doc, grasps=[g])


def _spearman(x: np.ndarray, y: np.ndarray) -> float:
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 4 or np.ptp(x[ok]) == 0 or np.ptp(y[ok]) == 0:
        return float("nan")
    return float(spearmanr(x[ok], y[ok]).statistic)


def _correlations(rows: list[dict], m: str) -> str:
    """One line: measure ``m`` against the weakest push and torque held."""
    x = np.array([r.get(m, np.nan) for r in rows], float)
    if not np.isfinite(x).any():
        return f"    {m:<14}  (not in the plans)"
    parts = sorted({r["part"] for r in rows})
    line = f"    {m:<14}"
    for target in ("force", "torque"):
        y = np.array([r[target] for r in rows], float)
        within = []
        for q in parts:
            sel = np.array([r["part"] == q for r in rows])
            w = _spearman(x[sel], y[sel])
            if np.isfinite(w):
                within.append(w)
        med = np.median(within) if within else float("nan")
        line += f"  {target} {_spearman(x, y):+.2f} / {med:+.2f} ({len(within)})"
    return line


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its tables."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--files", nargs="*", default=None)
    ap.add_argument("--part", default="1/1", metavar="I/N",
                    help="run the I-th of N slices of the corpus (to run N processes)")
    ap.add_argument("--dump", default=None, metavar="JSON",
                    help="also write the measurements to this file, for --merge")
    ap.add_argument("--merge", nargs="+", default=None, metavar="JSON",
                    help="print the summary of the measurements in these --dump files")
    ap.add_argument("--evals", type=int, default=PlanParams().evals)
    ap.add_argument("--top", type=int, default=10)
    args = ap.parse_args(argv)
    if args.merge:
        dumps = [json.loads(Path(f).read_text()) for f in args.merge]
        print(f"{sum(len({r['part'] for r in d['rows'][SETTINGS[0][0]]}) for d in dumps)} parts")
        _summary({name: [r for d in dumps for r in d["rows"][name]] for name, _ in SETTINGS},
                 {name: [sum(d["held"][name][k] for d in dumps) for k in (0, 1)]
                  for name, _ in SETTINGS},
                 [tuple(f) for d in dumps for f in d["fails"]],
                 [x for d in dumps for x in d["seconds"]], max(d["total_s"] for d in dumps))
        return 0
    corpus = [c for c in json.loads((CORPUS / "corpus.json").read_text())
              if c["expect"] == "plan" and (args.files is None or c["file"] in args.files)]
    i, n = (int(x) for x in args.part.split("/"))
    corpus = corpus[i - 1::n]
    rows: dict[str, list[dict]] = {name: [] for name, _ in SETTINGS}  # one per grasp
    held = {name: [0, 0] for name, _ in SETTINGS}
    fails: list[list] = []  # [held, escape_cos, failed_at] per grasp with a contact removed
    seconds: list[float] = []
    print(f"{'part':<44} {'grasps':>6} {'pieces':>6} {'CoACD':>10}  "
          + "  ".join(f"{name:>13}" for name, _ in SETTINGS) + "   s/grasp",
          flush=True)
    rng = np.random.default_rng(0)
    t_all = time.perf_counter()
    for c in corpus:
        path = CORPUS / c["file"]
        part = load_part(path, units=c.get("units"))
        plan = plan_part(part, PlanParams(top=args.top, evals=args.evals, seed=0, regions=True))
        if not plan.grasps:
            print(f"{c['file']:<44} {'no grasp':>6}", flush=True)
            continue
        doc = plan.to_json()
        file = check_document(doc, str(path))
        cells = []
        report = None
        for name, st in SETTINGS:
            r = simulate_file(file, st)
            report = report or r
            for g, lab in zip(file.grasps, r.labels):
                rows[name].append({"part": c["file"], "held": lab.held, "force": lab.force_min,
                                   "torque": lab.torque_min, **g.measures})
            n_held = sum(lab.held for lab in r.labels)
            held[name][0] += n_held
            held[name][1] += len(r.labels)
            cells.append(f"{n_held:>4}/{len(r.labels):<2}")
            seconds.extend(lab.seconds for lab in r.labels)
        assert report is not None
        best = doc["grasps"][0]
        for drop in rng.choice(len(best["points"]), size=min(3, len(best["points"])),
                               replace=False):
            one = check_document(_without(doc, best, int(drop)), str(path))
            lab = simulate_file(one, SETTINGS[0][1]).labels[0]
            fails.append([lab.held, lab.escape_cos, lab.failed_at])
        p = report.pieces
        dec = "-" if not p.decomposed else (f"{p.decomposed} {p.error:6.1%}" if p.error == p.error
                                            else f"{p.decomposed} open")
        print(f"{c['file']:<44} {len(file.grasps):>6} {len(p.pieces):>6} {dec:>10}  "
              + "  ".join(f"{cell:>13}" for cell in cells)
              + f"   {np.mean([lab.seconds for lab in report.labels]):7.2f}", flush=True)
        if args.dump:  # after every part, so that a run cut short still counts
            Path(args.dump).write_text(json.dumps({
                "rows": rows, "held": held, "fails": fails, "seconds": seconds,
                "total_s": time.perf_counter() - t_all}))

    _summary(rows, held, fails, seconds, time.perf_counter() - t_all)
    return 0


def _summary(rows: dict, held: dict, fails: list, seconds: list, total: float) -> None:
    """Print the shares, the correlations, the grasps that should fail, the times."""
    print("\nshare of the top grasps that hold (squeeze, gravity, shake of 1 g):")
    for name, (h, n) in held.items():
        print(f"  {name}: {h} of {n} ({h / max(n, 1):.0%})")
    print("\nshare held by conditioning (the planner's floor is 1e-3):")
    bands = (0.001, 0.003, 0.01, 0.03, 0.1, 1.0)
    print(f"  {'':<14}" + "".join(f"  {lo:g}-{hi:g}".ljust(14) for lo, hi in
                                  zip(bands[:-1], bands[1:])))
    for name, _ in SETTINGS:
        cond = np.array([r["conditioning"] for r in rows[name]], float)
        ok = np.array([r["held"] for r in rows[name]], bool)
        cells = []
        for lo, hi in zip(bands[:-1], bands[1:]):
            sel = (cond >= lo) & (cond < hi)
            cells.append(f"  {int(ok[sel].sum())}/{int(sel.sum())}".ljust(14))
        print(f"  {name:<14}" + "".join(cells))
    print("\nSpearman rank correlation of each measure with the weakest push and torque held: "
          "pooled over all grasps / median over parts of the within-part correlation (parts)")
    for name, _ in SETTINGS:
        print(f"  {name}")
        for m in MEASURES:
            print(_correlations(rows[name], m))
    n_fail = sum(not h for h, _, _ in fails)
    cos = np.array([c for h, c, _ in fails if c is not None and not h])
    stages = {s: sum(1 for h, _, f in fails if f == s) for s in
              ("squeeze", "gravity", "shake", "diverged")}
    print(f"\ngrasps with one contact removed: {n_fail} of {len(fails)} fail "
          f"({', '.join(f'{k} {v}' for k, v in stages.items())}); cosine of the motion to "
          f"the predicted escape: median {np.median(cos) if len(cos) else float('nan'):.2f}, "
          f"above 0.9 in {int((cos > 0.9).sum())} of {len(cos)}")
    s = np.array(seconds)
    print(f"\ntime per grasp: median {np.median(s):.2f} s, mean {s.mean():.2f} s, max "
          f"{s.max():.2f} s; whole benchmark {total:.0f} s")


if __name__ == "__main__":
    raise SystemExit(main())
