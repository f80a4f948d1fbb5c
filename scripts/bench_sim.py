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
* grasps the facets reject: the part planned again with ``--surface smooth`` (closure with
  the interpolated normals alone); of its top grasps, those that are not form closure with
  the mesh's own normals (``d_star_mesh`` 0, or a wrench matrix of lower rank) are simulated
  with the default hand beside the ones the facets accept: how many hold, where they fail,
  and the cosine between the motion at failure and the escape twist synth predicts from the
  mesh's normals;
* time per grasp.

Usage:

    python scripts/bench_sim.py [--files a.obj b.stl] [--evals N] [--top N]
    python scripts/bench_sim.py --part 1/2 --dump a.json &  # two processes, then
    python scripts/bench_sim.py --part 2/2 --dump b.json
    python scripts/bench_sim.py --merge a.json b.json
    python scripts/bench_sim.py --smooth-only [--part 1/2 --dump c.json]  # the last part only
    python scripts/bench_sim.py --hands-only [--part 1/2 --dump d.json]  # all but the last

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
from synth.sim import SimSettings, check_document, predicted_escape, simulate_file  # noqa: E402

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


def _hands(part, path: Path, name: str, args: argparse.Namespace, rng: np.random.Generator,
           acc: dict) -> None:
    """The planner's top grasps at every hand of ``SETTINGS``, and the best one with a contact
    removed; one line per part, measurements added to ``acc``."""
    plan = plan_part(part, PlanParams(top=args.top, evals=args.evals, seed=0, regions=True))
    if not plan.grasps:
        print(f"{name:<44} {'no grasp':>6}", flush=True)
        return
    doc = plan.to_json()
    file = check_document(doc, str(path))
    cells = []
    report = None
    for label, st in SETTINGS:
        r = simulate_file(file, st)
        report = report or r
        for g, lab in zip(file.grasps, r.labels):
            acc["rows"][label].append({"part": name, "held": lab.held, "force": lab.force_min,
                                       "torque": lab.torque_min, **g.measures})
        n_held = sum(lab.held for lab in r.labels)
        acc["held"][label][0] += n_held
        acc["held"][label][1] += len(r.labels)
        cells.append(f"{n_held:>4}/{len(r.labels):<2}")
        acc["seconds"].extend(lab.seconds for lab in r.labels)
    assert report is not None
    best = doc["grasps"][0]
    for drop in rng.choice(len(best["points"]), size=min(3, len(best["points"])),
                           replace=False):
        one = check_document(_without(doc, best, int(drop)), str(path))
        lab = simulate_file(one, SETTINGS[0][1]).labels[0]
        acc["fails"].append([lab.held, lab.escape_cos, lab.failed_at])
    p = report.pieces
    dec = "-" if not p.decomposed else (f"{p.decomposed} {p.error:6.1%}" if p.error == p.error
                                        else f"{p.decomposed} open")
    print(f"{name:<44} {len(file.grasps):>6} {len(p.pieces):>6} {dec:>10}  "
          + "  ".join(f"{cell:>13}" for cell in cells)
          + f"   {np.mean([lab.seconds for lab in report.labels]):7.2f}", flush=True)


