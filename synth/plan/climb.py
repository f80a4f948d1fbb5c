"""Local search: a population of grasps climbing d*, first over a pool of contacts, then on
the surface.

Both climbs share one scheme (:class:`Population`): each round every member proposes moves,
takes its best improving one and widens its step (x ``GROW``), or narrows it (x ``SHRINK``);
a member whose step falls below a floor has converged, is set aside and restarts from the next
unused seed. Restarts beat long climbs on parts with many local optima.

* :func:`swap_climb` (7 contacts without friction) moves over a pool of contacts already
  checked (exposed, reachable by a finger, single face contacts clear of sharp edges, see
  ``CLEARANCE``) by best responses: for one contact at a time it scores *every* pool contact
  as its replacement and takes the best. The null vector of a 6 x 7 wrench matrix is its
  generalised cross product, ``v_i = (-1)^i det(W without column i)``; with column ``j``
  replaced by ``x`` every ``v_i`` (i != j) is a linear function ``c_i . x`` of ``x`` (its
  cofactors) and ``v_j`` does not change, so the d* of all replacements costs one 6 x 6 by
  6 x n product: exact, and a few microseconds for a thousand candidates.
* :func:`pool_climb` (any other case) moves over the same pool: a move swaps one contact for
  the pool contact nearest a Gaussian step away from it, one score each.
* :func:`surface_climb` moves on the surface itself: steps of all contacts along the ascent
  direction of d* (:mod:`synth.plan.ascent`, 7 contacts without friction) at four step sizes,
  and single-contact Gaussian moves in the tangent plane, snapped back onto the surface (so
  they cross edges onto neighbouring faces, and kept only as single face contacts clear of
  sharp edges). A member takes its best improving proposal whose moved contacts are exposed
  and reachable (checked for the few best only: those checks cost the most).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from synth.fingers import Fingers, check_fingers
from synth.part.clearance import sharp_clearance
from synth.part.resolve import closest_points
from synth.plan.ascent import ascent_directions
from synth.plan.batch import GraspBatch, Scorer
from synth.scores.surface import differs

__all__ = ["GROW", "SHRINK", "FIRST_STEP", "CLEARANCE", "Population", "SwapPool", "pool_climb",
           "surface_climb", "swap_climb", "swap_pool", "reachable", "clear_of_edges"]

#: A planned contact lies more than this many feature tolerances from every sharp edge of the
#: part, so that it is a face contact on the file's own vertices as on the welded mesh (a
#: contact just past the tolerance from a sharp edge of a narrow neighbouring face was called
#: a face contact, with the normal of its face, where the file's vertices put the face across
#: that edge within the tolerance: tests/test_part_scale.py).
CLEARANCE = 2.0
#: Step-size factors after a round with and without an improvement.
GROW, SHRINK = 1.5, 0.7
#: First (and largest) step of the pool climb and the placement climb, relative to the part's
#: length.
FIRST_STEP = 0.05
#: Surface climb: first (and largest) step and the step below which a member has converged,
#: relative to the part's length. Its seeds come out of the swap climb already refined, so
#: it starts finer than the pool climb (corpus, seeds 0-5: mean planner/reference d* 0.988
#: -> 0.992, median 0.981 -> 0.986, runs below the reference 72% -> 68%, against 0.05).
_SURFACE_FIRST_STEP = 0.02
_MIN_STEP = 1e-4
#: Pool climb: members and single-contact moves each proposes per round.
_POOL_MEMBERS, _POOL_MOVES = 16, 32
#: Surface climb: members, single-contact moves per round, steps along the ascent direction
#: (in units of the member's step) and improving proposals checked per member and round.
#: Six members rather than twelve give the best seeds twice the rounds (corpus, seeds 0-3,
#: with the surface share of the budget cut from 0.15 to 0.12 to keep the planning time: mean
#: planner/reference d* 0.996 -> 0.997, median 0.988 -> 0.992, runs below it 63% -> 60%).
#: Nine rather than six now (issue 31: fewer, larger rounds; on 11 corpus parts x seeds 0-3
#: the median plan 0.62 -> 0.57 s of CPU for a mean first-grasp d* of 0.8888 -> 0.8881).
_SURFACE_MEMBERS, _SURFACE_MOVES = 9, 24
_GRADIENT_STEPS = (2.0, 1.0, 0.5, 0.25)
_CHECKED = 3
#: Swap climb: replacements of each member confirmed by the full scorer (rank, conditioning)
#: per try. The screened best alone: over 11 corpus parts, of 9,609 tries with a hopeful
#: screen the screened best was confirmed in 7,806, and one of the best three in 7,859, so
#: checking three tripled the confirmations for 0.7% more moves.
_SWAP_CHECKED = 1
#: The swap screen's d* is computed in float32 (half the memory traffic of its products of a
#: few thousand columns); a screened gain below this is round-off.
_SCREEN_TOL = 1e-6
_TINY32 = np.finfo(np.float32).tiny
#: Members the screen takes at a time: its (M, 6, n) float32 products then stay in the cache
#: (250 greedy starts over a pool of 2,000 contacts: 9.7 ms at once, 4.5 ms 64 at a time, 4.8 ms
#: 32 at a time, on the corpus parts' pools).
_SCREEN_ROWS = 64
#: Swap climb: members climbing side by side.
_SWAP_MEMBERS = 32


def clear_of_edges(part: Any, points: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which points (n, 3) lie more than ``CLEARANCE`` feature tolerances from every sharp
    edge of the part (:mod:`synth.part.clearance`)."""
    return np.isinf(sharp_clearance(part, points, CLEARANCE * part.feature_tolerance))


