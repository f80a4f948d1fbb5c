"""The slow reference search the planner is measured against (``../shared/DOMAIN.md``).

For one part, with a wall-clock budget:

1. sample 60,000 contacts of the exposed surface (synth's part model, both readings of the
   normals: the facets' own and the interpolated ones on curved patches) and score random
   7-subsets in batches for 30% of the budget under the planner's default surface model
   (``both``: closure and conditioning with both readings, d* the smaller), so that both
   searches score the same physical model;
2. keep the 8 best valid sets (form closure, conditioning >= 1e-3, fingertips of the
   planner's default radius at least two radii apart) and hill-climb each for an equal share
   of the rest: 256 proposals a round, each moving one random contact by a Gaussian step
   (5% of the bounding-box diagonal at first) snapped to the closest surface point and kept
   only if that point is exposed and a single face contact; the best proposal is taken when it
   beats the current set, else the step shrinks by 0.7; a climb stops at 1e-5 of the diagonal.

Unlike the domain notes' search, every contact must also be one a finger of the planner's
default size can make on its own (its tip fits and its straight approach is clear), the
constraint every contact the planner returns meets: otherwise the reference counts grasps no
hand could make (between a LEGO brick's studs, in narrow slots).

Its results vary between seeds; ``bench_plan.py`` runs two and keeps the better. Running this
file computes the reference for every mesh of the corpus and stores it in
``scripts/reference_plan.json`` (the reference does not depend on the planner, so the
benchmark reuses it):

    python scripts/reference_search.py [--seconds 60] [--seeds 0 1] [--files a.obj b.stl] [--missing]
"""

from __future__ import annotations

import argparse
import json
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from synth import load_part, sample_contacts
from synth.fingers import check_fingers, default_fingers
from synth.scores.quality import conditioning, scaled_wrenches
from synth.scores.surface import readings, surface_scores

__all__ = ["reference_search", "valid_d_star"]

CORPUS = Path(__file__).resolve().parent.parent / "meshes" / "corpus"
CACHE = Path(__file__).resolve().parent / "reference_plan.json"


def valid_d_star(part, P: np.ndarray, N: np.ndarray, S: np.ndarray,  # type: ignore[no-untyped-def]
                 r: float, surface: str = "both") -> np.ndarray:
    """d* of each set (B, k, 3) with the mesh's normals ``N`` and the smooth ones ``S`` under
    ``surface`` where valid (form closure, conditioning >= 1e-3 with every reading, tips at
    least 2 r apart; tips along ``N``), else -1."""
    res = surface_scores(P, N, S, surface, part.center_mass, part.length)
    ok = res.closure.copy()
    for n in readings(N, S, surface):
        if ok.any():
            W = scaled_wrenches(P[ok], n[ok], part.center_mass, part.length)
            ok[ok] &= np.asarray(conditioning(W)).reshape(-1) >= 1e-3
    tips = P - r * N
    iu = np.triu_indices(P.shape[1], 1)
    ok &= np.linalg.norm(tips[:, iu[0]] - tips[:, iu[1]], axis=2).min(axis=1) >= 2 * r
    return np.where(ok, res.d_star, -1.0)


