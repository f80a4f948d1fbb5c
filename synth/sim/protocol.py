"""What is done to a simulated grasp, in order, and what is measured.

0. **Start**: no finger or pad may touch the part before it closes (each starts clear, see
   :mod:`synth.sim.scene` and :mod:`synth.sim.jaws`); one that does is reported as
   ``failed_at = "start"``, never simulated (its first contact would throw the part).
1. **Close** (no gravity, the part held in place): the servos' targets move smoothly from
   where the fingers start to the planned contact over ``CLOSE_S`` and hold ``SETTLE_S``.
2. **Squeeze**: the targets move on to the squeeze over ``SQUEEZE_S`` and hold ``HOLD_S``. The
   balanced hand then corrects each target by the difference between the force it wants and
   the force its finger presses with (``CORRECTIONS`` times, ``SETTLE_S`` each): the contacts'
   own softness sits in series with the servo, and the squeeze must be the grasp's own. Then
   the part is let go and rests ``HOLD_S`` in the fingers alone: a squeeze that does not
   balance pushes it out here. The state reached is the *held pose*.
3. **Gravity**: from the held pose, the part's weight along +x, -x, +y, -y, +z, -z of the hand,
   one at a time, each turned on over ``RAMP_S`` and held ``GRAVITY_S`` (the field's protocols:
   GraspDataGen tugs with 1 g for 0.5 s, DexGraspBench pulls six directions with 1 g).
4. **Shake**: from the held pose, gravity along the hand's shake direction (``Scene.
   shake_gravity``: -z of the part's file for point fingers, the approach for a gripper),
   then the hand shaken along its x, y and z, two periods each, with a peak acceleration of
   ``shake`` g (in the hand's frame, gravity changing with time). ``shake`` = 0 skips it.

The grasp *holds* when the part stays within the motion thresholds of the scene through every
stage. After a stage fails the later ones are not run (the six gravity directions are all run,
so the label says which of them held).

Divergence: after every ``CHECK_STEPS`` steps, and whenever the part seems to have moved, the
state must be finite, MuJoCo must not have flagged a bad acceleration (it then resets the
state, which would look like a held part), the part may not move faster than ``SPEED_LIMIT``
sizes per second, and no finger may sink into the part deeper than the scene's limit. Otherwise
the run stops and reports the reason; :func:`run_refined` then runs the grasp again at half the
time step, ``REFINEMENTS`` times at most, before a divergence is its label. MuJoCo's warnings
are read from its counters, never printed nor logged to a file.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError
from synth.sim.scene import GRAVITY, HAND_BITS, Scene, quiet_mujoco
from synth.sim.settings import SimSettings

__all__ = ["SimRun", "run_protocol", "run_refined", "REFINEMENTS", "settle_under",
           "DIRECTIONS", "CLOSE_S", "SETTLE_S",
           "SQUEEZE_S", "HOLD_S", "CORRECTIONS", "RAMP_S", "GRAVITY_S", "CHECK_STEPS",
           "SPEED_LIMIT"]

#: Time over which the fingers close onto the part, s.
CLOSE_S: float = 0.05
#: Time the fingers rest after closing and after each squeeze correction, s.
SETTLE_S: float = 0.05
#: Time over which the squeeze is applied, s.
SQUEEZE_S: float = 0.1
#: Time the squeeze is held before the corrections, s.
HOLD_S: float = 0.15
#: Corrections of the balanced hand's targets towards its squeeze.
CORRECTIONS: int = 2
#: Time over which gravity is turned on, s.
RAMP_S: float = 0.1
#: Time each gravity direction is held, s.
GRAVITY_S: float = 0.5
#: Steps between divergence checks.
CHECK_STEPS: int = 50
#: Fastest a part may move (its centre, or a point half its size from it), in sizes per second:
#: falling freely for the whole protocol it would reach about 60.
SPEED_LIMIT: float = 1000.0
#: Names of the six gravity directions, in the hand's frame, in order.
DIRECTIONS: tuple[str, ...] = ("+x", "-x", "+y", "-y", "+z", "-z")
_UNIT = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


@dataclass(frozen=True)
class SimRun:
    """Raw measurements of one simulated grasp (SI units, the world frame).

    Attributes
    ----------
    failed_at : str or None
        ``"start"``, ``"close"``, ``"squeeze"``, ``"gravity"`` or ``"shake"``: the first
        stage in which the part moved past the threshold; None when it held through all.
    diverged : str or None
        Why the simulation was stopped as diverged; None when it did not.
    reason : str or None
        For ``"start"``: which finger touches the part before closing.
    gravity_held : (6,) bool
        Held under its weight along each of ``DIRECTIONS`` (all False when the squeeze failed).
    motion : (6,) float or None
        Displacement of the centre of mass (m) and rotation vector (rad) when the part first
        moved past the threshold, in the failing stage (the first failing gravity direction).
    motion_at : str or None
        The stage (``"gravity -z"`` for a gravity direction).
    forces : (a,) float
        Each actuator's force in the held pose, N (NaN where the squeeze was not reached).
    steps : int
    seconds : float
        Wall-clock time.
    """

    failed_at: str | None
    diverged: str | None
    reason: str | None
    gravity_held: NDArray[np.bool_] = field(repr=False)
    motion: NDArray[np.float64] | None = field(repr=False)
    motion_at: str | None
    forces: NDArray[np.float64] = field(repr=False)
    steps: int
    seconds: float

    @property
    def held(self) -> bool:
        """Held through every stage without diverging."""
        return self.failed_at is None and self.diverged is None


class _Diverged(Exception):
    pass


class _Runner:
    """One grasp's MuJoCo data and the measurements shared by the stages."""

    def __init__(self, scene: Scene) -> None:
        import mujoco

        self.mj = mujoco
        self.scene = scene
        self.m = scene.model
        self.d = mujoco.MjData(self.m)
        self.dt = float(self.m.opt.timestep)
        self.x_lim = scene.translation_limit
        self.th_lim = scene.rotation_limit
        self.steps = 0
        self.sig = mujoco.mjtState.mjSTATE_INTEGRATION
        self.hand_geoms = np.flatnonzero(np.asarray(self.m.geom_contype) == HAND_BITS)
        self.hold = self.mj.mj_name2id(self.m, self.mj.mjtObj.mjOBJ_EQUALITY, "hold")

    # -- state -------------------------------------------------------------------------
    def pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        q = self.d.qpos
        return q[:3].copy(), q[3:7].copy()

    def motion(self, ref: tuple[NDArray[np.float64], NDArray[np.float64]]
               ) -> NDArray[np.float64]:
        """Displacement and world rotation vector from the pose ``ref``."""
        q = self.d.qpos
        rot = np.zeros(3)
        self.mj.mju_subQuat(rot, q[3:7], ref[1])  # in ref's frame
        mat = np.zeros(9)
        self.mj.mju_quat2Mat(mat, ref[1])
        return np.concatenate([q[:3] - ref[0], mat.reshape(3, 3) @ rot])

    def moved(self, mo: NDArray[np.float64]) -> bool:
        """Whether the motion ``mo`` passes a threshold; a simulation that has diverged raises
        first, so that a blown-up state is never reported as a motion."""
        if np.linalg.norm(mo[:3]) > self.x_lim or np.linalg.norm(mo[3:]) > self.th_lim \
                or not np.isfinite(mo).all():
            self.check()
            return True
        return False

    def save(self) -> NDArray[np.float64]:
        out = np.zeros(self.mj.mj_stateSize(self.m, self.sig))
        self.mj.mj_getState(self.m, self.d, out, self.sig)
        return out

    def restore(self, state: NDArray[np.float64]) -> None:
        self.mj.mj_setState(self.m, self.d, state, self.sig)
        self.mj.mj_forward(self.m, self.d)

    def touching(self) -> list[int]:
        """Geoms of the hand touching the part deeper than the scene's start tolerance."""
        d = self.d
        out = set()
        for c in d.contact[: d.ncon]:
            if c.dist < -self.scene.start_tolerance:
                for g in (c.geom1, c.geom2):
                    if g in self.hand_geoms:
                        out.add(int(g))
        return sorted(out)

    # -- stepping ------------------------------------------------------------------------
    def step(self) -> None:
        self.mj.mj_step(self.m, self.d)
        self.steps += 1
        if self.steps % CHECK_STEPS == 0:
            self.check()

    def check(self) -> None:
        d = self.d
        if d.warning[self.mj.mjtWarning.mjWARN_BADQACC].number:
            raise _Diverged("MuJoCo found the accelerations unstable and reset the state")
        if not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
            raise _Diverged("the state became NaN or infinite")
        size = self.scene.size
        speed = max(float(np.linalg.norm(d.qvel[:3])),
                    float(np.linalg.norm(d.qvel[3:6])) * size / 2) / size
        if speed > SPEED_LIMIT:
            raise _Diverged(f"the part flew off at {speed:.3g} sizes per second")
        if d.ncon:
            con = d.contact[: d.ncon]
            lim = self.scene.penetration_limit
            over = -con.dist - np.minimum(lim[con.geom1], lim[con.geom2])
            k = int(np.argmax(over))
            if over[k] > 0:
                raise _Diverged(f"a finger sank {-con.dist[k] * 1e3:.3g} mm into the part "
                                f"(limit {(-con.dist[k] - over[k]) * 1e3:.3g} mm)")

    def run(self, seconds: float, each, ref) -> NDArray[np.float64] | None:
        """Step for ``seconds``, calling ``each(fraction of the time)`` before each step; the
        motion from ``ref`` if the part moved past the threshold."""
        n = max(1, round(seconds / self.dt))
        for i in range(n):
            each((i + 1) / n)
            self.step()
            if i % 10 == 0 or i == n - 1:
                mo = self.motion(ref)
                if self.moved(mo):
                    return mo
        return None

    def gravity(self, g: NDArray[np.float64]) -> None:
        self.m.opt.gravity[:] = g

    def let_go(self) -> None:
        """Release the weld that held the part while the hand closed."""
        self.d.eq_active[self.hold] = 0

    def forces(self) -> NDArray[np.float64]:
        """Each actuator's force magnitude, N."""
        return np.abs(np.asarray(self.d.actuator_force, float)).copy()