def reachable(part: Any, points: NDArray[np.float64], normals: NDArray[np.float64],
              fingers: Fingers) -> NDArray[np.bool_]:
    """Which single contacts (n, 3) a finger can make on its own (tip fits, approach clear)."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    return check_fingers(part, points[:, None, :], normals[:, None, :], fingers,
                         depths=False).mask


class Population:
    """Members climbing side by side, their steps, and restarts from a queue of seeds.

    Parameters
    ----------
    seeds : GraspBatch
        Starting grasps, best first; the first ``size`` climb, the rest wait.
    size : int
    first_step, min_step : float
        Step size at a (re)start and the floor below which a member has converged.
    tags : (n, k) int, optional
        Extra per-seed state that moves with the members (the pool climb's pool indices).
    """

    def __init__(self, seeds: GraspBatch, size: int, first_step: float, min_step: float,
                 tags: NDArray[np.int64] | None = None) -> None:
        n = min(size, len(seeds))
        self.seeds, self.seed_tags = seeds, tags
        self.members = seeds.take(np.arange(n))
        self.tags = None if tags is None else tags[:n].copy()
        self.next = n
        self.step = np.full(n, first_step)
        self.first_step, self.min_step = first_step, min_step
        self.done: list[GraspBatch] = []

    def __len__(self) -> int:
        return len(self.members)

    def advance(self, winners: NDArray[np.int64], cand: GraspBatch, src: NDArray[np.int64],
                cand_tags: NDArray[np.int64] | None = None) -> None:
        """Members ``winners`` move to candidates ``src``; then update every step, set aside
        the converged members and restart them from the waiting seeds."""
        self.members.put(winners, cand, src)
        if self.tags is not None and cand_tags is not None:
            self.tags[winners] = cand_tags[src]
        improve = np.zeros(len(self), bool)
        improve[winners] = True
        self.step = np.where(improve, np.minimum(self.step * GROW, self.first_step),
                             self.step * SHRINK)
        conv = np.flatnonzero(self.step < self.min_step)
        if not len(conv):
            return
        self.done.append(self.members.take(conv))
        fresh = min(len(conv), len(self.seeds) - self.next)
        slots, src_i = conv[:fresh], np.arange(self.next, self.next + fresh)
        self.members.put(slots, self.seeds, src_i)
        if self.tags is not None and self.seed_tags is not None:
            self.tags[slots] = self.seed_tags[src_i]
        self.step[slots] = self.first_step
        self.next += fresh
        keep = np.setdiff1d(np.arange(len(self)), conv[fresh:])
        self.members, self.step = self.members.take(keep), self.step[keep]
        if self.tags is not None:
            self.tags = self.tags[keep]

    def result(self) -> GraspBatch:
        """Every member, climbing or converged."""
        return GraspBatch.concat([self.members, *self.done])


def _best_per_member(who: NDArray[np.int64], fit: NDArray[np.float64], current: NDArray[np.float64]
                     ) -> NDArray[np.int64]:
    """Candidates that improve their member, best first within each member (grouped by
    member), as indices into ``who``/``fit``."""
    better = np.flatnonzero(fit > current[who] + 1e-12)
    return better[np.lexsort((better, -fit[better], who[better]))]


def _first_of_each(who: NDArray[np.int64], rows: NDArray[np.int64]) -> NDArray[np.int64]:
    """The first of ``rows`` (grouped by member ``who[rows]``) of each member."""
    if not len(rows):
        return rows
    return rows[np.r_[True, who[rows][1:] != who[rows][:-1]]]


def pool_climb(pool: GraspBatch, seeds: NDArray[np.int64], score: Scorer,
               rng: np.random.Generator, evals: int, length: float) -> GraspBatch:
    """Climb seeds over a pool of contacts (see the module notes), until ``evals`` are spent,
    every member has converged or the scorer's deadline passes.

    Parameters
    ----------
    pool : GraspBatch
        The pool as a batch of one-contact "grasps" (B = pool size, k = 1).
    seeds : (s, k) int
        Pool indices of the seeds, best first.
    score : Scorer
    rng : numpy.random.Generator
    evals : int
        Evaluations to spend.
    length : float
        The part's length.

    Returns
    -------
    GraspBatch
        The members at the end, converged ones included.
    """
    pp = pool.points[:, 0]
    tree = cKDTree(pp)
    spacing = float(np.median(tree.query(pp[: min(len(pp), 500)], k=2)[0][:, 1]))

    def batch(idx: NDArray[np.int64]) -> GraspBatch:
        b = GraspBatch(pp[idx], pool.normals[idx, 0], pool.smooth[idx, 0], pool.faces[idx, 0],
                       pool.regions[idx, 0], np.zeros(len(idx)), np.zeros(len(idx)))
        score.score(b)
        return b

    pop = Population(batch(seeds), _POOL_MEMBERS, FIRST_STEP * length, 0.5 * spacing, seeds)
    used = 0
    k = seeds.shape[1]
    while used < evals and len(pop) and not score.out_of_time():
        idx: NDArray[np.int64] = pop.tags  # type: ignore[assignment]  # set: seeds have tags
        who = np.repeat(np.arange(len(pop)), _POOL_MOVES)
        j = rng.integers(0, k, len(who))
        target = pp[idx[who, j]] + rng.normal(size=(len(who), 3)) * pop.step[who, None]
        cand_idx = idx[who].copy()
        cand_idx[np.arange(len(who)), j] = tree.query(target)[1]
        srt = np.sort(cand_idx, axis=1)
        fresh = ~(np.diff(srt, axis=1) == 0).any(axis=1)  # no contact used twice
        who, cand_idx = who[fresh], cand_idx[fresh]
        cand = batch(cand_idx)
        used += len(cand)
        rows = _first_of_each(who, _best_per_member(who, cand.fit, pop.members.fit))
        pop.advance(who[rows], cand, rows, cand_idx)
    return pop.result()


def _cofactors(W: NDArray[np.float64], j: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For 6 x 7 matrices W (B, 6, 7) and a column j: C (B, 6, 6) with the null-vector entries
    of W other than the j-th (in column order), with column j replaced by x, equal to
    ``C @ x``, and that fixed entry ``v_j`` (B,) (see the module notes).

    With ``W'`` the other six columns, ``[W' x] [y; t] = 0`` gives ``y = -t adj(W') x / det W'``;
    with ``t = v_j = (-1)^j det W'`` (the generalised cross product's entry) the other entries
    are ``-(-1)^j adj(W') x``, and ``adj(W') = det(W') inv(W')``: one 6 x 6 factorisation per
    matrix instead of 36 5 x 5 determinants (7x faster, the same to 1e-13). Where ``W'`` is
    singular ``v_j`` is 0, so no swap is strictly positive whatever ``C``: C is 0 there.
    """
    Wp = W[:, :, [q for q in range(7) if q != j]]
    det = np.linalg.det(Wp)
    singular = det == 0.0
    if singular.any():
        Wp = Wp.copy()
        Wp[singular] = np.eye(6)
    C = np.linalg.inv(Wp).astype(np.float64, copy=False)
    C *= (-((-1.0) ** j) * np.where(singular, 0.0, det))[:, None, None]
    return C, ((-1.0) ** j) * det


def _screen(Xs: Sequence[NDArray[np.float64]], X32s: Sequence[NDArray[np.float32]],
            clash: NDArray[np.bool_], members: NDArray[np.int64], j: int) -> NDArray[np.float32]:
    """Screened d* (M, n) of each member with contact ``j`` swapped for each pool contact.

    Parameters
    ----------
    Xs : sequence of (6, n) float
        The pool's wrench columns under each reading of the normals (d* is the smaller).
    X32s : sequence of (6, n) float32
        The same in float32.
    clash : (n, n) bool
        Pairs of pool contacts whose fingertips overlap.
    members : (M, 7) int
        Pool indices of the members' contacts.
    j : int
        The contact swapped.

    Returns
    -------
    (M, n) float32
        d* (min over max of the null vector's entries, 0 unless all are positive) of each
        swap, in float32; 0 where the swap is not allowed (a contact the member has, or one
        whose fingertip overlaps another of the member's).
    """
    M, n_pool = len(members), Xs[0].shape[1]
    # every reading's 6 x 6 factorisations in one batch (one call costs about half of two)
    C, vj = _cofactors(np.concatenate([X[:, members] for X in Xs], axis=1).transpose(1, 0, 2), j)
    # with the null vector's fixed entry v_j made positive, a swap is closure when the six
    # others are positive too, and d* = min/max of all seven (a screen: float32)
    C *= np.where(vj < 0, -1.0, 1.0)[:, None, None]
    C32 = C.astype(np.float32).reshape(len(Xs), M * 6, 6)
    a = np.abs(vj).astype(np.float32).reshape(len(Xs), M, 1)
    d = np.empty(0, np.float32)
    for r, X32 in enumerate(X32s):  # the smaller d* of the readings
        U = (C32[r] @ X32).reshape(M, 6, n_pool)
        vmin = np.minimum(np.minimum.reduce(U, axis=1), a[r])
        vmax = np.maximum(np.maximum.reduce(U, axis=1), a[r])
        # vmin / vmax where vmin > 0, else 0 (vmax >= vmin; a masked divide is 6x slower)
        np.maximum(vmin, 0.0, out=vmin)
        np.divide(vmin, np.maximum(vmax, _TINY32, out=vmax), out=vmin)
        d = vmin if r == 0 else np.minimum(d, vmin, out=d)
    others = np.delete(members, j, axis=1)
    d[np.arange(M)[:, None], others] = 0.0  # a contact once only
    d[np.arange(M), members[:, j]] = 0.0  # (no swap: its screened d* is the member's own)
    d[clash[others].any(axis=1)] = 0.0  # fingertips apart
    return d


@dataclass(frozen=True, eq=False)
class SwapPool:
    """The pool as the swap climb screens it.

    Attributes
    ----------
    columns : tuple of (6, n) float
        The pool's wrench columns (moments about the scorer's centre over its length) under
        each reading of the normals the surface model scores (one when the readings agree on
        the whole pool, as on a polyhedral part).
    columns32 : tuple of (6, n) float32
        The same in float32.
    clash : (n, n) bool
        Pairs of pool contacts whose fingertips overlap.
    """

    columns: tuple[NDArray[np.float64], ...]
    columns32: tuple[NDArray[np.float32], ...]
    clash: NDArray[np.bool_]

    def screen(self, members: NDArray[np.int64], j: int) -> NDArray[np.float32]:
        """Screened d* (M, n) of each member (M, 7) with contact ``j`` swapped for each pool
        contact (:func:`_screen`), ``_SCREEN_ROWS`` members at a time."""
        if len(members) <= _SCREEN_ROWS:
            return _screen(self.columns, self.columns32, self.clash, members, j)
        return np.concatenate([_screen(self.columns, self.columns32, self.clash,
                                       members[s : s + _SCREEN_ROWS], j)
                               for s in range(0, len(members), _SCREEN_ROWS)])


def swap_pool(pool: GraspBatch, score: Scorer) -> SwapPool:
    """The :class:`SwapPool` of ``pool`` (one-contact grasps) under ``score``'s readings."""
    pp, pn, ps = pool.points[:, 0], pool.normals[:, 0], pool.smooth[:, 0]
    sets = score.readings(pn, ps)
    if len(sets) == 2 and not differs(pn[None], ps[None])[0]:
        sets = sets[:1]
    Xs = tuple(np.concatenate([n, np.cross((pp - score.center) / score.length, n)], axis=1).T
               for n in sets)
    tips = pp - score.r * pn
    clash = np.zeros((len(pp), len(pp)), bool)  # fingertips of the two contacts overlap
    pairs = cKDTree(tips).query_pairs(2 * score.r * (1 - 1e-9), output_type="ndarray")
    clash[pairs[:, 0], pairs[:, 1]] = clash[pairs[:, 1], pairs[:, 0]] = True
    return SwapPool(Xs, tuple(X.astype(np.float32) for X in Xs), clash)


def swap_climb(pool: GraspBatch, seeds: NDArray[np.int64], score: Scorer,
               rng: np.random.Generator, sweeps: int, kicks: int = 0,
               seed_scores: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
               swaps: SwapPool | None = None) -> GraspBatch:
    """Climb 7-contact seeds over the pool by exact best responses (see the module notes).

    Each member takes one contact at a time, in a fixed cyclic order drawn at random, and
    replaces it by the best pool contact (exact d*, fingertips apart, a pool contact once only)
    when the full scorer confirms the gain (rank, conditioning); a member that gains nothing
    over ``k`` tries in a row (every contact once: no single swap it can confirm improves it)
    has converged and the next seed takes its place. (Against contacts drawn at random and
    ``2 k`` tries, which left a member often "converged" with a contact never tried and spent
    tries on contacts already at their best: on all 47 corpus and held-out parts x seeds 0-3,
    the median plan 0.359 -> 0.323 s of CPU for the same first-grasp d*, mean ratio to the
    reference 0.9472 -> 0.9452, a difference within the runs' noise, 0.0035.) Each seed
    climbs at most ``sweeps`` times k tries. Once the seeds are all taken, ``kicks`` more
    starts follow, each one of the ``_KICK_ELITE`` best optima found so far with two of its
    contacts replaced, one by one of its best screened swaps and the other by a random pool
    contact (iterated local search). The climb stops early when the scorer's deadline
    passes.

    Parameters
    ----------
    pool : GraspBatch
        The pool as one-contact "grasps" (B = pool size, k = 1).
    seeds : (s, 7) int
        Pool indices of the seeds, best first; every one of them climbs.
    score : Scorer
    rng : numpy.random.Generator
    sweeps : int
    kicks : int, optional
        Kicked starts after the seeds (none without seeds).
    seed_scores : ((s,) float, (s,) float), optional
        The seeds' d* and fitness, when the caller scored them already (the scorer gives a
        grasp the same scores in any batch, so they are not scored again; kicked starts are).
    swaps : SwapPool, optional
        ``swap_pool(pool, score)``, when the caller has it already.

    Returns
    -------
    GraspBatch
        Every seed and kicked start after its climb.
    """
    pp, pn, ps = pool.points[:, 0], pool.normals[:, 0], pool.smooth[:, 0]
    n_pool, k = len(pp), seeds.shape[1]
    if swaps is None:
        swaps = swap_pool(pool, score)
    n_seeds = len(seeds)
    # the kicked starts' rows, filled in as members converge (see _kick)
    seeds = np.concatenate([seeds, np.zeros((kicks if n_seeds else 0, k), np.int64)])
    members = seeds[:_SWAP_MEMBERS].copy()
    slot_of = np.arange(len(members))  # which seed each member is
    out = seeds.copy()
    next_seed = len(members)
    finished = np.zeros(len(seeds), bool)
    stale = np.zeros(len(members), np.int64)  # tries without a gain in a row
    tries = np.zeros(len(members), np.int64)
    def start(rows: NDArray[np.int64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The scores of the starts ``rows`` (seeds, then kicked starts)."""
        if seed_scores is not None and (rows < n_seeds).all():
            return seed_scores[0][rows].copy(), seed_scores[1][rows].copy()
        ms = seeds[rows]
        return score(pp[ms], pn[ms], ps[ms])

    screen = swaps.screen
    cur_d, cur_fit = start(np.arange(len(members)))
    out_d, out_fit = np.zeros(len(seeds)), np.full(len(seeds), -2.0)  # of each seed's climb
    order = rng.permutation(k)
    rounds = 0
    while len(members):
        if score.out_of_time():  # members still climbing keep where they got to
            out[slot_of], out_d[slot_of], out_fit[slot_of] = members, cur_d, cur_fit
            break
        M = len(members)
        j = int(order[rounds % k])  # every k rounds in a row try every contact once
        rounds += 1
        d = screen(members, j)
        best = np.argmax(d, axis=1)[:, None]  # the screened best only (see _SWAP_CHECKED)
        # only members whose screened best beats them (beyond the screen's float32 round-off)
        # go through the full scorer
        hope = np.flatnonzero(d[np.arange(M)[:, None], best].max(axis=1) > cur_fit + _SCREEN_TOL)
        win = np.zeros(M, bool)
        if len(hope):
            cand = np.repeat(members[hope, None, :], _SWAP_CHECKED, axis=1)
            cand[:, :, j] = best[hope]
            flat = cand.reshape(-1, k)
            cd, cfit = (a.reshape(len(hope), _SWAP_CHECKED) for a in score(pp[flat], pn[flat],
                                                                      ps[flat]))
            gain = np.where(cfit > cur_fit[hope, None] + 1e-12, cfit, -np.inf)
            pick = np.argmax(gain, axis=1)
            ok = np.isfinite(gain[np.arange(len(hope)), pick])
            h = hope[ok]
            win[h] = True
            members[h, j] = best[h, pick[ok]]
            cur_d[h], cur_fit[h] = cd[ok, pick[ok]], cfit[ok, pick[ok]]
        stale = np.where(win, 0, stale + 1)
        tries += 1
        conv = np.flatnonzero((stale >= k) | (tries >= sweeps * k))
        if len(conv):
            out[slot_of[conv]], out_d[slot_of[conv]] = members[conv], cur_d[conv]
            out_fit[slot_of[conv]] = cur_fit[conv]
            finished[slot_of[conv]] = True
            fresh = min(len(conv), len(seeds) - next_seed)
            if next_seed + fresh > n_seeds:  # kicked starts from the best optima so far
                _kick(seeds, out, out_fit, finished, max(n_seeds, next_seed),
                      next_seed + fresh, n_pool, rng, screen)
            slots = conv[:fresh]
            members[slots] = seeds[next_seed : next_seed + fresh]
            slot_of[slots] = np.arange(next_seed, next_seed + fresh)
            cur_d[slots], cur_fit[slots] = start(slot_of[slots])
            stale[slots], tries[slots] = 0, 0
            next_seed += fresh
            keep = np.setdiff1d(np.arange(M), conv[fresh:])
            members, slot_of, stale, tries, cur_d, cur_fit = (
                members[keep], slot_of[keep], stale[keep], tries[keep], cur_d[keep],
                cur_fit[keep])
    b = GraspBatch(pp[out], pn[out], ps[out], pool.faces[out, 0], pool.regions[out, 0], out_d,
                   out_fit)
    if not score.timed_out:  # else the scores kept above stand (seeds never climbed stay at -2)
        score.score(b)
    return b


#: Kicked starts of the swap climb: among how many of the best distinct optima so far a kick
#: picks the one it kicks (with random replacements, ``synth.plan.search.KICK_SHARE`` 0.5, on
#: all 47 parts x seeds 0-3, mean first grasp / reference 0.9472; an elite of 1 or 6: 0.9450 /
#: 0.9442).
_KICK_ELITE = 3
#: A kick replaces two contacts: one by one of the ``_KICK_TOP`` best swaps the screen finds
#: for it (the likely way into a neighbouring optimum), the other by a random pool contact
#: (so that a climb whose optima all lie in one basin can still leave it). Against one or two
#: contacts replaced at random, on all 47 parts x seeds 0-3 (one process, CPU 1, with the
#: contacts' clearance from sharp edges): mean first grasp / reference 0.9397 -> 0.9484, min
#: 0.825 -> 0.853, runs >= 0.99 36 -> 38 of 188, median CPU 0.313 -> 0.327 s; under
#: ``--surface mesh`` 0.9701 -> 0.9728, runs >= 0.99 63 -> 72, min 0.849 -> 0.638 (the UMI
#: gripper at seed 3, where random kicks are trapped too under another random stream). Chosen
#: on every second part (random kicks: 0.9527; this kick: 0.9577): the screen's swap for the
#: first of one or two contacts 0.9636, but a run at 0.624 on the other parts; for both
#: 0.9594; the 16 or 256 best swaps for the first of one or two 0.9555 and 0.9594; an elite of
#: 6 0.9571.
_KICK_TOP = 64


def _kick(seeds: NDArray[np.int64], out: NDArray[np.int64], out_fit: NDArray[np.float64],
          finished: NDArray[np.bool_], lo: int, hi: int, n_pool: int,
          rng: np.random.Generator,
          screen: Callable[[NDArray[np.int64], int], NDArray[np.float32]]) -> None:
    """Fill ``seeds[lo:hi]`` with the best finished optima so far, each with two contacts
    replaced (iterated local search): one by one of the ``_KICK_TOP`` best swaps of
    ``screen`` (members (1, 7), contact -> screened d* (1, n_pool), 0 where not allowed), or
    by a random pool contact when it allows none; the other by a random pool contact."""
    done = np.flatnonzero(finished)
    if not len(done):
        done = np.arange(lo)  # nothing finished yet: kick the seeds themselves
    fit = out_fit[done] if finished.any() else np.zeros(len(done))
    uniq, first = np.unique(np.round(fit, 9), return_index=True)
    elite = done[first[np.argsort(-uniq, kind="stable")][:_KICK_ELITE]]
    k = seeds.shape[1]
    for i in range(lo, hi):
        row = out[elite[rng.integers(0, len(elite))]].copy()
        near, far = rng.choice(k, 2, replace=False)
        d = screen(row[None], int(near))[0]
        t = min(_KICK_TOP, n_pool)
        top = np.sort(np.argpartition(-d, t - 1)[:t])
        top = top[d[top] > 0]
        if len(top):
            row[near] = top[rng.integers(0, len(top))]
        for j in (far,) if len(top) else (near, far):
            q = int(rng.integers(0, n_pool))
            while q in row:
                q = int(rng.integers(0, n_pool))
            row[j] = q
        seeds[i] = row


def surface_climb(part: Any, seeds: GraspBatch, score: Scorer, fingers: Fingers,
                  rng: np.random.Generator, evals: int, say: Callable[[float], None]
                  ) -> GraspBatch:
    """Climb seeds on the surface (see the module notes), until ``evals`` are spent, every
    member has converged or the scorer's deadline passes.

    Parameters
    ----------
    part : synth.Part
    seeds : GraspBatch
        Starting grasps, best first.
    score : Scorer
    fingers : Fingers
    rng : numpy.random.Generator
    evals : int
        Evaluations to spend.
    say : callable(float)
        Told the best fitness after every round.

    Returns
    -------
    GraspBatch
        The members at the end, converged ones included.
    """
    L = score.length
    k = seeds.points.shape[1]
    gradient = score.params.mu == 0 and k == 7
    pop = Population(seeds, _SURFACE_MEMBERS, _SURFACE_FIRST_STEP * L, _MIN_STEP * L)
    used = 0
    while used < evals and len(pop) and not score.out_of_time():
        who, P, moved = _proposals(pop, rng, gradient, score)
        cand, ok = _settle(part, pop.members, who, P, moved)
        sel = np.flatnonzero(ok)
        cand, who, moved = cand.take(sel), who[sel], moved[sel]
        score.score(cand)
        used += len(cand)
        better = _best_per_member(who, cand.fit, pop.members.fit)
        rank = np.arange(len(better)) - np.searchsorted(who[better], who[better])
        tried = better[rank < _CHECKED]
        rows = _first_of_each(who, tried[_usable(part, cand, tried, moved, fingers)])
        pop.advance(who[rows], cand, rows)
        if len(pop):
            say(float(pop.members.fit.max()))
    return pop.result()


def _proposals(pop: Population, rng: np.random.Generator, gradient: bool, score: Scorer
               ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]:
    """Moved contact sets: member (c,), points (c, k, 3) and which contacts moved (c, k)."""
    mem, sigma = pop.members, pop.step
    M, k, _ = mem.points.shape
    whos, Ps, moveds = [], [], []
    if gradient:  # along the reading of the normals that bounds d*
        (dirs, low), *more = [ascent_directions(mem.points, n, score.center, score.length)
                              for n in score.readings(mem.normals, mem.smooth)]
        for dx, ratio in more:
            dirs = np.where((ratio < low)[:, None, None], dx, dirs)
        usable = np.flatnonzero(np.abs(dirs).sum(axis=(1, 2)) > 0)
        for s in _GRADIENT_STEPS:
            whos.append(usable)
            Ps.append(mem.points[usable] + s * sigma[usable, None, None] * dirs[usable])
            moveds.append(np.ones((len(usable), k), bool))
    who = np.repeat(np.arange(M), _SURFACE_MOVES)
    which = rng.integers(0, k, len(who))
    n0 = mem.normals[who, which]
    step = rng.normal(size=(len(who), 3))
    step -= (step * n0).sum(1, keepdims=True) * n0
    step *= (sigma[who] * rng.random(len(who)))[:, None] / np.maximum(
        np.linalg.norm(step, axis=1, keepdims=True), 1e-300)
    P = mem.points[who].copy()
    P[np.arange(len(who)), which] += step
    moved = np.zeros((len(who), k), bool)
    moved[np.arange(len(who)), which] = True
    whos.append(who)
    Ps.append(P)
    moveds.append(moved)
    return np.concatenate(whos), np.concatenate(Ps), np.concatenate(moveds)


def _settle(part: Any, members: GraspBatch, who: NDArray[np.int64], P: NDArray[np.float64],
            moved: NDArray[np.bool_]) -> tuple[GraspBatch, NDArray[np.bool_]]:
    """Drop the moved contacts onto the surface (the closest surface point); candidates (c,)
    and which keep every moved contact a single face contact."""
    cand = members.take(who)
    rows, cols = np.nonzero(moved)
    q, f, _ = closest_points(part, P[rows, cols])
    c = part.resolve(q, f, snap=True)
    n = len(rows)
    one = np.bincount(c.finger, minlength=n) == 1
    first = np.full(n, -1)
    first[c.finger[::-1]] = np.arange(len(c))[::-1]
    good = one & (first >= 0)
    good[good] &= c.features[first[good]] == "face"
    good[good] &= clear_of_edges(part, c.points[first[good]])
    ok = np.ones(len(who), bool)
    np.logical_and.at(ok, rows, good)
    g = np.flatnonzero(good)
    j = first[g]
    cand.points[rows[g], cols[g]] = c.points[j]
    cand.normals[rows[g], cols[g]] = c.normals[j]
    cand.smooth[rows[g], cols[g]] = c.smooth_normals[j]
    cand.faces[rows[g], cols[g]] = c.faces[j]
    cand.regions[rows[g], cols[g]] = c.region[j]
    return cand, ok


def _usable(part: Any, cand: GraspBatch, rows: NDArray[np.int64], moved: NDArray[np.bool_],
            fingers: Fingers) -> NDArray[np.bool_]:
    """Which candidates ``rows`` have every moved contact exposed and reachable by a finger."""
    r, c = np.nonzero(moved[rows])
    P, N = cand.points[rows[r], c], cand.normals[rows[r], c]
    good = part.exposed(P, N)
    good[good] &= reachable(part, P[good], N[good], fingers)
    ok = np.ones(len(rows), bool)
    np.logical_and.at(ok, r, good)
    return ok
