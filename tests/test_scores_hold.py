"""The least finger force per weight (synth.scores.hold) against answers found without it.

The stiff hand's forces are the preload plus the least-norm response to the weight, so for
any direction the forces are known in closed form; the reference here samples many directions
with numpy's own pseudo-inverse and a plain scipy LP over the preload, and checks that the
reported preload keeps every finger pressing and none above the reported force.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from synth.errors import InputError
from synth.scores.hold import finger_hold_batch, internal_squeeze, stiff_hold_batch
from tests.cli_support import CUBE_FC
from tests.sim_support import CUBE3, CUBE7

RNG = np.random.default_rng(7)
DIRS = RNG.normal(size=(4000, 3))
DIRS /= np.linalg.norm(DIRS, axis=1, keepdims=True)


def _reference(P, N, center, length) -> float:
    """min over preloads p in null(W) of max over sampled loads and fingers of the force,
    subject to every force >= 0: a scipy LP over (y, F), a row per load. The loads are the
    weight in a direction d and a moment m up to COM_RTOL weight x length: random ones, and
    for each finger the two that change its force most (d and m along its own responses)."""
    from synth.scores.hold import COM_RTOL

    W = np.vstack([N.T, np.cross(P - center, N).T])
    pinv = np.linalg.pinv(W)
    A, T = pinv[:, :3], pinv[:, 3:] * COM_RTOL * length
    Z = np.linalg.svd(W)[2][6:].T
    k, n = Z.shape
    unit = lambda x: x / np.linalg.norm(x, axis=-1, keepdims=True)  # noqa: E731
    M = unit(RNG.normal(size=DIRS.shape)) * RNG.uniform(0, 1, (len(DIRS), 1)) ** (1 / 3)
    ext_d, ext_m = np.vstack([unit(A), -unit(A)]), np.vstack([unit(T), -unit(T)])
    R = np.vstack([DIRS @ A.T + M @ T.T, ext_d @ A.T + ext_m @ T.T])  # (D, k)
    rows_lo = np.hstack([-np.repeat(Z[None], len(R), 0).reshape(-1, n), np.zeros((k * len(R), 1))])
    rows_hi = np.hstack([np.repeat(Z[None], len(R), 0).reshape(-1, n), -np.ones((k * len(R), 1))])
    b = R.reshape(-1)
    res = linprog(np.r_[np.zeros(n), 1.0], A_ub=np.vstack([rows_lo, rows_hi]),
                  b_ub=np.r_[-b, b], bounds=[(None, None)] * (n + 1), method="highs")
    assert res.status == 0
    return float(res.x[-1])


@pytest.mark.parametrize("case", [CUBE7, (np.array(CUBE_FC["points"], float),
                                          np.array(CUBE_FC["normals"], float))])
def test_seven_contacts_match_a_sampled_lp(case):
    P, N = (np.asarray(x, float) for x in case)
    h = stiff_hold_batch(P[None], N[None], np.zeros(3), 3**0.5)
    assert h.model == "stiff"
    ref = _reference(P, N, np.zeros(3), 3**0.5)
    # the loads include each finger's worst: the reference is the exact value
    assert ref == pytest.approx(h.squeeze_per_weight[0], rel=1e-6)
    forces = h.preload[0][None] - DIRS @ h.response[0].T
    assert forces.min() >= -1e-9 and forces.max() <= h.squeeze_per_weight[0] * (1 + 1e-9)


def test_more_contacts_take_the_lp_and_match_the_reference():
    P, N = CUBE7
    extra = np.array([[0.2, -0.2, 0.5]]), np.array([[0.0, 0.0, -1.0]])
    P8, N8 = np.vstack([P, extra[0]]), np.vstack([N, extra[1]])
    h = stiff_hold_batch(P8[None], N8[None], np.zeros(3), 3**0.5)
    ref = _reference(P8, N8, np.zeros(3), 3**0.5)
    assert ref == pytest.approx(h.squeeze_per_weight[0], rel=1e-6)
    W = np.vstack([N8.T, np.cross(P8, N8).T])
    assert np.linalg.norm(W @ h.preload[0]) < 1e-8  # a squeeze the part feels as nothing


def test_the_batched_lp_matches_the_reference_on_many_contacts():
    """Grasps of 9 and 12 contacts (the batched simplex from a feasible preload, scipy where it
    has none) against the sampled scipy LP of ``_reference``."""
    P0, N0 = CUBE7
    for k in (9, 12):
        idx = np.arange(k) % 7
        P = P0[idx][None] + 0.3 * RNG.uniform(-1, 1, size=(4, k, 3)) * (1 - np.abs(N0[idx]))[None]
        N = np.repeat(N0[idx][None], 4, axis=0)
        h = stiff_hold_batch(P, N, np.zeros(3), 3**0.5)
        for b in range(4):
            ref = _reference(P[b], N[b], np.zeros(3), 3**0.5)
            assert h.squeeze_per_weight[b] == pytest.approx(ref, rel=1e-6)


def test_a_bound_settles_the_grasps_within_it_and_the_lp_the_rest():
    """``at_most``: grasps of more than seven contacts that one feasible preload holds within
    the bound get that preload (feasible: a squeeze the part feels as nothing, every finger
    pressing through every load) and its squeeze, at least the least and at most the bound;
    the others the LP's least, as without it. Whether a squeeze is within the bound is the
    same either way."""
    P0, N0 = CUBE7
    extra = np.array([[0.2, -0.2, 0.5], [-0.3, 0.1, -0.5]]), np.array([[0.0, 0.0, -1.0],
                                                                        [0.0, 0.0, 1.0]])
    P9, N9 = np.vstack([P0, extra[0]]), np.vstack([N0, extra[1]])
    # the grasp with its contacts moved about on their faces
    P = P9[None] + 0.3 * RNG.uniform(-1, 1, size=(200, 9, 3)) * (1 - np.abs(N9))[None]
    N = np.repeat(N9[None], 200, axis=0)
    exact = stiff_hold_batch(P, N, np.zeros(3), 3**0.5)
    e = exact.squeeze_per_weight
    cap = float(np.median(e[np.isfinite(e)]))
    fast = stiff_hold_batch(P, N, np.zeros(3), 3**0.5, at_most=cap)
    f = fast.squeeze_per_weight
    np.testing.assert_array_equal(f <= cap, e <= cap)
    bounded = f != e
    assert 20 < bounded.sum() < (e <= cap).sum() + 1  # some settled by the bound, not all
    assert (f[bounded] >= e[bounded] * (1 - 1e-12)).all() and (f[bounded] <= cap).all()
    np.testing.assert_array_equal(f[~bounded], e[~bounded])
    for b in np.flatnonzero(bounded)[:20]:
        W = np.vstack([N[b].T, np.cross(P[b], N[b]).T])
        pre = fast.preload[b]
        assert np.linalg.norm(W @ pre) < 1e-9 * np.linalg.norm(pre)
        forces = pre[None] - DIRS @ fast.response[b].T  # the weight in sampled directions
        assert forces.min() >= -1e-9 and forces.max() <= f[b] * (1 + 1e-9)


def test_the_closure_forces_start_the_lp_where_the_all_ones_squeeze_cannot(monkeypatch):
    """Grasps of 12 contacts whose all-ones squeeze projected onto the null space has an entry
    that is not positive: given the d* LP's forces, the batched simplex starts from them and
    none is solved one at a time, with the same least squeeze as without them (which takes
    scipy's LP for those grasps), and that equals the sampled scipy LP of ``_reference``."""
    import synth.scores.hold as hold
    from synth.scores.batch import form_closure_batch
    from synth.scores.quality import scaled_wrenches
    from tests.scoring_cases import cube_contacts

    rng = np.random.default_rng(12)
    grasps = [cube_contacts(rng, 12) for _ in range(400)]
    P, N = np.stack([g[0] for g in grasps]), np.stack([g[1] for g in grasps])
    res = form_closure_batch(scaled_wrenches(P, N, np.zeros(3), 3**0.5))
    P, N, forces = P[res.closure], N[res.closure], res.forces[res.closure]
    W = np.stack([np.vstack([n.T, np.cross(p, n).T]) for p, n in zip(P, N, strict=True)])
    Z = np.swapaxes(np.linalg.svd(W)[2][:, 6:], 1, 2)
    no_start = (np.einsum("bkn,bn->bk", Z, Z.sum(axis=1)).min(axis=1) <= 0)
    assert no_start.sum() >= 5
    exact = stiff_hold_batch(P, N, np.zeros(3), 3**0.5)

    def no_scipy(Z, r):
        raise AssertionError("a grasp was solved one at a time")

    monkeypatch.setattr(hold, "_stiff_lp", no_scipy)
    started = stiff_hold_batch(P, N, np.zeros(3), 3**0.5, forces=forces)
    np.testing.assert_allclose(started.squeeze_per_weight, exact.squeeze_per_weight, rtol=1e-9)
    for b in np.flatnonzero(no_start)[:4]:
        assert started.squeeze_per_weight[b] == pytest.approx(
            _reference(P[b], N[b], np.zeros(3), 3**0.5), rel=1e-6)


def test_forces_of_another_shape_are_refused():
    P, N = CUBE7
    P8, N8 = np.vstack([P, P[:1]]), np.vstack([N, N[:1]])
    with pytest.raises(InputError, match=r"forces: of shape \(1, 7\), expected \(1, 8\)"):
        stiff_hold_batch(P8[None], N8[None], np.zeros(3), 3**0.5, forces=np.ones((1, 7)))


def test_the_gram_route_of_a_bound_equals_the_svd_route(monkeypatch):
    """With more than seven contacts and a bound, the certified grasps' start comes from the
    Gram factor (no basis of the null space): the same decisions and squeezes as with every
    grasp through the SVD."""
    import synth.scores.gram as gram

    P0, N0 = CUBE7
    extra = np.array([[0.2, -0.2, 0.5], [-0.3, 0.1, -0.5]]), np.array([[0.0, 0.0, -1.0],
                                                                        [0.0, 0.0, 1.0]])
    P9, N9 = np.vstack([P0, extra[0]]), np.vstack([N0, extra[1]])
    P = P9[None] + 0.3 * RNG.uniform(-1, 1, size=(200, 9, 3)) * (1 - np.abs(N9))[None]
    N = np.repeat(N9[None], 200, axis=0)
    e = stiff_hold_batch(P, N, np.zeros(3), 3**0.5).squeeze_per_weight
    cap = float(np.median(e[np.isfinite(e)]))
    svd, rows = np.linalg.svd, []

    def counted(A, *args, **kwargs):
        rows.append(len(A))
        return svd(A, *args, **kwargs)

    monkeypatch.setattr(np.linalg, "svd", counted)
    a = stiff_hold_batch(P, N, np.zeros(3), 3**0.5, at_most=cap)
    # the bound settled some grasps from the Gram factor: they never reached the SVD
    assert 0 < sum(rows) < len(P) - 20
    monkeypatch.setattr(gram, "GRAM_COND2_MAX", -1.0)  # nothing certified: every SVD
    b = stiff_hold_batch(P, N, np.zeros(3), 3**0.5, at_most=cap)
    np.testing.assert_array_equal(a.squeeze_per_weight <= cap, b.squeeze_per_weight <= cap)
    np.testing.assert_allclose(a.squeeze_per_weight, b.squeeze_per_weight, rtol=1e-9)
    np.testing.assert_allclose(a.preload, b.preload, rtol=1e-9, atol=1e-12)


def test_invariant_to_frame_and_units():
    P, N = CUBE7
    q, _ = np.linalg.qr(RNG.normal(size=(3, 3)))
    R = q * np.sign(np.linalg.det(q))
    t = np.array([300.0, -20.0, 5.0])
    a = stiff_hold_batch(P[None], N[None], np.zeros(3), 3**0.5).squeeze_per_weight[0]
    # the part's size scales with it (it sets the moment the measure allows for)
    b = stiff_hold_batch(((P @ R.T) * 250 + t)[None], (N @ R.T)[None], t, 250 * 3**0.5)
    assert b.squeeze_per_weight[0] == pytest.approx(a, rel=1e-9)


def test_the_gram_route_equals_the_svd_route(monkeypatch):
    import synth.scores.gram as gram

    P0, N0 = CUBE7  # the cube grasp with its contacts moved about on their faces
    P = P0[None] + 0.15 * RNG.uniform(-1, 1, size=(300, 7, 3)) * (1 - np.abs(N0))[None]
    N = np.repeat(N0[None], 300, axis=0)
    a = stiff_hold_batch(P, N, np.zeros(3), 2.0)
    monkeypatch.setattr(gram, "GRAM_COND2_MAX", -1.0)  # nothing certified: every SVD
    b = stiff_hold_batch(P, N, np.zeros(3), 2.0)
    fa, fb = np.isfinite(a.squeeze_per_weight), np.isfinite(b.squeeze_per_weight)
    assert fa.sum() > 100 and np.array_equal(fa, fb)
    assert np.allclose(a.squeeze_per_weight[fa], b.squeeze_per_weight[fb], rtol=1e-9)


def test_the_response_is_the_pseudo_inverse_when_rows_are_balanced():
    # a centre of mass far from the contacts makes the moment rows much larger than the force
    # rows, so the Gram factor is of the balanced rows and must be scaled back: the response
    # must still be numpy's pseudo-inverse of the wrench matrix itself
    from synth.scores.gram import gram_factors
    from synth.scores.quality import scaled_wrenches

    P0, N0 = CUBE7
    P = P0[None] + 0.15 * RNG.uniform(-1, 1, size=(50, 7, 3)) * (1 - np.abs(N0))[None]
    N = np.repeat(N0[None], 50, axis=0)
    center = np.array([40.0, -25.0, 10.0])
    W = scaled_wrenches(P, N, center, 2.0)
    factors = gram_factors(W)
    assert factors.certified.all() and not np.allclose(factors.scale, 1.0)
    h = stiff_hold_batch(P, N, center, 2.0)
    pinv = np.linalg.pinv(W)  # (50, 7, 6)
    held = np.isfinite(h.squeeze_per_weight)
    assert held.sum() > 10
    # the Gram route's error bound: cond(W)^2 round-offs of the largest entry (here
    # cond(W) is in the thousands, so about 1e-8 relative)
    cond = np.linalg.cond(W[held])
    tol = 10.0 * cond**2 * np.finfo(float).eps * np.abs(pinv[held]).max(axis=(1, 2))
    assert np.all(np.abs(h.response[held] - pinv[held, :, :3]).max(axis=(1, 2)) <= tol)
    assert np.all(np.abs(h.torque_response[held] - pinv[held, :, 3:]).max(axis=(1, 2)) <= tol)
    shared = stiff_hold_batch(P, N, center, 2.0, factors)
    assert np.array_equal(shared.squeeze_per_weight, h.squeeze_per_weight)
    with pytest.raises(InputError, match="factors"):
        stiff_hold_batch(P[:3], N[:3], center, 2.0, factors)


def test_no_closure_no_hold():
    P, N = CUBE7
    flat = N.copy()
    flat[:, 2] = 0.0  # normals in one plane: nothing resists a push along z
    flat /= np.where(np.linalg.norm(flat, axis=1, keepdims=True) > 0,
                     np.linalg.norm(flat, axis=1, keepdims=True), 1.0)
    flat[np.linalg.norm(flat, axis=1) == 0] = [1.0, 0, 0]
    h = stiff_hold_batch(P[None], flat[None], np.zeros(3), 3**0.5)
    assert np.isinf(h.squeeze_per_weight[0]) and not h.preload.any()


def test_friction_takes_the_any_hand_bound():
    P, N = CUBE3
    h = finger_hold_batch(P[None], N[None], np.zeros(3), 3**0.5, mu=0.8)
    assert h.model == "any" and 0 < h.squeeze_per_weight[0] < np.inf
    assert np.isinf(finger_hold_batch(P[None], N[None], np.zeros(3), 3**0.5, mu=0.0)
                    .squeeze_per_weight[0])


def test_an_internal_squeeze_is_internal():
    P, N = CUBE3
    f = internal_squeeze(P, N, np.zeros(3), 3**0.5, mu=0.8)
    assert f is not None and f.max() == pytest.approx(1.0) and f.min() > 0
    assert internal_squeeze(P, N, np.zeros(3), 3**0.5, mu=0.0) is None


def test_margin_is_grip_over_the_least_squeeze():
    P, N = CUBE7
    h = stiff_hold_batch(P[None], N[None], np.zeros(3), 3**0.5)
    assert h.margin(10.0, 2.0)[0] == pytest.approx(10.0 / (2.0 * h.squeeze_per_weight[0]))
