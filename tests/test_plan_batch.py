"""The planner's scorer (synth.plan.batch.Scorer): what it counts of the grasps above the
physical floor is what both readings of the surface say together."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from synth.fingers import default_fingers
from synth.part import load_part
from synth.plan.batch import Scorer
from synth.plan.climb import swap_pool
from synth.plan.greedy import greedy_starts
from synth.plan.params import PlanParams
from synth.plan.search import _pool
from synth.scores.batch import form_closure_batch
from synth.scores.hold import stiff_hold_batch
from synth.scores.quality import scaled_wrenches

SPHERE = Path(__file__).resolve().parent.parent / "meshes" / "sphere.stl"


def test_above_the_floor_means_closure_under_both_readings_and_above_it():
    """The least squeeze a plan reports of the grasps above the floor ("the best needs ...")
    is, per grasp, the larger of the two readings' squeezes (the facets' normals, the smooth
    reading's), over the grasps closure under both. It was the smaller per reading: a grasp
    just above the floor with one reading and far above (or not closure) with the other
    counted at the first, and every part of revolution reported 4.00, the floor itself."""
    part = load_part(SPHERE)
    fingers = default_fingers(part)
    prm = PlanParams()
    score = Scorer(part, prm, fingers)
    rng = np.random.default_rng(0)
    pool = _pool(part, 7, rng, fingers)
    idx = greedy_starts(swap_pool(pool, score), rng, 3000)  # closure grasps, most of them
    P, N, S = pool.points[idx, 0], pool.normals[idx, 0], pool.smooth[idx, 0]
    score(P, N, S)
    closed, need = [], []
    for n in (N, S):  # the facets' normals, the smooth reading's
        res = form_closure_batch(scaled_wrenches(P, n, score.center, score.length))
        h = stiff_hold_batch(P, n, score.center, score.length).squeeze_per_weight
        closed.append(res.closure)
        need.append(np.where(res.closure, h, np.inf))
    squeeze = np.maximum(need[0], need[1])
    above = closed[0] & closed[1] & (squeeze > prm.floor)
    assert above.sum() > 100 and score.above_floor == above.sum()
    assert score.least_above == pytest.approx(squeeze[above].min(), rel=1e-9)
    # the smaller reading's least, what was reported, is well below it here
    per_reading = min(n[c & (n > prm.floor)].min(initial=np.inf)
                      for n, c in zip(need, closed, strict=True))
    assert per_reading < 0.9 * score.least_above
