"""The grasp search: a pool, seeds, the planar-piece LP, two climbs, selection.

Stages, all reproducible from the seed (the evaluation budget ``PlanParams.evals`` fixes how
much each does; every candidate scored is one evaluation):

1. **Pool.** Contacts sampled uniformly on the exposed surface, kept when they are single face
   contacts a finger can make on its own (exposed, tip fits, approach clear), more than
   ``synth.plan.climb.CLEARANCE`` feature tolerances from every sharp edge (when fewer than
   k are, every single contact is kept); the climbs keep their moves to such contacts too.
2. **Seeds** (``SEED_SHARE`` of the budget). Random k-subsets of the pool, scored in batches
   (:func:`synth.form_closure_batch`). With 7 contacts without friction, ``GREEDY_SHARE`` of
   the budget more are built a contact at a time: six that span the most wrench volume, and
   the seventh that balances them best (:mod:`synth.plan.greedy`).
3. **Region LP** (planar parts). For the best seeds on planar facets, each contact's face grows
   into a convex piece and one LP finds the positions on those pieces with the highest d*
   (:mod:`synth.plan.pieces`); its optimum can lose rank, which the surface climb repairs.
4. **Pool climb** (``POOL_SHARE``). The best distinct seeds climb over the pool: a move swaps
   one contact for a nearby pool contact, one score each (:func:`synth.plan.climb.pool_climb`).
   With 7 contacts without friction the swap climb takes its place (exact best responses,
   :func:`synth.plan.climb.swap_climb`), and ``KICK_SHARE`` of its starts are the best optima
   so far with two contacts replaced, one by a swap the screen rates highly, the other at
   random (iterated local search).
5. **Local pools** (7 contacts without friction). The ``synth.plan.polish.ELITE`` best
   distinct grasps climb by the same exact best responses over contacts drawn close around
   their own, twice, the second time closer; then the ``FINAL_ELITE`` best of all, closer
   still (:func:`synth.plan.polish.local_polish`).
6. **Surface climb** (``SURFACE_SHARE``, in any other case: the local pools take its place).
   The best distinct grasps climb on the surface itself, along the ascent direction of d*
   and by single-contact moves that may cross edges onto neighbouring faces
   (:func:`synth.plan.climb.surface_climb`).
7. **Selection.** Candidates in order of d* pass the finger checks (FCL), ``min_d_star`` and a
   diversity filter; conditioning and the Ferrari-Canny epsilon are computed for the chosen
   ones, and the grasps are ranked by ``rank_by``.

Fitness (which grasps the search prefers) is described in :mod:`synth.plan.batch`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from synth.contacts import Contacts, sample_contacts
from synth.errors import InputError, InternalError
from synth.fingers import Fingers, check_fingers, default_fingers, tip_sinks
from synth.memory import reusing_memory
from synth.part import Part
from synth.plan.batch import GraspBatch, Scorer, distinct_top
from synth.plan.climb import (
    SwapPool,
    clear_of_edges,
    pool_climb,
    reachable,
    surface_climb,
    swap_climb,
    swap_pool,
)
from synth.plan.greedy import greedy_starts
from synth.plan.params import AUTO_MAX_FINGERS, PlanParams
from synth.plan.pieces import best_positions, convex_piece
from synth.plan.placements import (
    Placements,
    finger_climb,
    placement_grasps,
    placement_pool,
    placement_seeds,
)
from synth.plan.polish import ELITE, FINAL_ELITE, FINAL_STEPS, STEPS, local_polish
from synth.plan.ranking import rank_grasps, shown_d_star
from synth.plan.result import Plan, PlannedGrasp, describe_part
from synth.robust import contact_regions
from synth.scores import describe_twist, form_closure, form_closure_batch, frictional_form_closure
from synth.scores.quality import conditioning, epsilon_quality
from synth.scores.surface import surface_scores, worst_reading, worst_reading_batch

__all__ = ["plan_part", "rank_grasps", "Progress", "SEED_SHARE", "POOL_SHARE", "SURFACE_SHARE",
           "PLACEMENT_SHARE", "PLACEMENT_SEED_SHARE", "SWAP_COST", "KICK_SHARE", "GREEDY_SHARE"]

Progress = Callable[[float, str], None]

#: Contacts sampled for the pool (those a finger cannot make are then dropped), and the share
#: of them drawn region by region rather than by area (a small facet's normal matters to
#: closure as much as a large one's: the rim facets of a can).
_POOL = 2500
REGION_SHARE = 1 / 2
#: Shares of the evaluation budget for the seeds, the pool climb and the surface climb. The
#: swap climb (7 contacts without friction) takes the pool climb's place and climbs one seed per
#: ``SWAP_COST`` evaluations of that share.
#:
#: Chosen for a default plan of at most 0.5 s of one core (issue 31). Against the earlier
#: pool of 3,000 and shares 0.3 / 0.5 / 0.12 with 6 surface climbers, on 11 corpus parts
#: (every 4th from the second) x seeds 0-3, run interleaved in one process (CPU seconds of a
#: 2-core VM under a load of 6 to 9): pool 2,000 and seeds 0.15 took the median plan from
#: 0.77 to 0.62 s for a mean first-grasp d* of 0.8946 -> 0.8888; 9 surface climbers 0.61 ->
#: 0.57 s (0.8881); a surface share of 0.08 0.61 -> 0.52 s (0.8834). Each cut costs about
#: as much d* as the others for the time it saves (sweeps 6 -> 4: 0.54 s, 0.8811; pool
#: 1,600: 0.56 s, 0.8808).
SEED_SHARE, POOL_SHARE, SURFACE_SHARE = 0.15, 0.5, 0.08
#: With ``--fingers``: the placement pool, the seeds' share and the placement climb's share (it
#: has no separate surface climb); as before the cuts above, which were measured on the
#: contact search only.
_PLACEMENT_POOL, PLACEMENT_SEED_SHARE, PLACEMENT_SHARE = 3000, 0.3, 0.65
#: Cut from 250 once the swap climb's cyclic order made a climb about 10% cheaper (see
#: :func:`synth.plan.climb.swap_climb`): 100 -> 142 starts at the default budget, for the same
#: CPU time. On all 47 corpus and held-out parts x seeds 0-3 (one process, interleaved), first
#: grasp / reference, mean 0.9472 -> 0.9520 (paired standard error 0.003), at seed 0 min
#: 0.772 -> 0.867, parts >= 0.99 10 -> 11; CPU per plan median 0.373 -> 0.375 s, max 0.566 ->
#: 0.545 s. 150 gave 0.9577 (13 parts >= 0.99 at seed 0) for a median of 0.395 s, 6% more;
#: 200: 0.9486; 150 with the random order: 0.9545 at a median of 0.458 s.
SWAP_COST = 175
#: Share of the swap climb's starts that are kicks (contacts of one of the best optima so far
#: replaced, :func:`synth.plan.climb.swap_climb`) instead of fresh
#: seeds: a swap climb's optimum is the best single swap of every contact over the pool, and
#: a better one is often one or two swaps away. On 4 hard parts at seed 0, the best optimum of
#: 400 fresh seeds came from the first 25 to 200, and 100 kicks of it climbed higher (coffee
#: mug 0.852 -> 0.937 of the reference, Jaco arm 0.908 -> 0.940, lego 0.904 -> 0.939). On all
#: 47 corpus and held-out parts x seeds 0-3 (one process, interleaved), first grasp /
#: reference: mean 0.9289 -> 0.9472, at seed 0 median 0.921 -> 0.956, runs >= 0.99 36 -> 45
#: of 188, median CPU 0.385 -> 0.378 s. A share of 0.75: mean 0.9429; 0.25: 0.9454 against
#: 0.9497 for 0.5 (every second part x seeds 0-1), with one or two contacts replaced at
#: random; with the first of one or two from the screen's best swaps, 0.7: 0.9608 against
#: 0.9636 (every second part x seeds 0-3).
KICK_SHARE = 0.5
#: Share of the budget for greedy starts, built after the random seeds when the swap climb runs
#: (7 contacts without friction, :mod:`synth.plan.greedy`); they and the random seeds compete
#: for the climb's starts by their scores. On all 47 corpus and held-out parts x seeds 0-3 (one
#: process pinned to one CPU, another on the other), first grasp / reference: mean 0.9420 ->
#: 0.9540, runs >= 0.99 36 -> 38 of 188, min 0.847 -> 0.868 (250 starts at the default budget;
#: under mesh 0.9649 -> 0.9733, min 0.631 -> 0.819). Twice the share (500 starts) gave 0.9588,
#: and 512 starts 0.9727 under mesh, but they cost about 0.05 s a plan, and ``db build`` fell
#: to 14,780-15,200 parts an hour, at or below its target of 15,000; 512 starts with the
#: random seeds' share cut to 0.10: 0.9589 against 0.9609 (before the reference was raised).
GREEDY_SHARE = 0.005
#: Best seeds on planar facets given to the region LP.
_LP_SEEDS = 40
#: Least work of each stage, whatever the budget: seeds scored, seeds climbing in the swap
#: climb, surface-climb evaluations.
_MIN_SEEDS, _MIN_SWAPS, _MIN_SURFACE = 1000, 8, 1000
#: Most tries of every contact of a seed in the swap climb.
_SWEEPS = 6
#: Distinct grasps kept from the seeds for the climbs.
_KEEP = 400
#: Ranking by conditioning or epsilon chooses among this many times ``top`` of the best grasps.
_CHOICE = 4
#: Seeds drawn and scored at a time: bounds the memory of the seed stage whatever ``evals``.
_SEED_CHUNK = 32_768
#: Greedy starts built at a time, for the same reason.
_GREEDY_CHUNK = 1024
#: Share of ``PlanParams.time`` the search may use; the finger checks of the selection have
#: the rest, so a plan cut by the clock still returns the grasps it found.
_SEARCH_TIME = 0.9


@reusing_memory
def plan_part(part: Part, params: PlanParams | None = None,
              progress: Progress | None = None) -> Plan:
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

    Examples
    --------
    >>> plan = plan_part(load_part("meshes/cube.stl"), PlanParams(top=3))  # doctest: +SKIP
    >>> plan.grasps[0].d_star  # doctest: +SKIP
    0.5
    """
    prm = params or PlanParams()
    if not isinstance(part, Part):
        raise InputError(f"part: expected a synth.Part (see synth.load_part), got "
                         f"{type(part).__name__}")
    if not isinstance(prm, PlanParams):
        raise InputError(f"params: expected a synth.PlanParams, got {type(prm).__name__}")
    if progress is not None and not callable(progress):
        raise InputError(f"progress: expected a function of (fraction, message), got "
                         f"{type(progress).__name__}")
    t0 = time.perf_counter()
    overrides: dict[str, Any] = {k: v for k, v in (("tip_radius", prm.finger_radius),
                                   ("body_length", prm.body_length),
                                   ("body_radius", prm.body_radius)) if v is not None}
    if prm.approach_cone:
        overrides["approach_cone"] = float(np.radians(prm.approach_cone))
    if prm.support_z is not None:
        overrides["support_plane"] = ((0.0, 0.0, prm.support_z), (0.0, 0.0, 1.0))
    fingers = default_fingers(part, **overrides)
    part_weight(part, prm)  # a density this part's unit cannot turn into a weight: the user's
    try:
        # BLAS on one thread: the search's matrices are small (stacks of 6 x 7, products of a
        # few thousand columns) and OpenBLAS's threads only spin on them (a default plan on a
        # 2-core VM: 1.20 s of CPU with 2 threads, 0.80 s with one; with the other core busy,
        # 3.6 s of wall time against 2.2 s); and the results do not depend on how a library
        # splits its work between threads
        with threadpool_limits(limits=1, user_api="blas"):
            return _search(part, prm, fingers, progress or (lambda f, m: None), t0)
    except InputError as e:  # everything the user gave was accepted above
        raise InternalError(f"the planner failed on {part.source or 'a part'} it accepted: "
                            f"{e}") from e


