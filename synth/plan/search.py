"""The grasp search: seeds, the planar-piece LP, local refinement, selection.

Stages, all reproducible from the seed (the evaluation budget fixes how much each does):

1. **Seeds.** An even spread of face contacts (farthest-point sampling) forms a pool; random
   k-subsets of it are scored in batches (:func:`synth.form_closure_batch`).
2. **Region LP** (planar parts). For the best seeds, each contact's face grows into a convex
   piece of its planar region and one LP finds the positions on those pieces with the
   highest d* (:mod:`synth.plan.pieces`).
3. **Refinement.** A population of the best distinct grasps hill-climbs: each round proposes
   moves of single contacts in their tangent plane, snaps them back to the surface with the
   part model and keeps the best move per grasp; the step halves when nothing improves. This
   also repairs the LP's degenerate optima (rank W < 6) and works on curved patches.
4. **Selection.** Candidates in order of d* pass the finger checks (FCL) and a diversity
   filter; the conditioning and the Ferrari-Canny epsilon are computed for the chosen ones.

A grasp's fitness is its d* when it is (frictional) form closure, well conditioned
(``min_conditioning``) and its fingertips do not overlap; other grasps rank below every valid
one (d* - 1 if only rank or conditioning fails, -2 if the tips overlap).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from synth.contacts import sample_contacts
from synth.fingers import Fingers, check_fingers, default_fingers
from synth.plan.params import PlanParams
from synth.plan.pieces import best_positions, convex_piece
from synth.plan.result import Plan, PlannedGrasp
from synth.scores import (
    describe_twist,
    form_closure,
    form_closure_batch,
    frictional_form_closure,
)
from synth.scores.quality import (
    conditioning,
    epsilon_quality,
    grasp_wrenches,
    scaled_wrenches,
)
from synth.scores.friction_batch import frictional_form_closure_batch

__all__ = ["plan_part", "Progress"]

Progress = Callable[[float, str], None]

_POOL = 600
_CHUNK = 4096


@dataclass
class _Batch:
    """Grasps under evaluation: (B, k) contact data and their scores."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    faces: NDArray[np.int64]
    regions: NDArray[np.int64]
    d: NDArray[np.float64]
    fit: NDArray[np.float64]

    def take(self, idx: NDArray[np.int64]) -> "_Batch":
        return _Batch(self.points[idx], self.normals[idx], self.faces[idx], self.regions[idx],
                      self.d[idx], self.fit[idx])

    @staticmethod
    def concat(parts: list["_Batch"]) -> "_Batch":
        return _Batch(*[np.concatenate([getattr(p, f) for p in parts]) for f in
                        ("points", "normals", "faces", "regions", "d", "fit")])


class _Scorer:
    """Fitness of batches of grasps for one part and parameter set."""

    def __init__(self, part, params: PlanParams, fingers: Fingers) -> None:
        self.center = np.asarray(part.center_mass, dtype=np.float64)
        self.length = float(part.length)
        self.params = params
        self.r = float(fingers.tip_radius)
        self.evaluations = 0

    def matrix(self, P: NDArray[np.float64], N: NDArray[np.float64]) -> NDArray[np.float64]:
        """The scaled wrench matrix (or matrices) whose conditioning is reported."""
        prm = self.params
        return grasp_wrenches(P, N, self.center, self.length, prm.mu, prm.edges)

    def __call__(self, P: NDArray[np.float64], N: NDArray[np.float64]) -> tuple[
        NDArray[np.float64], NDArray[np.float64]
    ]:
        B = P.shape[0]
        self.evaluations += B
        prm = self.params
        if prm.mu == 0:
            W = scaled_wrenches(P, N, self.center, self.length)
            d = np.empty(B)
            ok = np.empty(B, dtype=bool)
            for s in range(0, B, _CHUNK):
                res = form_closure_batch(W[s : s + _CHUNK])
                d[s : s + _CHUNK], ok[s : s + _CHUNK] = res.d_star, res.closure
        else:
            res = frictional_form_closure_batch(P, N, prm.mu, center=self.center,
                                                edges=prm.edges)
            d, ok = res.d_star, res.closure
        cond = np.zeros(B)
        if ok.any():  # conditioning matters only for closure grasps
            cond[ok] = np.asarray(conditioning(self.matrix(P[ok], N[ok]))).reshape(-1)
        tips = P - self.r * N
        k = P.shape[1]
        iu = np.triu_indices(k, 1)
        gap = np.linalg.norm(tips[:, iu[0]] - tips[:, iu[1]], axis=2).min(axis=1)
        tips_ok = gap >= 2 * self.r * (1 - 1e-9)
        valid = ok & (cond >= prm.min_conditioning) & (d >= prm.min_d_star)
        fit = np.where(tips_ok, np.where(valid, d, d - 1.0), -2.0)
        return d, fit


