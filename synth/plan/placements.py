"""Grasps counted in fingers: a fingertip on a face or a convex edge or vertex makes one
contact, in a groove (concave edge) two, in an inside corner three.

``PlanParams.fingers`` asks for grasps of that many fingertips; the contacts follow from where
the tips land, so three fingertips in three inside corners make nine contacts and can hold a
part in frictionless form closure, which seven single contacts need seven fingers for.

The search works on *placements*, each one fingertip position with its 1 to 3 contacts
(:func:`placement_pool`): sampled on faces, along sharp edges and at corners of the exposed
surface, each kept when its fingertip fits all its contacts and its finger can come in
(:func:`synth.check_fingers` with the contacts sharing the tip). Random sets of placements are
scored in batches grouped by their number of contacts, and the best climb by swapping one
placement for a nearby one (:func:`finger_climb`), one score each. Convex edges and vertices
get the mean normal of their cone (see :mod:`synth.part.resolve`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from synth.contacts import Contacts, sample_contacts
from synth.errors import InputError
from synth.fingers import Fingers, check_fingers, tip_centers
from synth.plan.batch import GraspBatch, Scorer
from synth.plan.climb import FIRST_STEP, GROW, SHRINK

__all__ = ["Placements", "placement_pool", "placement_seeds", "placement_grasps",
           "finger_climb"]

#: Most contacts one fingertip makes (an inside corner of three faces).
MAX_PER_FINGER = 3
_MEMBERS, _MOVES = 16, 32
#: A seated contact is kept when the face under it has at least this cosine to the face the
#: crease was sampled on (a tessellated fillet or cone turns a little); the finger check then
#: decides whether the tip still touches all its contacts.
_SAME_FACE_COS = 0.9


@dataclass(frozen=True)
class Placements:
    """Fingertip placements, each with up to three contacts (padded).

    Attributes
    ----------
    points, normals, smooth : (n, 3, 3) float
        Contacts of each placement, the mesh's normals and the smooth reading's; rows past
        ``count`` are padding.
    faces, regions : (n, 3) int
    count : (n,) int
        Contacts of each placement (1 to 3).
    center : (n, 3) float
        A point of each placement (its first contact), for nearness.
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    smooth: NDArray[np.float64]
    faces: NDArray[np.int64]
    regions: NDArray[np.int64]
    count: NDArray[np.int64]
    center: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.count.shape[0])


def _group(c: Contacts) -> Placements:
    """Contacts grouped by fingertip into padded placements (at most three contacts each)."""
    _, start, count = np.unique(c.finger, return_index=True, return_counts=True)
    keep = count <= MAX_PER_FINGER
    start, count = start[keep], count[keep]
    rows = start[:, None] + np.minimum(np.arange(MAX_PER_FINGER), count[:, None] - 1)
    return Placements(c.points[rows], c.normals[rows], c.smooth_normals[rows], c.faces[rows],
                      c.region[rows], count, c.points[start])