def _search(part: Part, prm: PlanParams, fingers: Fingers, say: Progress, t0: float) -> Plan:
    """The stages of the search (see the module notes)."""
    deadline = t0 + prm.time
    rng = np.random.default_rng(prm.seed)
    score = Scorer(part, prm, fingers, t0 + _SEARCH_TIME * prm.time)
    k = prm.contacts
    L = float(part.length)
    budget = prm.evals if prm.mu == 0 else max(100, prm.evals // 5)
    if prm.fingers is not None:
        return _search_fingers(part, prm, fingers, score, rng, budget, say, t0)

    say(0.0, "sampling contacts")
    pool = _pool(part, k, rng, fingers)
    say(0.1, f"{len(pool)} reachable contacts in the pool")
    archive, seed_idx = _seeds(pool, k, rng, score, max(_MIN_SEEDS, int(SEED_SHARE * budget)),
                               1e-6 * L)
    swapping = len(pool) > 4 * k and k == 7 and prm.mu == 0
    if swapping:
        swaps = swap_pool(pool, score)
        archive, seed_idx = _greedy_seeds(pool, swaps, rng, score, int(GREEDY_SHARE * budget),
                                          archive, seed_idx, 1e-6 * L)
    say(0.25, f"{score.evaluations} seeds scored, best d* {archive.fit.max(initial=0.0):.4f}")
    lp = _region_lp(part, archive, fingers, score)
    say(0.3, f"region LPs solved: {len(lp)}")
    if len(pool) > 4 * k:
        if swapping:
            n_swap = max(_MIN_SWAPS, int(POOL_SHARE * budget / SWAP_COST))
            n_kick = int(KICK_SHARE * n_swap)
            climbed = swap_climb(pool, seed_idx[:n_swap - n_kick], score, rng, _SWEEPS,
                                 n_kick, (archive.d[:n_swap - n_kick],
                                          archive.fit[:n_swap - n_kick]), swaps)
        else:
            climbed = pool_climb(pool, seed_idx, score, rng, int(POOL_SHARE * budget), L)
        archive = GraspBatch.concat([archive, climbed])
        say(0.5, f"pool climb: best d* {archive.fit.max(initial=0.0):.4f}")
    archive = GraspBatch.concat([archive, lp])
    starts = archive.take(distinct_top(archive, _KEEP, 1e-6 * L))
    if swapping:  # local pools instead of the surface climb
        say(0.5, "refining the best grasps over local pools")
        elite = starts.take(np.arange(min(ELITE, len(starts))))
        archive = GraspBatch.concat([archive, local_polish(part, elite, score, fingers, rng,
                                                           STEPS)])
        best = archive.take(distinct_top(archive, FINAL_ELITE, 1e-6 * L))
        say(0.8, f"refining the best {len(best)} closer, best d* "
                 f"{max(0.0, archive.fit.max(initial=0.0)):.4f}")
        archive = GraspBatch.concat([archive, local_polish(part, best, score, fingers, rng,
                                                           FINAL_STEPS)])
    else:
        climbed = surface_climb(
            part, starts, score, fingers, rng, max(_MIN_SURFACE, int(SURFACE_SHARE * budget)),
            lambda best: say(0.5 + 0.4 * min(1.0, score.evaluations / budget),
                             f"climbing: best d* {max(0.0, best):.4f}"))
        archive = GraspBatch.concat([archive, climbed])

    say(0.9, "checking fingers")
    grasps, rejected, near, cut = _select(part, archive, prm, fingers, score, deadline)
    stopped_by_time = score.timed_out or time.perf_counter() > deadline
    total = time.perf_counter() - t0
    escape = None
    if grasps:
        kind = "frictional form" if prm.mu > 0 else "form"
        message = (f"{len(grasps)} {kind}-closure grasp{'s' * (len(grasps) > 1)}"
                   f"{_fewer(len(grasps), rejected, near, cut, _below(archive, prm), prm)}, "
                   f"best d* {grasps[0].d_star:.4f} "
                   f"({score.evaluations} grasps evaluated in {total:.1f} s)")
    elif prm.min_d_star > 0 and (archive.fit > 0).any():
        message = (f"no grasp reached --min-d-star {prm.min_d_star:g}: the best closure grasp "
                   f"found has d* {archive.fit.max():.4f}")
    elif stopped_by_time and (archive.fit > 0).any():
        message = (f"{int((archive.fit > 0).sum())} closure grasps were found, but the time "
                   f"limit passed before one of them passed the finger checks")
    elif rejected:
        message = (f"{sum(rejected.values())} closure grasps were found but none was kept: "
                   f"{_dropped(rejected, prm)}")
    elif not stopped_by_time and len(archive) and not (
            (archive.fit > _OVERLAP) & (archive.d > 0)).any() and (
            (archive.d > 0).any() or not (archive.fit > _OVERLAP).any()):
        message = _crowded(archive, prm, fingers, L)
    elif score.above_floor and not (archive.fit > 0).any():
        escape = _why_none(archive, prm, score)
        message = (f"{score.above_floor} closure grasps were found, but none within the "
                   f"physical floor: the best needs {score.least_above:.2f} times the part's "
                   f"weight per finger to hold it in every orientation, above --max-squeeze "
                   f"{prm.floor:g}" + (f"; the best candidate is {escape}" if escape else "")
                   + _revolution_note(prm, escape)
                   + ((f"; {'if it is not, ' if _revolution_note(prm, escape) else ''}a budget "
                       f"above --evals {prm.evals} may find one that holds")
                      if prm.evals < PlanParams().evals else "")
                   + "; --max-squeeze 0 returns them anyway")
    else:
        escape = _why_none(archive, prm, score)
        kind = "with friction mu = %g" % prm.mu if prm.mu > 0 else "without friction"
        message = f"no {k}-contact closure grasp {kind} was found" + (
            f"; the best candidate is {escape}" if escape else "")
        message += _revolution_note(prm, escape)
        turn = prm.mu == 0 and escape and "rotate about" in escape
        if prm.evals < PlanParams().evals:
            message += (f"; {'if it is not, ' if turn else ''}a budget above --evals "
                        f"{prm.evals} may find one")
    if stopped_by_time:
        message += _cut_note(prm, score, budget)
    say(1.0, "done")
    return Plan(tuple(grasps), message, describe_part(part), prm.to_dict(), fingers.to_dict(),
                score.evaluations, total, stopped_by_time, escape)


def _search_fingers(part: Part, prm: PlanParams, fingers: Fingers, score: Scorer,
                    rng: np.random.Generator, budget: int, say: Progress, t0: float) -> Plan:
    """Grasps of ``prm.fingers`` fingertips (or the fewest that hold, for ``"auto"``), the
    contacts following from where they land (:mod:`synth.plan.placements`). ``"auto"`` tries
    2, 3, ... fingers, each with the whole search effort, and stops at the first count that
    gives a grasp; counts whose tips cannot make enough contacts are skipped."""
    L = float(part.length)
    deadline = t0 + prm.time
    say(0.0, "sampling finger placements")
    pool = placement_pool(part, fingers, rng, _PLACEMENT_POOL, _PLACEMENT_POOL // 3,
                          _PLACEMENT_POOL // 10)
    need = 7 if prm.mu == 0 else 3
    most = int(pool.count.max()) if len(pool) else 1
    counts = list(range(2, AUTO_MAX_FINGERS + 1)) if prm.fingers == "auto" else [
        int(prm.fingers)]  # type: ignore[arg-type]
    counts = [F for F in counts if F <= len(pool) and F * most >= need]
    grasps: list[PlannedGrasp] = []
    rejected: dict[str, int] = {}
    tried: list[int] = []
    for n, F in enumerate(counts):
        if score.out_of_time():
            break
        tried.append(F)
        n_seed = max(_MIN_SEEDS, int(PLACEMENT_SEED_SHARE * budget))
        archives: dict[int, list[GraspBatch]] = {}
        chosen, fit = np.zeros((0, F), np.int64), np.zeros(0)
        for s in range(0, n_seed, _SEED_CHUNK):  # the best _KEEP seeds, a chunk at a time
            if score.out_of_time():
                break
            more = placement_seeds(pool, min(_SEED_CHUNK, n_seed - s), F, rng)
            more_fit = np.full(len(more), -np.inf)
            for kk, (g, rows) in placement_grasps(pool, more, score).items():
                more_fit[rows] = g.fit
                archives.setdefault(kk, []).append(g.take(distinct_top(g, _KEEP, 1e-6 * L)))
            chosen, fit = np.concatenate([chosen, more]), np.concatenate([fit, more_fit])
            order = np.argsort(-fit, kind="stable")[:_KEEP]
            chosen, fit = chosen[order], fit[order]
        climbed = finger_climb(pool, chosen, fit, score, rng, int(PLACEMENT_SHARE * budget), L)
        for kk, g in climbed.items():
            archives.setdefault(kk, []).append(g)
        say((n + 1) / (len(counts) + 1), f"{F} fingers searched")
        found: list[PlannedGrasp] = []
        for kk, parts in archives.items():
            if kk < need:
                continue
            picked, rej, _, _ = _select(part, GraspBatch.concat(parts), prm, fingers, score,
                                        deadline)
            found.extend(picked)
            for key, v in rej.items():
                rejected[key] = rejected.get(key, 0) + v
        if found:
            grasps = rank_grasps(found, prm.rank_by)[: prm.top]
            break
        if score.timed_out:
            break
    stopped_by_time = score.timed_out or time.perf_counter() > deadline
    total = time.perf_counter() - t0
    kind = "frictional form" if prm.mu > 0 else "form"
    if grasps:
        message = (f"{len(grasps)} {kind}-closure grasp{'s' * (len(grasps) > 1)} with "
                   f"{tried[-1]} fingers, best d* "
                   f"{grasps[0].d_star:.4f} with {len(grasps[0].points)} contacts "
                   f"({score.evaluations} grasps evaluated in {total:.1f} s)")
    elif not len(pool):
        message = (f"no {kind}-closure grasp: a fingertip of radius {fingers.tip_radius:.4g} fits "
                   f"nowhere on the exposed surface; try a smaller --finger-radius")
    elif not tried and counts:
        message = (f"no {kind}-closure grasp: the time limit (--time {prm.time:g} s) passed "
                   f"before the search began ({_placement_counts(pool)})")
    elif not tried:
        message = (f"no {kind}-closure grasp: {prm.fingers} fingers cannot make the {need} "
                   f"contacts {kind} closure needs (on this part a fingertip makes at most "
                   f"{most}: {_placement_counts(pool)})")
    else:
        message = (f"no {kind}-closure grasp with {', '.join(map(str, tried))} fingers was "
                   f"found ({_placement_counts(pool)})")
        if prm.evals < PlanParams().evals:
            message += f"; a budget above --evals {prm.evals} may find one"
        if rejected:
            message += f"; grasps were dropped: {_dropped(rejected, prm)}"
    if stopped_by_time and tried:
        message += _cut_note(prm, score, budget)
    say(1.0, "done")
    return Plan(tuple(grasps), message, describe_part(part), prm.to_dict(), fingers.to_dict(),
                score.evaluations, total, stopped_by_time, None)


#: The key of ``_select``'s rejection counts for grasps below ``--min-tolerance``.
_LOW_TOLERANCE = "placement tolerance below --min-tolerance"
_ABOVE_FLOOR = "needs more squeeze than --max-squeeze"


def _revolution_note(prm: PlanParams, escape: str | None) -> str:
    """The hint for a frictionless search whose best candidate (nearly) turns freely."""
    if prm.mu == 0 and escape and "rotate about" in escape:
        return (". If the part is a surface of revolution (sphere, cylinder, torus), no number "
                "of frictionless contacts stops that turn: try --mu > 0 with --contacts 3 or 4")
    return ""


def _dropped(rejected: dict[str, int], prm: PlanParams) -> str:
    """Why found grasps were dropped, in words: the finger checks' most common reason, and
    how many fell below ``--min-tolerance``."""
    parts = []
    fingers = {k: v for k, v in rejected.items() if k not in (_LOW_TOLERANCE, _ABOVE_FLOOR)}
    if fingers:
        reason, _ = max(fingers.items(), key=lambda kv: kv[1])
        parts.append(f"{sum(fingers.values())} the fingers could not make (most often: "
                     f"{reason}; try a smaller --finger-radius or a wider --approach-cone)")
    if rejected.get(_LOW_TOLERANCE):
        parts.append(f"{rejected[_LOW_TOLERANCE]} with a placement tolerance below "
                     f"--min-tolerance {prm.min_tolerance:g}")
    if rejected.get(_ABOVE_FLOOR):
        parts.append(f"{rejected[_ABOVE_FLOOR]} whose fingers would need more than "
                     f"--max-squeeze {prm.max_squeeze:g} times the part's weight to hold it")
    return "; ".join(parts)


def _fewer(n: int, rejected: dict[str, int], near: int, cut: bool, below: int,
           prm: PlanParams) -> str:
    """Why a plan kept fewer grasps than ``--top`` asked for, in words ("" when it did not):
    only the causes that happened (``near``: candidates within ``diversity`` of a kept one;
    ``cut``: the time limit stopped the checks; ``below``: closure grasps under
    ``--min-d-star``)."""
    if n >= prm.top:
        return ""
    if cut:
        return f" of the {prm.top} asked for (the time limit passed before the rest were checked)"
    why = []
    if near:
        why.append(f"had their contacts within {100 * prm.diversity:g}% of the part's size of "
                   f"one of these")
    if rejected:
        why.append(f"were dropped: {_dropped(rejected, prm)}")
    if below:
        why.append(f"had d* below --min-d-star {prm.min_d_star:g}")
    found = (f"the other closure grasps found {' or '.join(why)}" if why
             else "the search found no other closure grasps")
    return f" of the {prm.top} asked for ({found}; a larger --evals may find more)"


def _below(archive: GraspBatch, prm: PlanParams) -> int:
    """Closure grasps of the search under ``--min-d-star``."""
    return int(((archive.fit > 0) & (archive.fit < prm.min_d_star)).sum())


#: The fitness of a candidate whose fingertips overlap (:mod:`synth.plan.batch`).
_OVERLAP = -2.0


def _crowded(archive: GraspBatch, prm: PlanParams, fingers: Fingers, L: float) -> str:
    """The message of a search whose every candidate that could hold the part (or every
    candidate at all) puts two fingertips on top of each other: the fingers are too large."""
    from synth.fingers.model import DEFAULT_TIP_RELATIVE_RADIUS

    r, share = float(fingers.tip_radius), DEFAULT_TIP_RELATIVE_RADIUS
    which = "every candidate with d* > 0" if (archive.d > 0).any() else "every candidate"
    return (f"no {prm.contacts}-contact grasp with its fingertips apart was found: in {which}, "
            f"two fingertips of radius {r:.4g} would overlap (their centres closer than "
            f"{2 * r:.4g}), so the fingers are too large for this part ({L:.4g} across its "
            f"bounding box); try a smaller --finger-radius (the default is {100 * share:g}% "
            f"of that, {share * L:.3g})")


def _cut_note(prm: PlanParams, score: Scorer, budget: int) -> str:
    """The end of a message of a search the clock stopped."""
    return (f"; stopped at the time limit (--time {prm.time:g} s) after {score.evaluations:,} "
            f"evaluations (budget {budget:,}), so this result depends on the machine's "
            f"speed (a larger --time lets the search finish)")


def _placement_counts(pool: Placements) -> str:
    """Finger placements of the pool by kind, in words."""
    n = np.bincount(pool.count, minlength=4)
    return (f"{len(pool)} finger placements: {n[1]} on faces, edges or vertices, {n[2]} in "
            f"grooves, {n[3]} in inside corners")


def _pool(part: Part, k: int, rng: np.random.Generator, fingers: Fingers) -> GraspBatch:
    """Single face contacts of the exposed surface a finger can make, as one-contact grasps:
    area-uniform, and ``REGION_SHARE`` of them spread evenly over the face regions."""
    n_reg = int(REGION_SHARE * _POOL)
    c = Contacts.concatenate([sample_contacts(part, _POOL - n_reg, seed=rng, method="uniform"),
                              sample_contacts(part, n_reg, seed=rng, method="regions")])
    single = np.bincount(c.finger)[c.finger] == 1
    keep = (c.features == "face") & single
    keep[keep] &= clear_of_edges(part, c.points[keep])
    if keep.sum() < k:
        keep = single
    keep[keep] &= reachable(part, c.points[keep], c.normals[keep], fingers)
    return GraspBatch.of_contacts(c, keep)


def _seeds(pool: GraspBatch, k: int, rng: np.random.Generator, score: Scorer, n: int,
           scale: float) -> tuple[GraspBatch, NDArray[np.int64]]:
    """The best ``_KEEP`` distinct (at ``scale``) of ``n`` random k-subsets of the pool,
    scored, and their pool indices (m, k); drawn ``_SEED_CHUNK`` at a time, until the
    scorer's deadline."""
    size = len(pool)
    best = GraspBatch(np.zeros((0, k, 3)), np.zeros((0, k, 3)), np.zeros((0, k, 3)),
                      np.zeros((0, k), np.int64), np.zeros((0, k), np.int64), np.zeros(0),
                      np.zeros(0))
    best_idx = np.zeros((0, k), np.int64)
    if size < k:
        return best, best_idx
    for s in range(0, n, _SEED_CHUNK):
        if score.out_of_time():
            break
        m = min(_SEED_CHUNK, n - s)
        idx = np.argsort(rng.random((m, size)), axis=1)[:, :k] if size <= 64 else (
            _distinct_rows(rng, m, size, k))
        best, best_idx = _keep_best(pool, idx, score, best, best_idx, scale)
    return best, best_idx


def _keep_best(pool: GraspBatch, idx: NDArray[np.int64], score: Scorer, best: GraspBatch,
               best_idx: NDArray[np.int64], scale: float
               ) -> tuple[GraspBatch, NDArray[np.int64]]:
    """The pool's contact sets ``idx`` (m, k) scored, and the best ``_KEEP`` distinct (at
    ``scale``) of them and ``best`` (with its pool indices ``best_idx``), with theirs."""
    m = len(idx)
    b = GraspBatch(pool.points[idx, 0], pool.normals[idx, 0], pool.smooth[idx, 0],
                   pool.faces[idx, 0], pool.regions[idx, 0], np.zeros(m), np.zeros(m))
    score.score(b)
    merged = GraspBatch.concat([best, b])
    merged_idx = np.concatenate([best_idx, idx])
    top = distinct_top(merged, _KEEP, scale)
    return merged.take(top), merged_idx[top]


def _greedy_seeds(pool: GraspBatch, swaps: SwapPool, rng: np.random.Generator, score: Scorer,
                  n: int, best: GraspBatch, best_idx: NDArray[np.int64], scale: float
                  ) -> tuple[GraspBatch, NDArray[np.int64]]:
    """The seeds ``best`` with pool indices ``best_idx`` (m, 7) and ``n`` greedy starts
    (:func:`synth.plan.greedy.greedy_starts`), scored: the best ``_KEEP`` distinct (at
    ``scale``) of both, and their pool indices."""
    for s in range(0, n, _GREEDY_CHUNK):  # bounded memory (about 0.1 MB a start) at any budget
        if score.out_of_time():
            break
        idx = greedy_starts(swaps, rng, min(_GREEDY_CHUNK, n - s))
        best, best_idx = _keep_best(pool, idx, score, best, best_idx, scale)
    return best, best_idx


def _region_lp(part: Part, archive: GraspBatch, fingers: Fingers, score: Scorer
               ) -> GraspBatch:
    """Grasps from the planar-piece LP on the faces of the best seeds on planar facets."""
    k = archive.points.shape[1]
    found = []
    tuples_seen: set[tuple[int, ...]] = set()
    for i in range(min(_LP_SEEDS, len(archive))):
        if score.out_of_time():
            break
        faces = archive.faces[i]
        if not all(part.regions[int(part.face_region[f])].planar for f in faces):
            continue
        pieces = [convex_piece(part, f, fingers.tip_radius) for f in faces.tolist()]
        pcs = [p for p in pieces if p is not None]
        if len(pcs) < len(pieces):
            continue
        key = tuple(sorted(id(p) for p in pcs))
        if key in tuples_seen:
            continue
        tuples_seen.add(key)
        if not _spans_forces(np.array([p.normal for p in pcs])):
            continue  # no positions on these pieces can balance every force
        sol = best_positions(pcs, score.center, score.length)
        if sol is None:
            continue
        c = part.resolve(sol[0], snap=True)
        if (len(c) != k or not clear_of_edges(part, c.points).all()
                or not part.exposed(c.points, c.normals).all()):
            continue
        found.append(GraspBatch(c.points[None], c.normals[None], c.smooth_normals[None],
                                c.faces[None], c.region[None], np.zeros(1), np.zeros(1)))
    if not found:
        return archive.take(np.zeros(0, np.int64))
    lp = GraspBatch.concat(found)
    score.score(lp)
    return lp


def _spans_forces(normals: NDArray[np.float64]) -> bool:
    """Necessary condition for form closure: the normals positively span 3-D force space,
    i.e. the origin is strictly inside their convex hull (Trinkle's test on the 3 x k force
    rows alone)."""
    return bool(form_closure_batch(normals.T[None], compiled=False).closure[0])


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


def _hold(P: NDArray[np.float64], N: NDArray[np.float64], S: NDArray[np.float64],
          finger: NDArray[np.int64], prm: PlanParams, score: Scorer) -> tuple[float, str]:
    """The least finger force per weight that holds a grasp in every orientation
    (:func:`synth.scores.hold.finger_hold_batch`), the larger over the surface model's
    readings of the normals, and the hand model it is exact for."""
    from synth.scores.hold import finger_hold_batch

    worst, model = 0.0, "stiff"
    for n in score.readings(N, S):
        h = finger_hold_batch(P[None], n[None], score.center, score.length, prm.mu,
                              finger[None], prm.edges)
        worst, model = max(worst, float(h.squeeze_per_weight[0])), h.model
    return worst, model


def part_weight(part: Part, prm: PlanParams) -> float | None:
    """The part's weight in newtons from ``prm.mass`` or ``prm.density`` (None without).

    Raises
    ------
    InputError
        A density for a part whose unit is unknown, or that has no closed body.
    """
    from synth.scores.gravity import GRAVITY

    if prm.mass is not None:
        return prm.mass * GRAVITY
    if prm.density is None:
        return None
    if part.units is None:
        raise InputError("density: the part's unit is unknown, so its volume in m^3 is too; "
                         "give --units, or --mass instead")
    if part.volume <= 0:
        raise InputError("density: the part has no closed body, so no volume; give --mass")
    import trimesh

    metres = float(trimesh.units.unit_conversion(part.units, "meters"))
    return prm.density * part.volume * metres**3 * GRAVITY


def _select(part: Part, archive: GraspBatch, prm: PlanParams, fingers: Fingers, score: Scorer,
            deadline: float) -> tuple[list[PlannedGrasp], dict[str, int], int, bool]:
    """Best valid grasps that pass the finger checks, ``min_d_star`` and the diversity filter,
    ranked by ``prm.rank_by``; a count of the finger-check failures by kind; how many
    candidates the diversity filter passed over; and whether the deadline stopped the checks
    with candidates left.

    Ranking by d*, candidates are taken in the order of the ranking itself (shown d*, ties
    by conditioning, computed for all at once), so the first grasps do not depend on
    ``top``: asking for fewer gives the first rows of a longer list. Ranking by another
    measure, up to ``_CHOICE`` times ``top`` such grasps are gathered in order of d*, then
    ranked, so that it chooses among the best grasps, not among all.
    Candidates are checked 64 at a time; after ``deadline`` (a ``time.perf_counter()``
    value) no further block is started, and no further candidate is taken once one grasp is
    chosen, but the first block is always checked, so a search the clock cut still returns
    the best grasp it found when one of the 64 best passes the finger checks."""
    valid = np.flatnonzero((archive.fit > 0) & (archive.fit >= prm.min_d_star))
    order = valid[np.argsort(-archive.fit[valid], kind="stable")]
    ranked_cond: dict[int, float] = {}  # ranking by d*: each candidate's conditioning
    if prm.rank_by == "d_star" and len(order):
        P = archive.points[order]
        cond_all = worst_reading_batch(lambda n, rows: conditioning(score.matrix(P[rows], n)),
                                       archive.normals[order], archive.smooth[order],
                                       prm.surface)
        shown = np.array([shown_d_star(float(d)) for d in archive.d[order]])
        perm = np.lexsort((-cond_all, -shown))  # the ranking's own order, stable
        order, cond_all = order[perm], cond_all[perm]
        ranked_cond = dict(zip(order.tolist(), cond_all.tolist(), strict=True))
    weight = part_weight(part, prm)
    chosen: list[PlannedGrasp] = []
    picked: list[NDArray[np.float64]] = []
    rejected: dict[str, int] = {}
    min_gap = prm.diversity * part.length
    want = prm.top * (_CHOICE if prm.rank_by != "d_star" else 1)

    def conditioning_of(P: NDArray[np.float64], n: NDArray[np.float64]) -> float:
        return float(conditioning(score.matrix(P, n)))

    def epsilon_of(P: NDArray[np.float64], n: NDArray[np.float64]) -> float:
        return epsilon_quality(P, n, score.center, score.length, prm.mu, prm.edges)

    near, cut = 0, False
    for s in range(0, len(order), 64):
        if s > 0 and time.perf_counter() > deadline:  # the first block is always checked
            cut = True
            break
        block = order[s : s + 64]
        size = len(block)
        block = np.array([i for i in block if all(
            _hausdorff(archive.points[i], q) >= min_gap for q in picked)], dtype=np.int64)
        near += size - len(block)
        if block.size == 0:
            continue
        chk = check_fingers(part, archive.points[block], archive.normals[block], fingers,
                            archive.finger[block])
        for j, i in enumerate(block.tolist()):
            if chosen and time.perf_counter() > deadline:
                cut = True
                break
            if not chk.mask[j]:
                kind = " ".join(w for w in chk.reasons[j].split() if not any(
                    ch.isdigit() for ch in w)).split("(")[0].strip()
                rejected[kind] = rejected.get(kind, 0) + 1
                continue
            P = archive.points[i]
            if any(_hausdorff(P, q) < min_gap for q in picked):
                near += 1
                continue
            N, S = archive.normals[i], archive.smooth[i]
            where = chk.placement(j)
            placement = where.to_dict()
            placement["contact_finger"] = where.contact_finger.tolist()
            placement["tip_sink"] = float(tip_sinks(part, where.tip_centers, where.tip_radius)
                                          .max(initial=0.0))
            both = surface_scores(P[None], N[None], S[None], prm.surface, score.center,
                                  score.length, prm.mu, prm.edges, compiled=False)
            cond = ranked_cond[i] if ranked_cond else worst_reading(
                partial(conditioning_of, P), N, S, prm.surface)
            closure = "form" if prm.mu == 0 else "frictional form"
            eps = worst_reading(partial(epsilon_of, P), N, S, prm.surface)
            robust = contact_regions(part, P, N, mu=prm.mu, edges=prm.edges,
                                     d_star=float(archive.d[i]), smooth=S,
                                     surface=prm.surface) if prm.wants_regions else None
            if robust is not None and robust.tolerance < prm.min_tolerance:
                rejected[_LOW_TOLERANCE] = rejected.get(_LOW_TOLERANCE, 0) + 1
                continue
            spw, model = _hold(P, N, S, archive.finger[i], prm, score)
            if not spw <= prm.floor:
                rejected[_ABOVE_FLOOR] = rejected.get(_ABOVE_FLOOR, 0) + 1
                continue
            least = None if weight is None else spw * weight
            margin = None if least is None or prm.grip is None else prm.grip / least
            chosen.append(PlannedGrasp(P.copy(), N.copy(), _features(part, P, archive.faces[i]),
                                       archive.regions[i].copy(), float(archive.d[i]), closure,
                                       cond, eps, placement, robust, S.copy(),
                                       float(both.d_mesh[0]), float(both.d_smooth[0]),
                                       spw, model, least, margin))
            picked.append(P)
            if len(chosen) == want:
                return rank_grasps(chosen, prm.rank_by)[: prm.top], rejected, near, False
    return rank_grasps(chosen, prm.rank_by)[: prm.top], rejected, near, cut


def _features(part: Part, P: NDArray[np.float64], faces: NDArray[np.int64]) -> tuple[str, ...]:
    """Feature (face, edge or vertex) of each contact (a point in a groove resolves to a
    contact on each face; the one on the contact's own face is its)."""
    c = part.resolve(P, faces=faces)
    out = []
    for j in range(len(P)):
        rows = np.flatnonzero(c.finger == j)
        own = rows[c.faces[rows] == faces[j]]
        out.append(str(c.features[own[0] if len(own) else rows[0]]))
    return tuple(out)


def _why_none(archive: GraspBatch, prm: PlanParams, score: Scorer) -> str | None:
    """The motion the most promising candidate leaves free (or nearly free), in words.

    Candidates with a positive d* but no (well-conditioned) closure fail because W is rank
    deficient or nearly so: their weakest twist (the last left singular vector of the scaled
    wrench matrix) is reported. Otherwise a twist that lifts the part off its contacts is.
    """
    order = np.argsort(-archive.d, kind="stable")[:20]
    if order.size == 0:
        return None
    best, best_cond = int(order[0]), -1.0
    mats: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    for i in order:
        P = archive.points[i]
        # the reading of the normals (under the surface model) that holds the grasp least
        cands = [(score.matrix(P, n), n) for n in score.readings(archive.normals[i],
                                                                   archive.smooth[i])]
        W, n = min(cands, key=lambda wn: float(conditioning(wn[0])))
        if prm.mu == 0 and archive.d[i] <= 0:
            W, n = min(cands, key=lambda wn: form_closure(wn[0]).d_star)
        mats[int(i)] = W, n
        c = float(conditioning(W))
        if archive.d[i] > 0 and c > best_cond:
            best, best_cond = int(i), c
    W, N = mats[best]
    if archive.d[best] <= 0:
        if prm.mu == 0:
            return form_closure(W).escape_words
        return frictional_form_closure(archive.points[best], N, prm.mu, center=score.center,
                                       edges=prm.edges).escape_words
    U, sv, _ = np.linalg.svd(W)
    t = U[:, -1].copy()
    t[3:] /= score.length  # back to part units: W_scaled = diag(1, 1, 1, 1/L, 1/L, 1/L) W
    words = describe_twist(t, score.center, both_senses=True, length=score.length)
    if sv[-1] > 1e-9 * sv[0]:
        words = "nearly " + words + f" (conditioning {sv[-1] / sv[0]:.1e})"
    return words