def _grasp_key(b: _Batch, i: int, scale: float) -> tuple:
    """A rounded, order-free signature to drop duplicate grasps."""
    q = np.round(b.points[i] / scale).astype(np.int64)
    return tuple(sorted(map(tuple, q)))


def _distinct_top(b: _Batch, n: int, scale: float) -> NDArray[np.int64]:
    order = np.argsort(-b.fit, kind="stable")
    seen: set[tuple] = set()
    out = []
    for i in order:
        key = _grasp_key(b, int(i), scale)
        if key in seen:
            continue
        seen.add(key)
        out.append(int(i))
        if len(out) == n:
            break
    return np.array(out, dtype=np.int64)


def plan_part(part, params: PlanParams | None = None, progress: Progress | None = None) -> Plan:
    """Search a part for the best collision-free grasps ranked by d*.

    Parameters
    ----------
    part : synth.Part
    params : PlanParams, optional
    progress : callable(fraction, message), optional
        Called as the search advances (fraction in [0, 1]).

    Returns
    -------
    Plan
    """
    prm = params or PlanParams()
    t0 = time.perf_counter()
    deadline = t0 + prm.time
    rng = np.random.default_rng(prm.seed)
    overrides = {k: v for k, v in (("tip_radius", prm.finger_radius),
                                   ("body_length", prm.body_length),
                                   ("body_radius", prm.body_radius)) if v is not None}
    if prm.approach_cone:
        overrides["approach_cone"] = float(np.radians(prm.approach_cone))
    if prm.support_z is not None:
        overrides["support_plane"] = ((0.0, 0.0, prm.support_z), (0.0, 0.0, 1.0))
    fingers = default_fingers(part, **overrides)
    score = _Scorer(part, prm, fingers)
    k = prm.contacts
    L = float(part.length)
    say = progress or (lambda f, m: None)
    budget = prm.evals if prm.mu == 0 else max(100, prm.evals // 5)

    # 1. seeds --------------------------------------------------------------------------
    say(0.0, "sampling contacts")
    pool = sample_contacts(part, _POOL, seed=rng, method="even")
    single = np.bincount(pool.finger)[pool.finger] == 1
    keep = (pool.features == "face") & single
    if keep.sum() < k:
        keep = single
    keep[keep] &= _reachable(part, pool.points[keep], pool.normals[keep], fingers)
    pp, pn = pool.points[keep], pool.normals[keep]
    pf, pr = pool.faces[keep], pool.region[keep]
    n_seed = budget // 3
    idx = np.argsort(rng.random((n_seed, len(pp))), axis=1)[:, :k] if len(pp) <= 64 else (
        _distinct_rows(rng, n_seed, len(pp), k))
    seeds = _Batch(pp[idx], pn[idx], pf[idx], pr[idx], np.zeros(n_seed), np.zeros(n_seed))
    seeds.d, seeds.fit = score(seeds.points, seeds.normals)
    archive = seeds.take(_distinct_top(seeds, 400, 1e-6 * L))
    say(0.3, f"{score.evaluations} seeds scored, best d* {max(0.0, archive.fit.max()):.4f}")

    # 2. planar-piece LP ----------------------------------------------------------------
    margin = fingers.tip_radius
    pieces: dict[int, object] = {}
    lp_found = []
    tuples_seen: set[tuple] = set()
    for i in _distinct_top(archive, 40, 1e-6 * L):
        if time.perf_counter() > deadline:
            break
        faces = archive.faces[i]
        if not all(part.regions[int(part.face_region[f])].planar for f in faces):
            continue
        pcs = []
        for f in faces:
            if int(f) not in pieces:
                pieces[int(f)] = convex_piece(part, int(f), margin)
            pcs.append(pieces[int(f)])
        if any(p is None for p in pcs):
            continue
        key = tuple(sorted(id(p) for p in pcs))
        if key in tuples_seen:
            continue
        tuples_seen.add(key)
        if not _spans_forces(np.array([p.normal for p in pcs])):
            continue  # no positions on these pieces can balance every force
        sol = best_positions(pcs, score.center, L)
        if sol is None:
            continue
        pts, _ = sol
        c = part.resolve(pts, snap=True)
        if len(c) != k:
            continue
        lp_found.append(_Batch(c.points[None], c.normals[None], c.faces[None], c.region[None],
                               np.zeros(1), np.zeros(1)))
    if lp_found:
        lpb = _Batch.concat(lp_found)
        lpb.d, lpb.fit = score(lpb.points, lpb.normals)
        archive = _Batch.concat([archive, lpb])
    say(0.45, f"region LPs solved: {len(lp_found)}")

    # 3. refinement ---------------------------------------------------------------------
    pop_size = 16
    moves = 24
    pop = archive.take(_distinct_top(archive, pop_size, 1e-6 * L))
    sigma = np.full(len(pop.d), 0.05 * L)
    stopped_by_time = False
    while score.evaluations < budget and (sigma > 1e-4 * L).any():
        if time.perf_counter() > deadline:
            stopped_by_time = True
            break
        M = len(pop.d)
        who = np.repeat(np.arange(M), moves)
        which = rng.integers(0, k, M * moves)
        P = pop.points[who].copy()
        N0 = pop.normals[who, which]
        step = rng.normal(size=(M * moves, 3))
        step -= (step * N0).sum(1, keepdims=True) * N0
        step *= (sigma[who] * rng.random(M * moves))[:, None] / np.maximum(
            np.linalg.norm(step, axis=1, keepdims=True), 1e-300)
        moved = P[np.arange(M * moves), which] + step
        c = part.resolve(moved, snap=True)
        one = np.bincount(c.finger, minlength=M * moves) == 1
        first = np.full(M * moves, -1)
        first[c.finger[::-1]] = np.arange(len(c))[::-1]
        okm = one & (first >= 0)
        okm[okm] &= c.features[first[okm]] == "face"
        okm[okm] &= _reachable(part, c.points[first[okm]], c.normals[first[okm]], fingers)
        if not okm.any():
            sigma *= 0.5
            continue
        sel = np.nonzero(okm)[0]
        cand = pop.take(who[sel])
        rows = np.arange(len(sel))
        cand.points = cand.points.copy()
        cand.normals = cand.normals.copy()
        cand.faces = cand.faces.copy()
        cand.regions = cand.regions.copy()
        j = first[sel]
        cand.points[rows, which[sel]] = c.points[j]
        cand.normals[rows, which[sel]] = c.normals[j]
        cand.faces[rows, which[sel]] = c.faces[j]
        cand.regions[rows, which[sel]] = c.region[j]
        cand.d, cand.fit = score(cand.points, cand.normals)
        archive = _Batch.concat([archive, cand.take(np.nonzero(cand.fit > 0)[0])])
        # best move of each member (first one among equals), without a Python loop
        member = who[sel]
        order = np.lexsort((np.arange(member.size), -cand.fit, member))
        head = order[np.r_[True, member[order][1:] != member[order][:-1]]]
        best = np.full(M, -np.inf)
        arg = np.full(M, -1)
        best[member[head]], arg[member[head]] = cand.fit[head], head
        improve = best > pop.fit + 1e-12
        m_i = np.nonzero(improve)[0]
        r_i = arg[m_i]
        for f in ("points", "normals", "faces", "regions", "d", "fit"):
            getattr(pop, f)[m_i] = getattr(cand, f)[r_i]
        sigma = np.where(improve, sigma * 1.2, sigma * 0.5)
        say(0.45 + 0.45 * min(1.0, score.evaluations / budget),
            f"refining: best d* {max(0.0, pop.fit.max()):.4f}")
    archive = _Batch.concat([archive, pop])

    # 4. selection ----------------------------------------------------------------------
    say(0.9, "checking fingers")
    grasps, rejected = _select(part, archive, prm, fingers, score)
    total = time.perf_counter() - t0
    mesh_info = {"path": part.source, "sha256": part.sha256, "units": part.units, "length": L}
    escape = None
    if grasps:
        kind = "frictional form" if prm.mu > 0 else "form"
        message = (f"{len(grasps)} {kind}-closure grasps, best d* {grasps[0].d_star:.4f} "
                   f"({score.evaluations} grasps evaluated in {total:.1f} s)")
    elif rejected:
        reason, count = max(rejected.items(), key=lambda kv: kv[1])
        message = (f"{sum(rejected.values())} closure grasps were found but the fingers could "
                   f"make none of them (most often: {reason}); try a smaller --finger-radius "
                   f"or a wider --approach-cone")
    else:
        escape = _why_none(archive, prm, score)
        kind = "with friction mu = %g" % prm.mu if prm.mu > 0 else "without friction"
        message = f"no {k}-contact closure grasp {kind} was found" + (
            f"; the best candidate is {escape}" if escape else "")
        if prm.mu == 0 and escape and "rotate about" in escape:
            message += (". Without friction no number of contacts stops a turn about an axis "
                        "of symmetry (sphere, cylinder, torus): try mu > 0 with 3 or 4 contacts")
    say(1.0, "done")
    return Plan(tuple(grasps), message, mesh_info, prm.to_dict(), fingers.to_dict(),
                score.evaluations, total, stopped_by_time, escape)


def _spans_forces(normals: NDArray[np.float64]) -> bool:
    """Necessary condition for form closure: the normals positively span 3-D force space,
    i.e. the origin is strictly inside their convex hull (Trinkle's test on the 3 x k force
    rows alone)."""
    return bool(form_closure_batch(normals.T[None]).closure[0])


def _reachable(part, points: NDArray[np.float64], normals: NDArray[np.float64],
               fingers: Fingers) -> NDArray[np.bool_]:
    """Which single contacts a finger can make alone (tip fits, approach is clear)."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    return check_fingers(part, points[:, None, :], normals[:, None, :], fingers).mask


def _distinct_rows(rng: np.random.Generator, n: int, size: int, k: int) -> NDArray[np.int64]:
    """n random k-subsets of range(size) (no repeated index within a row)."""
    idx = rng.integers(0, size, (n, k))
    for _ in range(8):
        srt = np.sort(idx, axis=1)
        dup = (np.diff(srt, axis=1) == 0).any(axis=1)
        if not dup.any():
            break
        idx[dup] = rng.integers(0, size, (int(dup.sum()), k))
    return idx


def _hausdorff(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    D = np.linalg.norm(a[:, None] - b[None], axis=2)
    return float(max(D.min(axis=1).max(), D.min(axis=0).max()))


def _select(part, archive: _Batch, prm: PlanParams, fingers: Fingers, score: _Scorer
            ) -> tuple[list[PlannedGrasp], dict[str, int]]:
    """Best valid grasps that pass the finger checks and the diversity filter, and a count of
    the finger-check failures by kind."""
    valid = np.nonzero(archive.fit > 0)[0]
    order = valid[np.argsort(-archive.fit[valid], kind="stable")]
    chosen: list[PlannedGrasp] = []
    picked: list[NDArray[np.float64]] = []
    rejected: dict[str, int] = {}
    min_gap = prm.diversity * part.length
    for s in range(0, len(order), 64):
        block = order[s : s + 64]
        block = np.array([i for i in block if all(
            _hausdorff(archive.points[i], q) >= min_gap for q in picked)], dtype=np.int64)
        if block.size == 0:
            continue
        chk = check_fingers(part, archive.points[block], archive.normals[block], fingers)
        for j, i in enumerate(block):
            if not chk.mask[j]:
                kind = " ".join(w for w in chk.reasons[j].split() if not any(
                    ch.isdigit() for ch in w)).split("(")[0].strip()
                rejected[kind] = rejected.get(kind, 0) + 1
                continue
            P = archive.points[i]
            if any(_hausdorff(P, q) < min_gap for q in picked):
                continue
            N = archive.normals[i]
            placement = chk.placement(j).to_dict()
            placement["contact_finger"] = list(range(len(P)))
            cond = float(conditioning(score.matrix(P, N)))
            closure = "form" if prm.mu == 0 else "frictional form"
            eps = epsilon_quality(P, N, score.center, score.length, prm.mu, prm.edges)
            c = part.resolve(P, faces=archive.faces[i])
            chosen.append(PlannedGrasp(P.copy(), N.copy(), tuple(c.features[: len(P)]),
                                       archive.regions[i].copy(), float(archive.d[i]), closure,
                                       cond, eps, placement))
            picked.append(P)
            if len(chosen) == prm.top:
                return _sorted(chosen), rejected
    return _sorted(chosen), rejected


def _sorted(grasps: list[PlannedGrasp]) -> list[PlannedGrasp]:
    """Rank by d*; d* equal to 1e-6 (LP noise) are ordered by conditioning."""
    return sorted(grasps, key=lambda g: (-round(g.d_star, 6), -g.conditioning))


def _why_none(archive: _Batch, prm: PlanParams, score: _Scorer) -> str | None:
    """The motion the most promising candidate leaves free (or nearly free), in words.

    Candidates with a positive d* but no (well-conditioned) closure fail because W is rank
    deficient or nearly so: their weakest twist (the last left singular vector of the scaled
    wrench matrix) is reported. Otherwise a twist that lifts the part off its contacts is.
    """
    order = np.argsort(-archive.d, kind="stable")[:20]
    if order.size == 0:
        return None
    best, best_cond = int(order[0]), -1.0
    mats = {}
    for i in order:
        W = score.matrix(archive.points[i], archive.normals[i])
        mats[int(i)] = W
        c = float(conditioning(W))
        if archive.d[i] > 0 and c > best_cond:
            best, best_cond = int(i), c
    W = mats[best]
    if archive.d[best] <= 0:
        if prm.mu == 0:
            return form_closure(W).escape_words
        P, N = archive.points[best], archive.normals[best]
        return frictional_form_closure(P, N, prm.mu, center=score.center,
                                       edges=prm.edges).escape_words
    U, sv, _ = np.linalg.svd(W)
    t = U[:, -1].copy()
    t[3:] /= score.length  # back to part units: W_scaled = diag(1, 1, 1, 1/L, 1/L, 1/L) W
    words = describe_twist(t, score.center, both_senses=True, length=score.length)
    if sv[-1] > 1e-9 * sv[0]:
        words = "nearly " + words + f" (conditioning {sv[-1] / sv[0]:.1e})"
    return words