def _smooth(part, path: Path, name: str, args: argparse.Namespace) -> list[dict]:
    """The top grasps planned with ``--surface smooth``, each simulated with the default
    hand and classified by form closure with the mesh's own normals; one line per part and
    one per grasp the facets reject."""
    plan = plan_part(part, PlanParams(top=args.top, evals=args.evals, seed=0,
                                      surface="smooth"))
    if not plan.grasps:
        print(f"{name:<44} smooth: no grasp", flush=True)
        return []
    doc = plan.to_json()
    file = check_document(doc, str(path))
    labels = simulate_file(file, SETTINGS[0][1]).labels
    out = []
    for i, (g, lab) in enumerate(zip(file.grasps, labels), 1):
        escape = predicted_escape(g.points, g.normals, file.mu, file.center_mass, file.length)
        out.append({"part": name, "rank": i, "rejected": escape is not None,
                    "d_star_smooth": g.measures["d_star_smooth"],
                    "d_star_mesh": g.measures["d_star_mesh"],
                    "conditioning": g.measures["conditioning"], "held": lab.held,
                    "failed_at": lab.failed_at, "escape_cos": lab.escape_cos,
                    "motion": lab.motion_words, "motion_at": lab.motion_at,
                    "force": lab.force_min, "seconds": lab.seconds})
    rej = [r for r in out if r["rejected"]]
    acc = [r for r in out if not r["rejected"]]
    print(f"{name:<44} smooth: {len(rej)} of {len(out)} rejected on the facets, "
          f"{sum(r['held'] for r in rej)} of them held; {sum(r['held'] for r in acc)} of "
          f"{len(acc)} accepted held", flush=True)
    for r in rej:
        cos = "" if r["escape_cos"] is None else f", cos {r['escape_cos']:+.2f} to the escape"
        print(f"    #{r['rank']:<2} d* smooth {r['d_star_smooth']:.3f} mesh "
              f"{r['d_star_mesh']:.3f}: {'held' if r['held'] else 'failed at ' + r['failed_at']}"
              + ("" if r["held"] else f", {r['motion_at']}: {r['motion']}{cos}"), flush=True)
    return out


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
    only = ap.add_mutually_exclusive_group()
    only.add_argument("--smooth-only", action="store_true",
                      help="only the grasps planned with --surface smooth (not the hands)")
    only.add_argument("--hands-only", action="store_true",
                      help="only the hands (not the grasps planned with --surface smooth)")
    ap.add_argument("--evals", type=int, default=PlanParams().evals)
    ap.add_argument("--top", type=int, default=10)
    args = ap.parse_args(argv)
    if args.merge:
        dumps = [json.loads(Path(f).read_text()) for f in args.merge]
        acc = {"rows": {name: [r for d in dumps for r in d["rows"][name]] for name, _ in SETTINGS},
               "held": {name: [sum(d["held"][name][k] for d in dumps) for k in (0, 1)]
                        for name, _ in SETTINGS},
               "fails": [f for d in dumps for f in d["fails"]],
               "seconds": [x for d in dumps for x in d["seconds"]],
               "smooth": [r for d in dumps for r in d["smooth"]]}
        parts = {r["part"] for r in acc["rows"][SETTINGS[0][0]] + acc["smooth"]}
        print(f"{len(parts)} parts")
        _summary(acc, max(d["total_s"] for d in dumps))
        return 0
    corpus = [c for c in json.loads((CORPUS / "corpus.json").read_text())
              if c["expect"] == "plan" and (args.files is None or c["file"] in args.files)]
    i, n = (int(x) for x in args.part.split("/"))
    corpus = corpus[i - 1::n]
    acc = {"rows": {name: [] for name, _ in SETTINGS},  # one per grasp
           "held": {name: [0, 0] for name, _ in SETTINGS},
           "fails": [],  # [held, escape_cos, failed_at] per grasp with a contact removed
           "seconds": [], "smooth": []}
    if not args.smooth_only:
        print(f"{'part':<44} {'grasps':>6} {'pieces':>6} {'CoACD':>10}  "
              + "  ".join(f"{name:>13}" for name, _ in SETTINGS) + "   s/grasp", flush=True)
    rng = np.random.default_rng(0)
    t_all = time.perf_counter()
    for c in corpus:
        path = CORPUS / c["file"]
        part = load_part(path, units=c.get("units"))
        if not args.smooth_only:
            _hands(part, path, c["file"], args, rng, acc)
        if not args.hands_only:
            acc["smooth"].extend(_smooth(part, path, c["file"], args))
        if args.dump:  # after every part, so that a run cut short still counts
            Path(args.dump).write_text(json.dumps({**acc,
                                                   "total_s": time.perf_counter() - t_all}))
    _summary(acc, time.perf_counter() - t_all)
    return 0


def _summary(acc: dict, total: float) -> None:
    """Print the shares, the correlations, the grasps that should fail, the grasps the
    facets reject, the times."""
    if acc["seconds"]:
        _hand_summary(acc["rows"], acc["held"], acc["fails"])
    if acc["smooth"]:
        _smooth_summary(acc["smooth"])
    s = np.array(acc["seconds"] + [r["seconds"] for r in acc["smooth"]])
    print(f"\ntime per grasp: median {np.median(s):.2f} s, mean {s.mean():.2f} s, max "
          f"{s.max():.2f} s; whole benchmark {total:.0f} s")


def _cosines(rows: list) -> str:
    cos = np.array([c for c in rows if c is not None])
    return (f"median {np.median(cos) if len(cos) else float('nan'):.2f}, above 0.9 in "
            f"{int((cos > 0.9).sum())} of {len(cos)}")


def _stages(failed_at: list) -> str:
    return ", ".join(f"{s} {sum(1 for f in failed_at if f == s)}" for s in
                     ("squeeze", "gravity", "shake", "diverged"))


def _smooth_summary(rows: list[dict]) -> None:
    """The grasps planned with ``--surface smooth``, rejected on the facets or not."""
    rej = [r for r in rows if r["rejected"]]
    acc = [r for r in rows if not r["rejected"]]
    zero = sum(r["d_star_mesh"] == 0 for r in rej)
    parts = len({r["part"] for r in rows})
    print(f"\ngrasps planned with --surface smooth ({len(rows)} on {parts} parts), simulated "
          f"with the default hand ({SETTINGS[0][0]}):")
    print(f"  rejected on the facets (not form closure with the mesh's own normals): "
          f"{len(rej)} on {len({r['part'] for r in rej})} parts (d_star_mesh 0: {zero}; "
          f"d_star_mesh > 0 but rank < 6: {len(rej) - zero})")
    print(f"    held: {sum(r['held'] for r in rej)} of {len(rej)}; failed at: "
          f"{_stages([r['failed_at'] for r in rej])}")
    print(f"    cosine of the motion at failure to the escape predicted from the mesh's "
          f"normals: {_cosines([r['escape_cos'] for r in rej if not r['held']])}")
    print(f"  accepted on the facets: {sum(r['held'] for r in acc)} of {len(acc)} held; "
          f"failed at: {_stages([r['failed_at'] for r in acc])}")


def _hand_summary(rows: dict, held: dict, fails: list) -> None:
    """The hands of ``SETTINGS``: shares held, correlations, a contact removed."""
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
    print(f"\ngrasps with one contact removed: {n_fail} of {len(fails)} fail "
          f"({_stages([f for _, _, f in fails])}); cosine of the motion to the predicted "
          f"escape: {_cosines([c for h, c, _ in fails if not h])}")


if __name__ == "__main__":
    raise SystemExit(main())
