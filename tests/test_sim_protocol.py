"""Physics against hand-derived answers: a cube held by point fingers.

The balanced hand presses with the grasp's own squeeze and holds its positions, so while no
finger lets go nor reaches its force limit the forces follow the stiff-finger model of
:mod:`synth.scores.hold`, and no hand of force-limited frictionless fingers can hold a weight
that no forces within the limits balance (an LP). So the simulated part must be held in every
direction below the stiff model's bound, and fall in a direction above that direction's LP
bound. Both bounds here come from a plain scipy LP and numpy, sharing no code with MuJoCo or
synth.sim. Also: a free motion is found, friction holds where it must and creeps nowhere, a
finger planned inside the part is refused, and a diverging simulation is never held.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

pytest.importorskip("mujoco")

from synth.scores import form_closure, frictional_form_closure, wrench_matrix  # noqa: E402
from synth.sim import (  # noqa: E402
    ContactModel,
    SimSettings,
    build_scene,
    load_planned_part,
    read_grasp_file,
    simulate_file,
)
from synth.sim.protocol import REFINEMENTS, settle_under  # noqa: E402
from synth.sim.shape import part_shape  # noqa: E402
from synth.sim.simulate import balanced_preload  # noqa: E402
from tests.sim_support import (  # noqa: E402
    CUBE3,
    CUBE6,
    CUBE7,
    rotation,
    write_cube,
    write_grasps,
)

FAR = np.array([1500.0, -2500.0, 800.0])  # a thousand sizes from the origin
AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0]])


def _density(f, weight: float) -> float:
    """The density that gives the simulated unit cube of file ``f`` (scaled to a diagonal of
    0.1 m) the weight ``weight`` newtons."""
    return weight / ((0.1 / f.length) ** 3 * 9.80665)


def _file(tmp_path, points, normals, *, R=None, t=None, mu=0.0):
    mesh = write_cube(tmp_path, R, t)
    return read_grasp_file(write_grasps(tmp_path, mesh, points, normals, mu=mu, R=R, t=t))


def _label(tmp_path, points, normals, *, R=None, t=None, mu=0.0, contact=None, settings=None):
    f = _file(tmp_path, points, normals, R=R, t=t, mu=mu)
    return f, simulate_file(f, settings, contact=contact).labels[0]


def _bounds(points, normals, center, length):
    """Per axis direction: the weight (in grip forces) at which the stiff model's first
    finger lets go or reaches its limit, and the largest any forces in [0, 1] balance. The
    hand's preload is sized for the weight in any direction plus a moment of ``COM_RTOL``
    times weight times ``length`` (synth.scores.hold's load set)."""
    from synth.scores.hold import COM_RTOL

    P = np.asarray(points, float) - center
    N = np.asarray(normals, float)
    W = np.vstack([N.T, np.cross(P, N).T])
    pinv = np.linalg.pinv(W)
    Wp = pinv[:, :3]  # the response to a unit force through the centre
    r = np.linalg.norm(Wp, axis=1) + COM_RTOL * length * np.linalg.norm(pinv[:, 3:], axis=1)
    c = np.linalg.svd(W)[2][-1]
    c = c * np.sign(c.sum())
    p = c * np.max(r / c)  # the preload per weight
    p = p / np.max(p + r)  # at grip 1
    linear, lp = [], []
    for d in AXES:
        a = Wp @ d
        drop = [p[i] / a[i] for i in range(len(p)) if a[i] > 1e-12]
        cap = [(1 - p[i]) / -a[i] for i in range(len(p)) if a[i] < -1e-12]
        linear.append(min(drop + cap))
        res = linprog(np.r_[np.zeros(len(p)), -1.0],
                      A_eq=np.hstack([W, np.r_[d, 0, 0, 0][:, None]]), b_eq=np.zeros(6),
                      bounds=[(0, 1)] * len(p) + [(0, None)], method="highs")
        assert res.status == 0
        lp.append(res.x[-1])
    return np.array(linear), np.array(lp)


def test_cube_grasp_is_form_closure():
    r = form_closure(wrench_matrix(*CUBE7, center=np.zeros(3)))
    assert r.closure == "form" and r.d_star == pytest.approx(0.5)


@pytest.mark.parametrize("placed", ["centred", "turned and far"])
def test_seven_fingers_hold_below_the_stiff_bound_and_fall_above_the_lp_bound(tmp_path, placed):
    R, t = (None, None) if placed == "centred" else (rotation(), FAR)
    f = _file(tmp_path, *CUBE7, R=R, t=t)
    g = f.grasps[0]
    linear, lp = _bounds(g.points, g.normals, f.center_mass, f.length)
    assert np.all(linear <= lp + 1e-9)
    grip = 10.0

    def run(weight: float):
        st = SimSettings(density=_density(f, weight * grip), shake=0.0, grip=grip)
        return simulate_file(f, st).labels[0]

    low = run(0.95 * linear.min())
    assert low.held and low.failed_at is None and low.gravity_held.all(), low
    heavy = 1.05 * lp.min()
    high = run(heavy)
    assert not high.held and high.failed_at == "gravity"
    # it falls where no forces within the limits balance the weight, and holds where the
    # stiff model keeps every finger within them
    assert not high.gravity_held[lp < heavy].any()
    assert high.gravity_held[linear > heavy].all()


def test_six_finger_grasp_is_free_along_x_only():
    r = form_closure(wrench_matrix(*CUBE6, center=np.zeros(3)))
    assert r.rank == 5 and r.d_star > 0.4 and r.escape_words == "free to translate along ±x"


@pytest.mark.parametrize("placed", ["centred", "turned and far"])
def test_six_fingers_slide_along_the_free_direction(tmp_path, placed):
    R, t = (None, None) if placed == "centred" else (rotation(), FAR)
    _, lab = _label(tmp_path, *CUBE6, R=R, t=t)
    free = (np.eye(3) if R is None else R)[:, 0]  # the cube's x axis in the file
    assert lab.failed_at == "gravity"
    if R is None:  # the weight along +-x slides it out, along y and z it is held
        assert list(lab.gravity_held) == [False, False, True, True, True, True]
    slide = lab.motion[:3] / np.linalg.norm(lab.motion[:3])
    assert abs(slide @ free) > 0.99
    assert lab.escape_cos is not None and lab.escape_cos > 0.98


def test_three_frictional_fingers_hold_with_friction_and_slip_without(tmp_path):
    assert frictional_form_closure(*CUBE3, mu=0.8).closure == "frictional form"
    _, lab = _label(tmp_path, *CUBE3, mu=0.8)
    assert lab.held, lab
    _, lab0 = _label(tmp_path, *CUBE3, mu=0.8, contact=ContactModel(0.0))
    assert not lab0.held and lab0.failed_at in ("squeeze", "gravity")


@pytest.mark.parametrize("noslip, creeps", [(10, False), (0, True)])
def test_a_squeezed_part_does_not_creep(tmp_path, noslip, creeps):
    # three frictional fingers at 17 times the least squeeze that holds the cube in the worst
    # direction, for 5 s: with the noslip solver it stays put; without it, MuJoCo's soft
    # friction lets it turn (measured 0.15 degrees a second), which is why noslip is on
    from synth.scores.gravity import gravity_hold_batch

    f = _file(tmp_path, *CUBE3, mu=0.8)
    g = f.grasps[0]
    hold = gravity_hold_batch(g.points[None], g.normals[None], 0.8, 0.0, f.center_mass,
                              f.length)
    grip = 10.0
    weight = grip / (17 * float(hold.squeeze_per_weight[0]))
    st = SimSettings(density=_density(f, weight), noslip=noslip, grip=grip)
    part = load_planned_part(f)
    scene = build_scene(part_shape(part), g.tip_centers, g.approach,
                        g.tip_radius, length=f.length, center_mass=f.center_mass,
                        volume=f.volume, settings=st, contact=ContactModel(0.8),
                        preload=balanced_preload(g, f.center_mass, f.length, 0.8, grip))
    moved = settle_under(scene, hold.worst_direction[0], 5.0)
    turned = np.degrees(np.linalg.norm(moved[3:]))
    if creeps:
        assert turned > 0.3
    else:
        assert turned < 0.02 and np.linalg.norm(moved[:3]) < 1e-4 * st.size


def test_a_finger_planned_inside_the_part_is_refused_at_the_start(tmp_path):
    P, N = CUBE7
    f = _file(tmp_path, P, N)
    g = f.grasps[0]
    deep = g.tip_centers.copy()
    deep[0] += 0.6 * 0.04 * N[0] * 3  # 1.8 tip radii into the part
    from dataclasses import replace

    f = replace(f, grasps=(replace(g, tip_centers=deep),))
    lab = simulate_file(f).labels[0]
    assert not lab.held and lab.failed_at == "start" and "fingertip 0" in lab.reason


def test_the_same_seed_gives_the_same_labels(tmp_path):
    a = _label(tmp_path, *CUBE7)[1].to_dict()
    b = _label(tmp_path, *CUBE7)[1].to_dict()
    c = _label(tmp_path, *CUBE6)[1].to_dict()
    d = _label(tmp_path, *CUBE6)[1].to_dict()
    for x in (a, b, c, d):
        x.pop("seconds")
    assert a == b and c == d


def test_the_balanced_hand_squeezes_with_the_grasp_s_own_forces(tmp_path):
    f, bal = _label(tmp_path, *CUBE7, settings=SimSettings(shake=0.0))
    g = f.grasps[0]
    want = balanced_preload(g, f.center_mass, f.length, 0.0, 10.0) / 10.0
    assert np.allclose(bal.forces, want, rtol=0.02), (bal.forces, want)
    W = wrench_matrix(g.points, g.normals, f.center_mass)
    assert np.linalg.norm(W @ want) < 1e-9  # a squeeze the part feels as no wrench
    # every saturated finger aims at the full grip; equal forces do not balance this
    # grasp, so the part is pushed until the fingers' forces balance, some below the grip
    _, sat = _label(tmp_path, *CUBE7, settings=SimSettings(hand="saturated", shake=0.0))
    assert sat.forces.max() == pytest.approx(1.0, abs=1e-3) and sat.forces.min() < 0.9


def test_a_diverging_simulation_is_reported_never_held(tmp_path):
    # servos of 1e9 N/m limited to 1e6 N on fingertips of a microgram, at steps of 1 ms:
    # the fingertips' integration blows up (MuJoCo finds a bad acceleration and resets)
    settings = SimSettings(stiffness=1e9, finger_mass=1e-9, timestep=1e-3, grip=1e6)
    _, lab = _label(tmp_path, *CUBE7, settings=settings)
    assert not lab.held and lab.failed_at == "diverged" and lab.reason
    assert lab.timestep == pytest.approx(1e-3 / 2**REFINEMENTS)  # refined, and still diverged


def test_a_run_that_diverges_is_run_again_at_half_the_step(tmp_path, monkeypatch):
    """A divergence is the integrator's failure: the grasp is simulated again at half the
    time step (a run made to diverge at the default step here), at most ``REFINEMENTS``
    times, and the label says the step it was simulated at."""
    from dataclasses import replace

    import synth.sim.protocol as protocol

    real, calls = protocol.run_protocol, []
    f = _file(tmp_path, *CUBE7)
    st = SimSettings(shake=0.0)
    dt = st.dt

    def diverging_above(limit):
        def run(scene):
            calls.append(scene.settings.dt)
            out = real(scene)
            return replace(out, diverged="made to diverge") if scene.settings.dt > limit else out
        return run

    monkeypatch.setattr(protocol, "run_protocol", diverging_above(0.6 * dt))
    lab = simulate_file(f, st).labels[0]
    assert calls == [dt, dt / 2] and lab.held and lab.timestep == dt / 2
    assert lab.to_dict()["timestep"] == dt / 2
    calls.clear()
    monkeypatch.setattr(protocol, "run_protocol", diverging_above(0.0))
    lab = simulate_file(f, st).labels[0]
    assert calls == [dt / 2**k for k in range(REFINEMENTS + 1)]
    assert lab.failed_at == "diverged" and not lab.held and lab.timestep == dt / 2**REFINEMENTS