def _ramp(r: _Runner, a: NDArray[np.float64], b: NDArray[np.float64]):
    """Move the controls from ``a`` to ``b`` smoothly (zero speed at both ends)."""
    def each(frac: float) -> None:
        f = min(1.0, frac)
        r.d.ctrl[:] = a + f * f * (3.0 - 2.0 * f) * (b - a)
    return each


#: A run that diverges is run again at half the time step, at most this many times: a
#: divergence is the integrator's failure, not the grasp's (a Rethink fingertip of 4 cm and 4
#: g, pinched by the Franka pads at 70 N, sank past half its 0.2 mm slab at the default step
#: and held at half of it, as an independent simulation says).
REFINEMENTS: int = 2


def run_refined(build: Callable[..., Scene], settings: SimSettings) -> tuple[SimRun, Scene]:
    """:func:`run_protocol` of the scene ``build(settings=settings)``, and again at half the
    time step while it diverges, ``REFINEMENTS`` times at most; the last run and its scene
    (whose ``settings.dt`` is the step the run took)."""
    st = settings
    for k in range(REFINEMENTS + 1):
        scene = build(settings=st)
        run = run_protocol(scene)
        if run.diverged is None or k == REFINEMENTS:
            break
        st = replace(st, timestep=st.dt / 2)
    return run, scene