def _seat(part: Any, pl: Placements, r: float) -> Placements:
    """Move the contacts of each groove and corner placement from the crease to where a tip of
    radius ``r`` seated there touches each face; drop placements whose tip would touch
    somewhere else (a face narrower than the tip's reach, or an unlike neighbour)."""
    multi = np.flatnonzero(pl.count > 1)
    if not len(multi):
        return pl
    P, N = pl.points[multi].copy(), pl.normals[multi]
    pad = np.arange(MAX_PER_FINGER)[None, :] >= pl.count[multi][:, None]
    ids = np.where(pad, 1, 0)  # padding rows on a finger of their own, ignored below
    centers = tip_centers(P, N, r, ids)[0][:, 0]  # (m, 3)
    seated = centers[:, None, :] + r * N  # tangent point on each contact's face plane
    P[~pad] = seated[~pad]
    flat = P[~pad]  # (q, 3), placement-major
    c = part.resolve(flat, snap=True)  # rows grouped by point, in order
    per_point = np.bincount(c.finger, minlength=len(flat))
    first = np.searchsorted(c.finger, np.arange(len(flat)))
    first = np.minimum(first, len(c.finger) - 1)
    fits = ((per_point == 1)
            & (np.einsum("ij,ij->i", c.normals[first], N[~pad]) > _SAME_FACE_COS)
            & (np.linalg.norm(c.points[first] - flat, axis=1) <= part.surface_tolerance))
    good = np.ones(len(multi), bool)
    np.logical_and.at(good, np.nonzero(~pad)[0], fits)
    F, NN, SS = pl.faces[multi].copy(), N.copy(), pl.smooth[multi].copy()
    F[~pad], NN[~pad], SS[~pad] = c.faces[first], c.normals[first], c.smooth_normals[first]
    points, normals, faces = pl.points.copy(), pl.normals.copy(), pl.faces.copy()
    smooth = pl.smooth.copy()
    points[multi], normals[multi], smooth[multi], faces[multi] = P, NN, SS, F
    keep = np.ones(len(pl), bool)
    keep[multi[~good]] = False
    k = np.flatnonzero(keep)
    return Placements(points[k], normals[k], smooth[k], faces[k], pl.regions[k], pl.count[k],
                      points[k, 0])


def placement_pool(part: Any, fingers: Fingers, rng: np.random.Generator, n_faces: int,
                   n_edges: int, n_corners: int) -> Placements:
    """Placements a finger can make, sampled on faces, sharp edges and corners.

    Parameters
    ----------
    part : synth.Part
    fingers : Fingers
    rng : numpy.random.Generator
    n_faces, n_edges, n_corners : int
        Samples of each kind (parts without sharp edges or corners give none of those).

    Returns
    -------
    Placements
    """
    parts = [sample_contacts(part, n_faces, seed=rng, method="uniform")]
    for method, n in (("edges", n_edges), ("corners", n_corners)):
        try:
            parts.append(sample_contacts(part, n, seed=rng, method=method))
        except InputError:  # no sharp edges, or no corners
            continue
    pl = _seat(part, _group(Contacts.concatenate(parts)), float(fingers.tip_radius))
    ok = np.zeros(len(pl), bool)
    for m in range(1, MAX_PER_FINGER + 1):
        sel = np.flatnonzero(pl.count == m)
        if len(sel):
            ok[sel] = check_fingers(part, pl.points[sel, :m], pl.normals[sel, :m], fingers,
                                    np.zeros(m, np.int64)).mask
    k = np.flatnonzero(ok)
    return Placements(pl.points[k], pl.normals[k], pl.smooth[k], pl.faces[k], pl.regions[k],
                      pl.count[k], pl.center[k])


def placement_seeds(pool: Placements, n: int, F: int, rng: np.random.Generator
                    ) -> NDArray[np.int64]:
    """``n`` random sets of ``F`` distinct placements, (n, F) int. Each fingertip is as likely
    to sit on a face as in a groove or a corner (when the part has them): grooves and corners
    are a small share of the surface but each makes two or three contacts."""
    kinds = np.unique(pool.count)
    share = np.bincount(pool.count, minlength=MAX_PER_FINGER + 1)[pool.count].astype(float)
    p = 1.0 / (len(kinds) * share)
    idx = rng.choice(len(pool), size=(n, F), p=p / p.sum())
    for _ in range(8):
        dup = (np.diff(np.sort(idx, axis=1), axis=1) == 0).any(axis=1)
        if not dup.any():
            break
        idx[dup] = rng.choice(len(pool), size=(int(dup.sum()), F), p=p / p.sum())
    return idx


