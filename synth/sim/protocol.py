"""What is done to a simulated grasp, in order, and what is measured.

1. **Squeeze** (no gravity): every servo's target moves ``stroke`` into the part over
   ``CLOSE_S``, then the fingers hold for ``HOLD_S``. A grasp whose preload pushes the part
   away (a poorly conditioned frictionless grasp on compliant fingers can be squeezed out)
   fails here.
2. **Gravity** (-z of the mesh file) is turned on over ``CLOSE_S`` and held ``HOLD_S``. The
   state reached is the *held pose*, from which the pushes and the shake start.
3. **Pushes**: a force along +x, -x, +y, -y, +z, -z of the part's frame at its centre of mass,
   then a torque about each, one at a time, each from the held pose. The push grows as a
   probe would apply it: a damped spring whose far end moves steadily away (the force rises
   by ``cap / RAMP_S`` per second while the part stays), so that when the fingers give way the
   force stops growing instead of overshooting by the part's inertia. It ends when the part
   has moved past the threshold; the largest force (torque) applied until then is the largest
   it held. ``cap`` is more than the fingers can balance together (every finger's grip force,
   with friction, plus the weight; times the size for torques).
4. **Shake**: from the held pose, the hand is shaken along x, then y, then z, two periods each,
   with a peak acceleration of ``shake`` g: in the hand's frame this is gravity changing with
   time, which is how it is applied (fingertip weights stay compensated). ``shake`` = 0
   skips it.

The grasp *holds* when the part stays within the motion thresholds of
:class:`~synth.sim.settings.SimSettings` through the squeeze, gravity and the shake.

Divergence: after every ``CHECK_STEPS`` steps, and whenever the part seems to have moved, the
state must be finite, MuJoCo must not have flagged a bad acceleration (it then resets the
state, which would look like a held part), the part may not be moving faster than
``SPEED_LIMIT`` sizes per second (a grasp that gives way lets the part go at a fraction of
that), and no fingertip may have sunk into the part by more than ``PENETRATION_LIMIT`` of its
radius (the contact solver is losing). Otherwise the run stops and reports the reason.
MuJoCo's own warnings are not printed (they are read from its counters).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from synth.sim.scene import GRAVITY, Scene

__all__ = ["SimRun", "run_protocol", "DIRECTIONS", "CLOSE_S", "HOLD_S", "RAMP_S",
           "DETECT_S", "CHECK_STEPS", "PENETRATION_LIMIT", "SPEED_LIMIT"]

#: Time over which the fingers close and gravity is turned on, s.
CLOSE_S: float = 0.05
#: Time the fingers hold after each, s.
HOLD_S: float = 0.15
#: A push reaches its cap after this long if the part does not move, s.
RAMP_S: float = 0.5
#: The probe's far end moves one motion threshold in this time, s.
DETECT_S: float = 0.2
#: Steps between divergence checks.
CHECK_STEPS: int = 50
#: Deepest allowed penetration of a fingertip into the part, as a fraction of its radius.
PENETRATION_LIMIT: float = 0.5
#: Fastest a part may move (its centre, or a point half its size from it), in sizes per second:
#: falling freely for the whole protocol it would reach about 60.
SPEED_LIMIT: float = 1000.0
#: Names of the twelve pushes, in order: forces, then torques, along +x, -x, +y, -y, +z, -z.
DIRECTIONS: tuple[str, ...] = tuple(f"{kind} {sign}{axis}" for kind in ("force", "torque")
                                    for axis in "xyz" for sign in "+-")


@dataclass(frozen=True)
class SimRun:
    """Raw measurements of one simulated grasp (SI units, the part's frame).

    Attributes
    ----------
    failed_at : str or None
        ``"squeeze"``, ``"gravity"`` or ``"shake"`` where the part moved past the threshold;
        None when it held through all three.
    diverged : str or None
        Why the simulation was stopped as diverged (NaN state, MuJoCo's bad acceleration,
        deep penetration); None when it did not.
    pushes : (12,) float
        Largest force (N, first six) or torque (N m, last six) held, in the order of
        ``DIRECTIONS``; 0 when the part was not held under gravity.
    motions : (13, 6) float
        Motion of the part when it first moved past the threshold: displacement of its
        centre of mass (m) and rotation vector (rad), world frame. Rows 0-11 for the pushes,
        row 12 for the squeeze, gravity or shake, whichever failed; NaN where none was
        measured.
    steps : int
        Simulation steps taken.
    seconds : float
        Wall-clock time.
    """

    failed_at: str | None
    diverged: str | None
    pushes: NDArray[np.float64] = field(repr=False)
    motions: NDArray[np.float64] = field(repr=False)
    steps: int
    seconds: float

    @property
    def held(self) -> bool:
        """Held through the squeeze, gravity and the shake, without diverging."""
        return self.failed_at is None and self.diverged is None


class _Diverged(Exception):
    pass


class _Runner:
    """One grasp's MuJoCo data and the measurements shared by the phases."""

    def __init__(self, scene: Scene) -> None:
        import mujoco

        self.mj = mujoco
        self.scene = scene
        self.m = scene.model
        self.d = mujoco.MjData(self.m)
        st = scene.settings
        self.dt = float(self.m.opt.timestep)
        self.x_lim = st.translation_limit
        self.th_lim = st.rotation_limit
        self.pen_lim = PENETRATION_LIMIT * scene.tip_radius
        self.steps = 0
        self.sig = mujoco.mjtState.mjSTATE_INTEGRATION
        self.state = np.zeros(mujoco.mj_stateSize(self.m, self.sig))

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
        out = np.zeros_like(self.state)
        self.mj.mj_getState(self.m, self.d, out, self.sig)
        return out

    def restore(self, state: NDArray[np.float64]) -> None:
        self.mj.mj_setState(self.m, self.d, state, self.sig)
        self.d.xfrc_applied[:] = 0.0
        self.mj.mj_forward(self.m, self.d)

    # -- stepping ------------------------------------------------------------------------
    def step(self) -> None:
        self.mj.mj_step(self.m, self.d)
        self.steps += 1
        if self.steps % CHECK_STEPS == 0:
            self.check()

    def check(self) -> None:
        d = self.d
        bad = d.warning[self.mj.mjtWarning.mjWARN_BADQACC].number
        if bad:
            raise _Diverged("MuJoCo found the accelerations unstable and reset the state")
        if not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()):
            raise _Diverged("the state became NaN or infinite")
        size = self.scene.settings.size
        speed = max(float(np.linalg.norm(d.qvel[:3])),
                    float(np.linalg.norm(d.qvel[3:6])) * size / 2) / size
        if speed > SPEED_LIMIT:
            raise _Diverged(f"the part flew off at {speed:.3g} sizes per second")
        if d.ncon:
            deepest = -float(d.contact.dist[: d.ncon].min())
            if deepest > self.pen_lim:
                raise _Diverged(f"a fingertip sank {deepest / self.pen_lim * PENETRATION_LIMIT:.2f}"
                                " of its radius into the part")

    def gravity(self, g: NDArray[np.float64]) -> None:
        self.m.opt.gravity[:] = g

    # -- phases ----------------------------------------------------------------------------
    def settle(self, ref: tuple[NDArray[np.float64], NDArray[np.float64]], ramp,
               ) -> NDArray[np.float64] | None:
        """Run ``CLOSE_S`` with ``ramp(fraction)`` applied, then ``HOLD_S``; the motion if the
        part moved past the threshold."""
        n_close = max(1, round(CLOSE_S / self.dt))
        n_hold = max(1, round(HOLD_S / self.dt))
        for i in range(n_close + n_hold):
            ramp(min(1.0, (i + 1) / n_close))
            self.step()
            if i % 10 == 0 or i == n_close + n_hold - 1:
                mo = self.motion(ref)
                if self.moved(mo):
                    return mo
        return None

    def push(self, k: int, held: tuple[NDArray[np.float64], NDArray[np.float64]],
             cap: float) -> tuple[float, NDArray[np.float64]]:
        """Push ``DIRECTIONS[k]`` from the held pose; the largest load held and the motion."""
        torque = k >= 6
        axis, sign = (k % 6) // 2, (1.0 if k % 2 == 0 else -1.0)
        lim = self.th_lim if torque else self.x_lim
        rate = cap / RAMP_S
        speed = lim / DETECT_S
        spring = rate / speed
        if torque:  # moment of inertia about the world axis
            X = self.d.ximat[self.scene.part].reshape(3, 3)
            inertia = float(X[axis] @ (self.scene.inertia * X[axis]))
        else:
            inertia = self.scene.mass
        damp = 2.0 * math.sqrt(spring * inertia)
        part = self.scene.part
        xfrc = self.d.xfrc_applied[part]
        slot = (3 if torque else 0) + axis
        largest = 0.0
        n = round((RAMP_S + 2 * DETECT_S) / self.dt)
        for i in range(n):
            mo = self.motion(held)
            if self.moved(mo):
                return largest, mo
            x = sign * mo[slot]
            if torque:
                mat = np.zeros(9)
                self.mj.mju_quat2Mat(mat, self.d.qpos[3:7])
                rate_x = sign * (mat.reshape(3, 3) @ self.d.qvel[3:6])[axis]
            else:
                rate_x = sign * self.d.qvel[axis]
            load = max(0.0, spring * (speed * i * self.dt - x) - damp * rate_x)
            largest = max(largest, load)
            xfrc[:] = 0.0
            xfrc[slot] = sign * load
            self.step()
        return largest, self.motion(held)

    def shake(self, held: tuple[NDArray[np.float64], NDArray[np.float64]]
              ) -> NDArray[np.float64] | None:
        st = self.scene.settings
        g0 = np.array([0.0, 0.0, -GRAVITY])
        n = max(1, round(2.0 / st.shake_hz / self.dt))
        for axis in range(3):
            e = np.zeros(3)
            e[axis] = st.shake * GRAVITY
            for i in range(n):
                self.gravity(g0 + e * math.sin(2 * math.pi * st.shake_hz * (i + 1) * self.dt))
                self.step()
                if i % 10 == 0 or i == n - 1:
                    mo = self.motion(held)
                    if self.moved(mo):
                        return mo
        return None