def _reachable(part, P: np.ndarray, N: np.ndarray, fingers) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Which single contacts a finger can make (its tip fits, its approach is clear)."""
    if not len(P):
        return np.zeros(0, bool)
    return check_fingers(part, P[:, None], N[:, None], fingers).mask


def reference_search(part, seconds: float, seed: int, k: int = 7,  # type: ignore[no-untyped-def]
                     reachable: bool = True) -> float:
    """Best valid d* the reference search finds in ``seconds`` (see the module notes)."""
    rng = np.random.default_rng(seed)
    t_end_random = time.perf_counter() + 0.3 * seconds
    fingers = default_fingers(part)
    r = fingers.tip_radius
    L = part.length
    pool = sample_contacts(part, 60_000, seed=rng)
    single = (np.bincount(pool.finger)[pool.finger] == 1) & (pool.features == "face")
    PP, PN, PS = pool.points[single], pool.normals[single], pool.smooth_normals[single]
    if reachable:
        ok = _reachable(part, PP, PN, fingers)
        PP, PN, PS = PP[ok], PN[ok], PS[ok]
    best_sets: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = []
    while time.perf_counter() < t_end_random:
        idx = rng.integers(0, len(PP), size=(4096, k))
        P, N, S = PP[idx], PN[idx], PS[idx]
        d = valid_d_star(part, P, N, S, r)
        for i in np.argsort(-d)[:8]:
            if d[i] > 0:
                best_sets.append((float(d[i]), P[i], N[i], S[i]))
        best_sets = sorted(best_sets, key=lambda t: -t[0])[:8]
    best = best_sets[0][0] if best_sets else 0.0
    if not best_sets:
        return 0.0
    share = (seconds * 0.7) / len(best_sets)
    for d0, P0, N0, S0 in best_sets:
        cur_d, P, N, S = d0, P0.copy(), N0.copy(), S0.copy()
        sigma = 0.05 * L
        t_end = time.perf_counter() + share
        while sigma > 1e-5 * L and time.perf_counter() < t_end:
            which = rng.integers(0, k, 256)
            moved = P[which] + rng.normal(size=(256, 3)) * sigma
            c = part.resolve(moved, snap=True)
            one = np.bincount(c.finger, minlength=256) == 1
            first = np.full(256, -1)
            first[c.finger[::-1]] = np.arange(len(c))[::-1]
            ok = one & (first >= 0)
            ok[ok] &= c.features[first[ok]] == "face"
            ok[ok] &= part.exposed(c.points[first[ok]], c.normals[first[ok]])
            if reachable:
                ok[ok] &= _reachable(part, c.points[first[ok]], c.normals[first[ok]], fingers)
            sel = np.flatnonzero(ok)
            if not len(sel):
                sigma *= 0.7
                continue
            Pc = np.repeat(P[None], len(sel), axis=0)
            Nc = np.repeat(N[None], len(sel), axis=0)
            Sc = np.repeat(S[None], len(sel), axis=0)
            Pc[np.arange(len(sel)), which[sel]] = c.points[first[sel]]
            Nc[np.arange(len(sel)), which[sel]] = c.normals[first[sel]]
            Sc[np.arange(len(sel)), which[sel]] = c.smooth_normals[first[sel]]
            d = valid_d_star(part, Pc, Nc, Sc, r)
            j = int(np.argmax(d))
            if d[j] > cur_d:
                cur_d, P, N, S = float(d[j]), Pc[j], Nc[j], Sc[j]
            else:
                sigma *= 0.7
        best = max(best, cur_d)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seeds", type=int, nargs="*", default=[0, 1])
    ap.add_argument("--files", nargs="*", default=None, help="corpus files (default: all)")
    ap.add_argument("--missing", action="store_true",
                    help="only the files with no stored reference yet (resumes a cut-off run)")
    args = ap.parse_args()
    entries = json.loads((CORPUS / "corpus.json").read_text())
    cache = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    for e in entries:
        if e["expect"] != "plan" or (args.files and e["file"] not in args.files):
            continue
        if args.missing and e["file"] in cache:
            continue
        part = load_part(CORPUS / e["file"], units=e["units"])
        found = {str(s): reference_search(part, args.seconds, s) for s in args.seeds}
        cache[e["file"]] = {"seconds": args.seconds, "seeds": found, "surface": "both",
                            "best": max(found.values()),
                            "computed": datetime.now(timezone.utc).strftime("%Y-%m-%d")}
        print(f"{e['file'][:44]:44s} " + "  ".join(f"seed {s}: {d:.4f}" for s, d in found.items()),
              flush=True)
        CACHE.write_text(json.dumps(cache, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