def placement_grasps(pool: Placements, chosen: NDArray[np.int64], score: Scorer
                     ) -> dict[int, tuple[GraspBatch, NDArray[np.int64]]]:
    """Grasps made of the placements ``chosen`` (B, F), scored, grouped by their number of
    contacts: ``{k: (grasps, rows of chosen)}``."""
    total = pool.count[chosen].sum(axis=1)
    out = {}
    for k in np.unique(total).tolist():
        rows = np.flatnonzero(total == k)
        sel = chosen[rows]  # (b, F)
        b, F = sel.shape
        slot = np.arange(MAX_PER_FINGER)[None, None, :] < pool.count[sel][:, :, None]  # (b, F, 3)
        bi, fi, ci = np.nonzero(slot)  # row-major: contacts in finger order
        P = pool.points[sel[bi, fi], ci].reshape(b, k, 3)
        N = pool.normals[sel[bi, fi], ci].reshape(b, k, 3)
        S = pool.smooth[sel[bi, fi], ci].reshape(b, k, 3)
        faces = pool.faces[sel[bi, fi], ci].reshape(b, k)
        regions = pool.regions[sel[bi, fi], ci].reshape(b, k)
        finger = fi.reshape(b, k)
        g = GraspBatch(P, N, S, faces, regions, np.zeros(b), np.zeros(b), finger)
        score.score(g)
        out[k] = (g, rows)
    return out


def finger_climb(pool: Placements, seeds: NDArray[np.int64], seed_fit: NDArray[np.float64],
                 score: Scorer, rng: np.random.Generator, evals: int, length: float
                 ) -> dict[int, GraspBatch]:
    """Climb sets of placements by swapping one for the placement nearest a Gaussian step
    away, until ``evals`` are spent, every member has converged or the scorer's deadline
    passes; the grasps met on the way, grouped by number of contacts.

    Parameters
    ----------
    pool : Placements
    seeds : (s, F) int
        Placement indices of the starting sets, best first.
    seed_fit : (s,) float
    score : Scorer
    rng : numpy.random.Generator
    evals : int
    length : float
        The part's length.

    Returns
    -------
    dict of int to GraspBatch
    """
    tree = cKDTree(pool.center)
    members = seeds[:_MEMBERS].copy()
    fit = seed_fit[:_MEMBERS].copy()
    queue = list(range(len(members), len(seeds)))
    step = np.full(len(members), FIRST_STEP * length)
    floor = 0.5 * float(np.median(tree.query(pool.center[: min(len(pool), 500)], k=2)[0][:, 1]))
    found: dict[int, list[GraspBatch]] = {}
    used = 0
    F = seeds.shape[1]
    while used < evals and len(members) and not score.out_of_time():
        M = len(members)
        who = np.repeat(np.arange(M), _MOVES)
        j = rng.integers(0, F, len(who))
        target = pool.center[members[who, j]] + rng.normal(size=(len(who), 3)) * step[who, None]
        cand = members[who].copy()
        cand[np.arange(len(who)), j] = tree.query(target)[1]
        fresh = ~(np.diff(np.sort(cand, axis=1), axis=1) == 0).any(axis=1)
        who, cand = who[fresh], cand[fresh]
        cfit = np.full(len(who), -np.inf)
        for k, (g, rows) in placement_grasps(pool, cand, score).items():
            cfit[rows] = g.fit
            found.setdefault(k, []).append(g.take(np.flatnonzero(g.fit > 0)))
        used += len(who)
        best = np.full(M, -np.inf)
        arg = np.full(M, -1)
        order = np.lexsort((np.arange(len(who)), -cfit, who))
        head = order[np.r_[True, who[order][1:] != who[order][:-1]]] if len(order) else order
        best[who[head]], arg[who[head]] = cfit[head], head
        improve = best > fit + 1e-12
        members[improve], fit[improve] = cand[arg[improve]], best[improve]
        step = np.where(improve, np.minimum(step * GROW, FIRST_STEP * length), step * SHRINK)
        conv = np.flatnonzero(step < floor)
        if len(conv):
            fresh_n = min(len(conv), len(queue))
            for slot in conv[:fresh_n]:
                i = queue.pop(0)
                members[slot], fit[slot], step[slot] = seeds[i], seed_fit[i], FIRST_STEP * length
            keep = np.setdiff1d(np.arange(M), conv[fresh_n:])
            members, fit, step = members[keep], fit[keep], step[keep]
    return {k: GraspBatch.concat(v) for k, v in found.items()}