def run_protocol(scene: Scene, *, pushes: bool = True) -> SimRun:
    """Squeeze, gravity, the twelve pushes and the shake on one grasp (see the module).

    Parameters
    ----------
    scene : Scene
        The compiled grasp (:func:`synth.sim.build_scene`); its model's gravity is changed
        while this runs and restored after.
    pushes : bool
        Measure the twelve pushes (False: squeeze, gravity and shake only).

    Returns
    -------
    SimRun
    """
    import mujoco

    t0 = time.perf_counter()
    r = _Runner(scene)
    st = scene.settings
    g = np.array([0.0, 0.0, -GRAVITY])
    loads = np.zeros(12)
    motions = np.full((13, 6), np.nan)
    failed: str | None = None
    diverged: str | None = None
    saved_gravity = np.array(scene.model.opt.gravity)
    saved_warning = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)  # divergence is read from the counters
    try:
        r.mj.mj_forward(r.m, r.d)
        start = r.pose()
        r.gravity(np.zeros(3))

        def close(frac: float) -> None:
            r.d.ctrl[:] = frac * st.stroke

        mo = r.settle(start, close)
        if mo is None:
            mo = r.settle(start, lambda frac: r.gravity(frac * g))
            failed = None if mo is None else "gravity"
        else:
            failed = "squeeze"
        if failed is None:
            held = r.pose()
            state = r.save()
            if pushes:
                mu = scene.contact.mu
                cap_force = scene.fingers * st.grip * (1.0 + mu) + scene.weight
                for k in range(12):
                    r.restore(state)
                    cap = cap_force * (st.size if k >= 6 else 1.0)
                    loads[k], motions[k] = r.push(k, held, cap)
            if st.shake > 0:
                r.restore(state)
                mo = r.shake(held)
                if mo is not None:
                    failed = "shake"
        if failed is not None:
            motions[12] = mo
    except _Diverged as e:
        diverged = str(e)
    finally:
        scene.model.opt.gravity[:] = saved_gravity
        mujoco.set_mju_user_warning(saved_warning)
    return SimRun(failed, diverged, loads, motions, r.steps, time.perf_counter() - t0)
