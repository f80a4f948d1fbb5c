"""Local pools: the best grasps so far refined by exact best responses over contacts drawn
around their own.

The swap climb (:func:`synth.plan.climb.swap_climb`) moves a grasp's contacts only onto the
pool's, a few thousand spread over the whole part, so its optima sit where the pool happens
to have contacts. Here each of the best grasps gets a pool of its own: ``SAMPLES`` contacts
around each of its contacts (Gaussian steps in the tangent plane, of a spread of ``STEPS[0]``
times the part's length, snapped back onto the surface and kept when they are single face
contacts clear of sharp edges, exposed and reachable by a finger, as the pool's are), and
climbs over it by the swap climb's exact best responses: every contact in turn is replaced
by the best of all the local contacts. Then again around the contacts it reached, with the
next spread. Each try weighs a hundred or more nearby positions of a contact at the cost of
one screen, where the surface climb (:func:`synth.plan.climb.surface_climb`) weighs 24
random moves of a grasp a round.

A grasp is replaced only by a better one, so the refinement never lowers the best fitness.
The search (:mod:`synth.plan.search`) refines the ``ELITE`` best distinct grasps of the swap
climb with the spreads ``STEPS``, then the ``FINAL_ELITE`` best of all with ``FINAL_STEPS``,
in place of the surface climb.

Measured on all 47 corpus and held-out parts x seeds 0-3 (each half of the parts in one
process on its own CPU), first grasp / reference, against the search before (the swap
climb, then the surface climb with 8% of the budget): mean 0.9626 -> 0.9698 on every second
part and 0.9454 -> 0.9546 on the others, lowest run 0.868 -> 0.889, CPU time about 1% less;
under ``--surface mesh`` (all parts) 0.9734 -> 0.9761, parts at 0.99 or more at seed 0
18 -> 23 of 47, CPU time 4% less. Tried on every second part: the first refinement alone,
before the surface climb with half its share, 0.9686 (+2% CPU); that surface climb added
0.0008 for 6% more time; 24 grasps refined instead of 16, 8 contacts a step instead of 12,
or spreads of (0.02, 0.005) or (0.005, 0.0015): no better; a third spread of 0.001 for all
16: +0.0013 for twice the cost of the refinement, which the ``FINAL_ELITE`` best get for less.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.fingers import Fingers
from synth.part.resolve import closest_points
from synth.plan.ascent import tangent_frames
from synth.plan.batch import GraspBatch, Scorer
from synth.plan.climb import clear_of_edges, reachable, swap_climb, swap_pool

__all__ = ["ELITE", "SAMPLES", "STEPS", "FINAL_ELITE", "FINAL_STEPS", "local_contacts",
           "local_polish"]

#: Grasps refined first (the best distinct ones), contacts drawn around each of their contacts
#: at each step, and the steps' spreads relative to the part's length.
ELITE, SAMPLES, STEPS = 16, 12, (0.01, 0.003)
#: Then the best distinct grasps of all, and their steps.
FINAL_ELITE, FINAL_STEPS = 4, (0.003, 0.001)
#: Most tries of every contact of a grasp over its local pool (as the swap climb's sweeps).
_SWEEPS = 6


def local_contacts(part: Any, points: NDArray[np.float64], normals: NDArray[np.float64],
                   n: int, spread: float, fingers: Fingers, rng: np.random.Generator
                   ) -> GraspBatch:
    """Single face contacts drawn around contacts (m, 3) with inward normals (m, 3).

    Parameters
    ----------
    part : synth.Part
    points, normals : (m, 3) float
    n : int
        Draws around each contact.
    spread : float
        Standard deviation of each draw's step in the contact's tangent plane (length).
    fingers : Fingers
    rng : numpy.random.Generator

    Returns
    -------
    GraspBatch
        The draws that landed as single face contacts clear of sharp edges, exposed and
        reachable, as one-contact grasps (at most ``m * n``; unscored).
    """
    m = len(points)
    steps = rng.normal(size=(m, n, 2)) * spread
    Q = (points[:, None] + np.einsum("mna,max->mnx", steps, tangent_frames(normals))
         ).reshape(-1, 3)
    q, f, _ = closest_points(part, Q)
    c = part.resolve(q, f, snap=True)
    single = np.bincount(c.finger, minlength=len(Q))[c.finger] == 1
    keep = (c.features == "face") & single
    keep[keep] &= clear_of_edges(part, c.points[keep])
    keep[keep] &= part.exposed(c.points[keep], c.normals[keep])
    keep[keep] &= reachable(part, c.points[keep], c.normals[keep], fingers)
    return GraspBatch.of_contacts(c, keep)


def local_polish(part: Any, elite: GraspBatch, score: Scorer, fingers: Fingers,
                 rng: np.random.Generator, steps: tuple[float, ...] = STEPS) -> GraspBatch:
    """The grasps ``elite`` (scored 7-contact grasps without friction) after their climbs over
    local pools (see the module notes).

    Parameters
    ----------
    part : synth.Part
    elite : GraspBatch
        Scored grasps (B, 7).
    score : Scorer
    fingers : Fingers
    rng : numpy.random.Generator
    steps : tuple of float
        The spreads of the local pools, one climb each, relative to the part's length.

    Returns
    -------
    GraspBatch
        A copy of ``elite`` in which each grasp is replaced by its refinement where that is
        fitter (never less fit, row by row).
    """
    out = elite.take(np.arange(len(elite)))
    B, k = out.faces.shape
    if B == 0:
        return out
    flat = B * k
    for spread in steps:
        if score.out_of_time():
            break
        own = GraspBatch(out.points.reshape(flat, 1, 3), out.normals.reshape(flat, 1, 3),
                         out.smooth.reshape(flat, 1, 3), out.faces.reshape(flat, 1),
                         out.regions.reshape(flat, 1), np.zeros(flat), np.zeros(flat))
        near = local_contacts(part, own.points[:, 0], own.normals[:, 0], SAMPLES,
                              spread * float(part.length), fingers, rng)
        pool = GraspBatch.concat([own, near])  # the grasps' own contacts come first
        climbed = swap_climb(pool, np.arange(flat).reshape(B, k), score, rng, _SWEEPS, 0,
                             (out.d.copy(), out.fit.copy()), swap_pool(pool, score))
        better = np.flatnonzero(climbed.fit > out.fit)
        out.put(better, climbed, better)
    return out
