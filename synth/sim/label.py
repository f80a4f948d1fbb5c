"""The label of a simulated grasp: held or not, where it failed, how the part moved.

A motion is reported as a unit twist about the centre of mass, ``[v, w * size / 2]``
normalised (a rotation counts as the motion of a point half the size away), in the mesh
file's axes, and compared with the escape twist synth predicts for a grasp that is not
closure: ``escape_cos`` is the cosine between the two (1: the part moved exactly as predicted;
taken in absolute value when the predicted motion is free in both senses).

A label that could not be made (synth's own failure: a MuJoCo load) is an
*error* label (:func:`error_label`): ``held`` is null and ``error`` says why. Every label
names the simulation that made it (``simulator``, :data:`synth.sim.settings.SIMULATOR`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.scores.escape import describe_twist
from synth.sim.protocol import DIRECTIONS, SimRun
from synth.sim.scene import Scene
from synth.sim.settings import SIMULATOR

__all__ = ["SimLabel", "Escape", "predicted_escape", "label_run", "error_label", "start_label",
           "FAILURE_STAGES"]

#: Values of ``failed_at``, in the order the stages run; ``"error"``: not simulated.
FAILURE_STAGES: tuple[str, ...] = ("start", "close", "squeeze", "gravity", "shake",
                                   "diverged", "error")


@dataclass(frozen=True)
class Escape:
    """A motion synth predicts the contacts do not prevent.

    Attributes
    ----------
    twist : (6,) float
        Unit ``[v, w * length / 2]`` about the centre of mass (``length``: the part's size).
    both_senses : bool
        The motion keeps every contact, so it is free in both senses.
    """

    twist: NDArray[np.float64] = field(repr=False)
    both_senses: bool


def predicted_escape(points: NDArray[np.float64], normals: NDArray[np.float64], mu: float,
                     center: NDArray[np.float64], length: float,
                     torsion: float = 0.0) -> Escape | None:
    """synth's escape twist of a grasp (:mod:`synth.scores.escape`), or None for closure.

    Parameters
    ----------
    points, normals : (k, 3) float
        Contacts, normals into the part.
    mu : float
        Friction coefficient (0: frictionless form closure; else the frictional test with
        8-edge cones).
    center : (3,) float
        Centre of mass: the twist's reference point.
    length : float
        The part's size, to weigh rotations.
    torsion : float
        Torsional coefficient of soft contacts, a length in the points' unit (0: point
        contacts).
    """
    from synth.scores import form_closure, frictional_form_closure, wrench_matrix
    from synth.scores.arguments import center_arg, length_arg

    center = center_arg(center)
    length = length_arg(length)
    if mu == 0:
        W = wrench_matrix(points, normals, center)
        esc = form_closure(W).escape
    else:
        r = frictional_form_closure(points, normals, mu, center=center, torsion=torsion)
        W = None
        esc = r.escape
    if esc is None:
        return None
    t = np.asarray(esc, float)
    both = W is not None and bool(np.all(np.abs(W.T @ t) <= 1e-9 * np.abs(W).max()))
    u = np.concatenate([t[:3], t[3:] * length / 2])
    return Escape(u / np.linalg.norm(u), both)


@dataclass(frozen=True)
class SimLabel:
    """What the simulation says about one grasp.

    Attributes
    ----------
    held : bool or None
        The part stayed put through every stage; None when it could not be simulated.
    failed_at : str or None
        One of ``FAILURE_STAGES``; None when held.
    reason : str or None
        Why, for ``"start"``, ``"diverged"`` and ``"error"``.
    gravity_held : (6,) bool
        Held under its weight along +x, -x, +y, -y, +z, -z of the hand.
    weight : float
        The part's weight over the grip force (a finger's, or the jaws').
    forces : (a,) float
        Each finger's (or the jaws') force in the held pose, over the grip force.
    motion : (6,) float or None
        Unit twist of the failure, mesh axes.
    motion_at : str or None
        The stage it belongs to (``"gravity -z"``).
    motion_words : str or None
        The motion in words, as synth puts escapes, with points in mesh coordinates.
    escape_cos : float or None
        Cosine between ``motion`` and synth's predicted escape, when there is one.
    steps : int
    seconds : float
    timestep : float
        The integration step the label was simulated at, s: the settings', or a half or a
        quarter of it when the run diverged at the larger step
        (:func:`synth.sim.protocol.run_refined`); nan when not simulated.
    """

    held: bool | None
    failed_at: str | None
    reason: str | None
    gravity_held: NDArray[np.bool_] = field(repr=False)
    weight: float
    forces: NDArray[np.float64] = field(repr=False)
    motion: NDArray[np.float64] | None = field(repr=False)
    motion_at: str | None
    motion_words: str | None
    escape_cos: float | None
    steps: int
    seconds: float
    timestep: float = float("nan")

    def to_dict(self) -> dict[str, Any]:
        """The ``sim`` object of a grasp in a grasp file."""
        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        return {
            "simulator": SIMULATOR,
            "held": self.held,
            "failed_at": self.failed_at,
            "reason": self.reason,
            "gravity_held": {d: bool(h) for d, h in zip(DIRECTIONS, self.gravity_held,
                                                        strict=True)},
            "weight": num(self.weight),
            "forces": [num(x) for x in self.forces],
            "motion": None if self.motion is None else [float(x) for x in self.motion],
            "motion_at": self.motion_at,
            "motion_words": self.motion_words,
            "escape_cos": self.escape_cos,
            "steps": int(self.steps),
            "seconds": float(self.seconds),
            "timestep": num(self.timestep),
        }


def start_label(reason: str) -> SimLabel:
    """The label of a grasp refused before its scene is built (its contacts are not on the
    part, or its fingers not where its contacts say): not held, at the start."""
    return SimLabel(False, "start", reason, np.zeros(6, bool), float("nan"), np.zeros(0), None,
                    None, None, None, 0, 0.0)


def error_label(reason: str) -> SimLabel:
    """The label of a grasp synth could not simulate (its own failure, said in ``reason``)."""
    return SimLabel(None, "error", reason, np.zeros(6, bool), float("nan"), np.zeros(0), None,
                    None, None, None, 0, 0.0)


def _unit(mo: NDArray[np.float64], size: float) -> NDArray[np.float64] | None:
    u = np.concatenate([mo[:3], mo[3:] * size / 2])
    n = float(np.linalg.norm(u))
    return None if not np.isfinite(n) or n == 0 else u / n


def _words(mo: NDArray[np.float64], scene: Scene) -> str:
    """A finite motion (displacement, rotation vector; mesh axes) in words, in mesh
    coordinates; a rotation that moves the part's surface less than a tenth of its
    displacement is left out (a translation with a little wobble is a translation)."""
    v, w = mo[:3] / scene.scale, mo[3:]
    length = scene.size / scene.scale
    if np.linalg.norm(w) * length / 2 < 0.1 * np.linalg.norm(v):
        w = np.zeros(3)
    text = describe_twist(np.concatenate([v, w]), scene.origin, length=length)
    return text.replace("free to ", "")


def label_run(run: SimRun, scene: Scene, escape: Escape | None) -> SimLabel:
    """Turn raw measurements into a grasp's label (relative forces, failure motion).

    Parameters
    ----------
    run : SimRun
    scene : Scene
        The simulated grasp.
    escape : Escape or None
        synth's prediction (:func:`predicted_escape`).
    """
    failed = "diverged" if run.diverged is not None else run.failed_at
    reason = run.diverged if run.diverged is not None else run.reason
    motion = words = None
    if run.motion is not None and run.diverged is None:
        mo = np.concatenate([scene.frame @ run.motion[:3], scene.frame @ run.motion[3:]])
        motion = _unit(mo, scene.size)
        words = None if motion is None else _words(mo, scene)
    cos = None
    if motion is not None and escape is not None:
        c = float(motion @ escape.twist)
        cos = abs(c) if escape.both_senses else c
    return SimLabel(run.held, failed, reason, run.gravity_held, scene.weight / scene.grip,
                    run.forces / scene.grip, motion, run.motion_at if failed != "diverged"
                    else None, words, cos, run.steps, run.seconds, scene.settings.dt)
