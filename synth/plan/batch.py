"""Grasps under evaluation and their fitness, shared by the stages of the search.

A grasp's *fitness* orders the search: its d* when it is (frictional) form closure, passes
the physical floor (its fingers need at most ``PlanParams.max_squeeze`` times the part's
weight to hold it in every orientation, :mod:`synth.scores.hold`; checked here for
frictionless grasps of one contact per fingertip, and for every grasp when it is chosen),
is conditioned at least ``PlanParams.min_conditioning``, and its fingertips do not overlap;
``floor / squeeze - 1`` (in (-1, 0)) for a closure grasp above the floor, so that a climber
moves towards grasps that hold; d* - 1 when closure or conditioning fails (so better
candidates still rank higher); -2 when two fingertips overlap. All of it under the surface model
``PlanParams.surface`` (:mod:`synth.scores.surface`): with ``"both"``, closure and conditioning must
hold with the mesh's normals and with the smooth reading's, and d* is the smaller of the two. Every
candidate scored counts as one evaluation of the budget.

The scorer also keeps the search's clock: it scores in chunks and stops at the deadline
between two chunks, so no stage of the search runs more than one chunk past
``PlanParams.time``, and the memory of one call is bounded by the chunk, not by the batch. A
chunk holds ``_CHUNK`` seven-contact frictionless grasps, and proportionally fewer of larger
LPs (a 64-contact frictional LP costs thousands of times a 7-contact frictionless one). The
chunk size depends on the parameters only, never on timings: the last bits of a batch's
results can depend on how it is split, and the same seed must give the same grasps.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.fingers import Fingers, default_fingers, tip_centers
from synth.plan.params import PlanParams
from synth.scores import form_closure_batch
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.gram import gram_factors
from synth.scores.hold import stiff_hold_batch
from synth.scores.quality import conditioning_at_least, grasp_wrenches, scaled_wrenches
from synth.scores.surface import differs, readings

__all__ = ["GraspBatch", "Scorer", "distinct_top", "admitted_d_star", "admission_key"]

_CHUNK = 4096
_FIELDS = ("points", "normals", "smooth", "faces", "regions", "d", "fit", "finger")


@dataclass
class GraspBatch:
    """Grasps under evaluation: (B, k) contact data and their scores.

    Attributes
    ----------
    points, normals : (B, k, 3) float
        Contacts and the mesh's inward normals (fingertips sit along them).
    smooth : (B, k, 3) float
        The smooth reading of the normals (:class:`synth.Contacts` ``smooth_normals``).
    faces, regions : (B, k) int
    d : (B,) float
        d* (frictional d* with friction).
    fit : (B,) float
        Fitness (see the module notes).
    finger : (B, k) int
        Fingertip of each contact (contacts in a groove or an inside corner share one);
        default one per contact.
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    smooth: NDArray[np.float64]
    faces: NDArray[np.int64]
    regions: NDArray[np.int64]
    d: NDArray[np.float64]
    fit: NDArray[np.float64]
    finger: NDArray[np.int64] = field(default=None)  # type: ignore[arg-type]  # __post_init__

    def __post_init__(self) -> None:
        if self.finger is None:
            B, k = self.faces.shape
            self.finger = np.broadcast_to(np.arange(k), (B, k)).copy()

    def __len__(self) -> int:
        return int(self.d.shape[0])

    def take(self, idx: NDArray[np.int64]) -> GraspBatch:
        """The grasps ``idx`` (copies)."""
        return GraspBatch(*[getattr(self, f)[idx] for f in _FIELDS])

    def put(self, rows: NDArray[np.int64], other: GraspBatch, src: NDArray[np.int64]) -> None:
        """Overwrite grasps ``rows`` with ``other``'s grasps ``src``."""
        for f in _FIELDS:
            getattr(self, f)[rows] = getattr(other, f)[src]

    @staticmethod
    def of_contacts(c: Any, rows: NDArray[np.bool_] | NDArray[np.int64]) -> GraspBatch:
        """The contacts ``rows`` of ``c`` (:class:`synth.Contacts`) as one-contact grasps,
        unscored (a pool of single contacts)."""
        n = len(c.points[rows])
        return GraspBatch(c.points[rows][:, None], c.normals[rows][:, None],
                          c.smooth_normals[rows][:, None], c.faces[rows][:, None],
                          c.region[rows][:, None], np.zeros(n), np.zeros(n))

    @staticmethod
    def concat(parts: list[GraspBatch]) -> GraspBatch:
        """One batch of all the grasps of ``parts``."""
        return GraspBatch(*[np.concatenate([getattr(p, f) for p in parts]) for f in _FIELDS])