def run_protocol(scene: Scene) -> SimRun:
    """Start, close, squeeze, the six gravity directions and the shake (see the module).

    Parameters
    ----------
    scene : Scene
        The compiled grasp; its model's gravity is changed while this runs and restored after.

    Returns
    -------
    SimRun
    """
    if not isinstance(scene, Scene):
        raise InputError(f"scene: expected a Scene (build_scene), got {type(scene).__name__}")
    t0 = time.perf_counter()
    r = _Runner(scene)
    st = scene.settings
    g0 = GRAVITY
    held_dirs = np.zeros(6, bool)
    forces = np.full(scene.actuators, np.nan)
    failed: str | None = None
    diverged: str | None = None
    reason: str | None = None
    motion: NDArray[np.float64] | None = None
    motion_at: str | None = None
    saved_gravity = np.array(scene.model.opt.gravity)
    with quiet_mujoco():  # divergence is read from MuJoCo's counters
        try:
            failed, reason, motion = _grip(r)
            motion_at = failed if motion is not None else None
            if failed is None:
                forces = r.forces()
                held = r.pose()
                state = r.save()
                first: tuple[NDArray[np.float64], str] | None = None
                for k, name in enumerate(DIRECTIONS):
                    r.restore(state)
                    g = _UNIT[k] * g0
                    mo = r.run(RAMP_S, lambda f, g=g: r.gravity(f * g), held)
                    mo = mo if mo is not None else r.run(GRAVITY_S, lambda f: None, held)
                    held_dirs[k] = mo is None
                    if mo is not None and first is None:
                        first = (mo, f"gravity {name}")
                if first is not None:
                    failed, (motion, motion_at) = "gravity", first
                elif st.shake > 0:
                    r.restore(state)
                    down = np.asarray(scene.shake_gravity, float) * g0
                    mo = r.run(RAMP_S, lambda f: r.gravity(f * down), held)
                    if mo is None:
                        mo = _shake(r, down, held)
                    if mo is not None:
                        failed, motion, motion_at = "shake", mo, "shake"
        except _Diverged as e:
            diverged = str(e)
        finally:
            scene.model.opt.gravity[:] = saved_gravity
    return SimRun(failed, diverged, reason, held_dirs, motion, motion_at, forces, r.steps,
                  time.perf_counter() - t0)


