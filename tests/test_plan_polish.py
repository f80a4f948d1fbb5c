"""Local pools (synth.plan.polish): refined grasps are fitter, never less fit, and their
contacts and d* hold against the file's own triangles and a plain scipy LP."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.fingers import default_fingers
from synth.part import load_part
from synth.plan.batch import GraspBatch, Scorer
from synth.plan.climb import swap_pool
from synth.plan.greedy import greedy_starts
from synth.plan.params import PlanParams
from synth.plan.polish import STEPS, local_contacts, local_polish
from synth.plan.search import _pool
from tests.independent_check import lp_d_star, point_triangle_distance

ROOT = Path(__file__).resolve().parent.parent
BRACKET = ROOT / "meshes" / "bracket.stl"


@pytest.fixture(scope="module")
def setting():  # type: ignore[no-untyped-def]
    part = load_part(BRACKET, units="dm")
    fingers = default_fingers(part)
    score = Scorer(part, PlanParams(), fingers)
    rng = np.random.default_rng(3)
    pool = _pool(part, 7, rng, fingers)
    # greedy starts of the pool, not climbed: closure grasps far from their optima
    idx = greedy_starts(swap_pool(pool, score), rng, 200)
    b = GraspBatch(pool.points[idx, 0], pool.normals[idx, 0], pool.smooth[idx, 0],
                   pool.faces[idx, 0], pool.regions[idx, 0], np.zeros(len(idx)),
                   np.zeros(len(idx)))
    score.score(b)
    elite = b.take(np.argsort(-b.fit)[:6])
    assert (elite.fit > 0).all()
    return part, fingers, score, elite


def test_refined_grasps_are_fitter_and_never_less_fit(setting) -> None:  # type: ignore[no-untyped-def]
    part, fingers, score, elite = setting
    before = elite.take(np.arange(len(elite)))
    out = local_polish(part, elite, score, fingers, np.random.default_rng(0))
    np.testing.assert_array_equal(elite.fit, before.fit)  # the input is not changed
    np.testing.assert_array_equal(elite.points, before.points)
    assert (out.fit >= elite.fit).all()
    assert (out.fit > elite.fit + 0.05).sum() >= len(elite) // 2  # starts are far off
    # the refinement is reproducible from the seed
    again = local_polish(part, elite, score, fingers, np.random.default_rng(0))
    np.testing.assert_array_equal(out.points, again.points)


def test_refined_contacts_and_d_star_hold_on_the_files_own_triangles(setting) -> None:  # type: ignore[no-untyped-def]
    part, fingers, score, elite = setting
    out = local_polish(part, elite, score, fingers, np.random.default_rng(1))
    mesh = trimesh.load(BRACKET)
    tri = np.asarray(mesh.triangles)
    inward = -np.asarray(mesh.face_normals)
    size = float(np.linalg.norm(mesh.extents))
    for P, N, d in zip(out.points, out.normals, out.d, strict=True):
        # each contact on the file's surface, its normal that of the triangle it lies in
        dist = np.stack([point_triangle_distance(tri, np.repeat(p[None], len(tri), 0))
                         for p in P])
        assert dist.min(axis=1).max() < 1e-9 * size
        for p_dist, n in zip(dist, N, strict=True):
            on = np.flatnonzero(p_dist < 1e-9 * size)
            assert np.abs(inward[on] - n).max() < 1e-9
        ref, rank = lp_d_star(P, N)
        assert rank == 6 and d == pytest.approx(ref, abs=1e-6)


def test_local_contacts_lie_near_their_centres_and_are_usable(setting) -> None:  # type: ignore[no-untyped-def]
    part, fingers, _, elite = setting
    P, N = elite.points[0], elite.normals[0]
    spread = STEPS[0] * part.length
    near = local_contacts(part, P, N, 30, spread, fingers, np.random.default_rng(2))
    assert len(near) > 30  # most of the 210 draws land as usable face contacts
    gap = np.linalg.norm(near.points[:, 0, None] - P[None], axis=2).min(axis=1)
    assert gap.max() < 6 * spread  # a Gaussian step of this spread, snapped to the surface
    assert part.exposed(near.points[:, 0], near.normals[:, 0]).all()