class Scorer:
    """Fitness of batches of grasps for one part and one parameter set.

    Parameters
    ----------
    part : synth.Part
    params : PlanParams
    fingers : Fingers
    deadline : float, optional
        ``time.perf_counter()`` value after which nothing more is scored (default: none).

    Attributes
    ----------
    evaluations : int
        Grasps scored so far.
    timed_out : bool
        True once the deadline was found passed; grasps left unscored then have d* 0 and the
        lowest fitness.
    above_floor : int
        Closure grasps scored that need more squeeze than the physical floor.
    least_above : float
        The least squeeze per weight among those (inf when none).
    """

    def __init__(self, part: Any, params: PlanParams, fingers: Fingers,
                 deadline: float | None = None) -> None:
        self.center = np.asarray(part.center_mass, dtype=np.float64)
        self.length = float(part.length)
        self.params = params
        self.r = float(fingers.tip_radius)
        self.evaluations = 0
        self.above_floor = 0
        self.least_above = math.inf
        self.deadline = np.inf if deadline is None else float(deadline)
        self.timed_out = False
        # LP columns per grasp, a frictional column weighted 4x (its LP is far more degenerate)
        cols = params.contacts * (4 * params.edges if params.mu > 0 else 1)
        self._rows = int(np.clip(_CHUNK * 7 // cols, 1, _CHUNK))

    def out_of_time(self) -> bool:
        """True (and ``timed_out`` set) once the deadline has passed."""
        if not self.timed_out and time.perf_counter() > self.deadline:
            self.timed_out = True
        return self.timed_out

    def matrix(self, P: NDArray[np.float64], N: NDArray[np.float64]) -> NDArray[np.float64]:
        """The scaled wrench matrix (or matrices) whose conditioning is reported."""
        prm = self.params
        return grasp_wrenches(P, N, self.center, self.length, prm.mu, prm.edges)

    def readings(self, N: NDArray[np.float64], S: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], ...]:
        """The normal sets a grasp is scored with (see :func:`synth.scores.surface.readings`)."""
        return readings(N, S, self.params.surface)

    def __call__(self, P: NDArray[np.float64], N: NDArray[np.float64], S: NDArray[np.float64],
                 finger: NDArray[np.int64] | None = None
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """d* and fitness (B,) of grasps ``P`` (B, k, 3) with the mesh's normals ``N`` and the
        smooth reading's ``S``, whose contacts belong to fingertips ``finger`` (B, k)
        (default: one each)."""
        B = P.shape[0]
        d = np.zeros(B)
        fit = np.full(B, -2.0)  # what rows left unscored at the deadline keep
        s = 0
        while s < B and not self.out_of_time():
            e = min(B, s + self._rows)
            d[s:e], fit[s:e] = self._chunk(P[s:e], N[s:e], S[s:e],
                                           None if finger is None else finger[s:e])
            self.evaluations += e - s
            s = e
        return d, fit

    def _closure(self, P: NDArray[np.float64], N: NDArray[np.float64], own: bool = True
                 ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
        """d*, whether each grasp is (frictional) form closure with the normals ``N``, within
        the physical floor (frictionless, ``own``: one contact per fingertip) and conditioned
        at least ``min_conditioning``, and for a closure grasp the floor over its least
        squeeze (1 where it passes or is not checked; 0 for a grasp that is not closure)."""
        prm = self.params
        # the numpy simplex always: a plan must not depend on whether numba is installed, nor
        # stall in the kernel's first compile (about 10 s) under a time cap
        factors = None
        if prm.mu == 0:  # the hold measure below reads the same factors as d*
            factors = gram_factors(scaled_wrenches(P, N, self.center, self.length))
            res = form_closure_batch(factors.wrenches, compiled=False, factors=factors)
        else:
            res = frictional_form_closure_batch(P, N, prm.mu, center=self.center, edges=prm.edges,
                                                compiled=False)
        d, ok = res.d_star, res.closure.copy()
        ratio = ok.astype(float)
        if factors is not None and ok.any() and own and math.isfinite(prm.floor):
            spw = stiff_hold_batch(P[ok], N[ok], self.center, self.length,
                                   factors.take(ok), at_most=prm.floor,
                                   forces=None if res.forces is None else res.forces[ok]
                                   ).squeeze_per_weight
            with np.errstate(divide="ignore"):
                ratio[ok] = np.minimum(1.0, prm.floor / spw)
            ok[ok] = ~(spw > prm.floor)
        if ok.any() and prm.min_conditioning > 0:  # conditioning matters only for closure
            ok[ok] = conditioning_at_least(self.matrix(P[ok], N[ok]), prm.min_conditioning)
        return d, ok, ratio

    def _chunk(self, P: NDArray[np.float64], N: NDArray[np.float64], S: NDArray[np.float64],
               finger: NDArray[np.int64] | None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """d* and fitness of one chunk: every array here is as large as the chunk, no larger."""
        sets = self.readings(N, S)
        own = finger is None or bool((finger == np.arange(P.shape[1])).all())
        # the second reading only where it differs from the first, scored in the same batch
        # (every row is scored on its own: one call costs half of two small ones)
        rows = np.flatnonzero(differs(N, S)) if len(sets) == 2 else np.zeros(0, np.int64)
        B = len(P)
        d, ok, ratio = self._closure(np.concatenate([P, P[rows]]),
                                     np.concatenate([sets[0], S[rows]]), own)
        if len(rows):
            d2, ok2, ratio2 = d[B:], ok[B:], ratio[B:]
            d, ok, ratio = d[:B].copy(), ok[:B].copy(), ratio[:B].copy()
            d[rows], ok[rows] = np.minimum(d[rows], d2), ok[rows] & ok2
            ratio[rows] = np.minimum(ratio[rows], ratio2)
        if finger is None:
            tips, present = P - self.r * N, np.ones(P.shape[:2], bool)
        else:
            tips, present, _, _ = tip_centers(P, N, self.r, finger)
        iu = _pairs(P.shape[1])
        gap = np.where(present[:, iu[0]] & present[:, iu[1]],
                       np.linalg.norm(tips[:, iu[0]] - tips[:, iu[1]], axis=2), np.inf)
        tips_ok = gap.min(axis=1) >= 2 * self.r * (1 - 1e-9)
        above = ~ok & (ratio > 0) & (ratio < 1)  # closure, above the floor
        # counted here, under every reading at once: a grasp within the floor under one and
        # not closure under the other (a surface of revolution's) is not "above the floor"
        self.above_floor += int(above.sum())
        if above.any():  # its squeeze: the floor over its ratio (the readings' larger)
            self.least_above = min(self.least_above,
                                   self.params.floor / float(ratio[above].max()))
        return d, np.where(tips_ok, np.where(ok, d, np.where(above, ratio - 1.0, d - 1.0)), -2.0)

    def score(self, b: GraspBatch) -> None:
        """Fill in ``b.d`` and ``b.fit``."""
        k = b.finger.shape[1]
        own = bool((b.finger == np.arange(k)).all())  # one fingertip per contact
        b.d, b.fit = self(b.points, b.normals, b.smooth, None if own else b.finger)


@functools.lru_cache(maxsize=None)
def _pairs(k: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``np.triu_indices(k, 1)``, kept (it costs about 0.1 ms, and the scorer asks for it
    on every chunk)."""
    iu = np.triu_indices(k, 1)
    for a in iu:
        a.flags.writeable = False
    return iu


def distinct_top(b: GraspBatch, n: int, scale: float) -> NDArray[np.int64]:
    """Indices of the ``n`` fittest grasps of ``b`` with distinct contact sets (contact points
    rounded to ``scale``, order ignored), best first."""
    order = np.argsort(-b.fit, kind="stable")
    seen: set[tuple[tuple[int, ...], ...]] = set()
    out = []
    for i in order.tolist():
        q = np.round(b.points[i] / scale).astype(np.int64)
        key = tuple(sorted(map(tuple, q.tolist())))
        if key in seen:
            continue
        seen.add(key)
        out.append(i)
        if len(out) == n:
            break
    return np.array(out, dtype=np.int64)


def admitted_d_star(part: Any, points: NDArray[np.float64], normals: NDArray[np.float64],
                    smooth: NDArray[np.float64], params: PlanParams | None = None,
                    fingers: Fingers | None = None) -> NDArray[np.float64]:
    """d* of each grasp where the planner admits it, else -1: the planner's own rules
    (:class:`Scorer`, whatever they are now: closure and the floor under every reading of the
    surface model, fingertips apart), for benchmarks and references that must follow them.

    Parameters
    ----------
    part : synth.Part
    points, normals, smooth : (B, k, 3) float
        Contacts, the mesh's inward normals and the smooth reading's.
    params : PlanParams, optional
        The rules' parameters (surface model, friction, floor); default ``PlanParams()``.
    fingers : Fingers, optional
        Default :func:`synth.default_fingers` of the part.

    Returns
    -------
    d : (B,) float
        The d* the planner reports where admitted, -1 elsewhere.
    """
    prm = params or PlanParams()
    fg = fingers or default_fingers(part)
    _, fit = Scorer(part, prm, fg)(np.asarray(points, float), np.asarray(normals, float),
                                   np.asarray(smooth, float))
    return np.where(fit > 0, fit, -1.0)


def admission_key(params: PlanParams | None = None) -> str:
    """A short fingerprint of the admission rules: the source of the scorer (this module) and
    the parameters that are not search effort. A stored reference whose key differs was
    computed under other rules and must be scored again."""
    import hashlib
    import inspect
    import sys
    from dataclasses import asdict

    prm = asdict(params or PlanParams())
    for effort in ("evals", "time", "seed", "top", "rank_by", "regions", "diversity"):
        prm.pop(effort, None)
    text = inspect.getsource(sys.modules[__name__]) + repr(sorted(prm.items()))
    return hashlib.sha256(text.encode()).hexdigest()[:12]