def _grip(r: _Runner) -> tuple[str | None, str | None, NDArray[np.float64] | None]:
    """Start, close and squeeze (no gravity): the failing stage, the reason and the motion,
    all None when the part is held at rest."""
    scene, st = r.scene, r.scene.settings
    r.gravity(np.zeros(3))
    r.d.ctrl[:] = scene.ctrl_open
    r.mj.mj_forward(r.m, r.d)
    start = r.pose()
    touching = r.touching()
    if touching:
        names = [scene.model.geom(g).name or f"geom {g}" for g in touching]
        deep = -float(r.d.contact.dist[: r.d.ncon].min()) / r.scene.scale
        return "start", (f"{', '.join(names)} already inside the part by {deep:.3g} mesh "
                         "units before closing"), None
    mo = r.run(CLOSE_S, _ramp(r, scene.ctrl_open, scene.ctrl_touch), start)
    mo = mo if mo is not None else r.run(SETTLE_S, lambda f: None, start)
    if mo is not None:
        return "close", None, mo
    mo = r.run(SQUEEZE_S, _ramp(r, scene.ctrl_touch, scene.ctrl_squeeze), start)
    mo = mo if mo is not None else r.run(HOLD_S, lambda f: None, start)
    if mo is None and scene.preload is not None:
        ctrl = scene.ctrl_squeeze.copy()
        for _ in range(CORRECTIONS):
            ctrl = ctrl + (scene.preload - r.forces()) / st.stiffness
            r.d.ctrl[:] = ctrl
            mo = r.run(SETTLE_S, lambda f: None, start)
            if mo is not None:
                break
    if mo is None:
        r.let_go()
        mo = r.run(HOLD_S, lambda f: None, start)
    return (None, None, None) if mo is None else ("squeeze", None, mo)


def settle_under(scene: Scene, gravity: NDArray[np.float64], seconds: float
                 ) -> NDArray[np.float64]:
    """Grip the part as the protocol does, then hold it under its weight along ``gravity``
    (world frame, normalised here) for ``seconds``: how far it has moved from the held pose
    (displacement in m and rotation vector in rad), whatever the thresholds (a creeping
    grasp shows here). NaN when it was not gripped.

    Examples
    --------
    >>> settle_under(scene, [0, 0, -1], 5.0)  # doctest: +SKIP
    array([ 1.2e-07, ...])
    """
    r = _Runner(scene)
    with quiet_mujoco():
        try:
            if _grip(r)[0] is not None:
                return np.full(6, np.nan)
            held = r.pose()
            g = np.asarray(gravity, float) / np.linalg.norm(gravity) * GRAVITY
            r.x_lim = r.th_lim = np.inf
            r.run(RAMP_S, lambda f: r.gravity(f * g), held)
            r.run(seconds, lambda f: None, held)
            return r.motion(held)
        except _Diverged:
            return np.full(6, np.nan)
        finally:
            scene.model.opt.gravity[:] = 0.0


def _shake(r: _Runner, down: NDArray[np.float64],
           held: tuple[NDArray[np.float64], NDArray[np.float64]]) -> NDArray[np.float64] | None:
    st = r.scene.settings
    period = 2.0 / st.shake_hz
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = st.shake * GRAVITY

        def each(frac: float, e: NDArray[np.float64] = e) -> None:
            r.gravity(down + e * math.sin(2 * math.pi * 2.0 * frac))

        mo = r.run(period, each, held)
        if mo is not None:
            return mo
    return None
