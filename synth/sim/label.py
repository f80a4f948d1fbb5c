"""The label of a simulated grasp: held or not, how much it held, how it moved when it failed.

Loads are relative, so that they do not depend on the scale the part was simulated at:
forces over the grip force (one finger's force limit), torques over the grip force times the
part's size, and the weight over the grip force. A motion is reported as a unit twist about
the centre of mass, ``[v, w * size / 2]`` normalised (a rotation counts as the motion of a
point half the size away), in the mesh file's axes, and compared with the escape twist synth
predicts for a grasp that is not closure: ``escape_cos`` is the cosine between the two (1:
the part moved exactly as predicted; taken in absolute value when the predicted motion is
free in both senses).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.scores.escape import describe_twist
from synth.sim.protocol import DIRECTIONS, SimRun
from synth.sim.scene import Scene

__all__ = ["SimLabel", "Escape", "predicted_escape", "label_run"]


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
        contacts); soft contacts take the frictional test with it.
    """
    from synth.scores import form_closure, frictional_form_closure, wrench_matrix

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
    rates = None if W is None else W.T @ t
    both = rates is not None and bool(np.all(np.abs(rates) <= 1e-9 * np.abs(W).max()))
    u = np.concatenate([t[:3], t[3:] * length / 2])
    return Escape(u / np.linalg.norm(u), both)


@dataclass(frozen=True)
class SimLabel:
    """What the simulation says about one grasp.

    Attributes
    ----------
    held : bool
        The part stayed put through the squeeze, gravity and the shake.
    failed_at : str or None
        ``"squeeze"``, ``"gravity"``, ``"shake"`` or ``"diverged"``; None when held.
    diverged : str or None
        Why the simulation was stopped (never reported as held).
    force_held : (6,) float
        Largest push held along +x, -x, +y, -y, +z, -z of the part's frame, over the grip
        force (0 when the part fell under gravity alone).
    torque_held : (6,) float
        Largest torque held about the same axes, over grip force times size.
    weight : float
        The part's weight over the grip force.
    motion : (6,) float or None
        Unit twist of the failure: the failing stage's, else the weakest push's.
    motion_at : str or None
        Which stage or push ``motion`` belongs to.
    motion_words : str or None
        The motion in words, as synth puts escapes (``"translate along +z"``), with points in
        mesh coordinates.
    escape_cos : float or None
        Cosine between ``motion`` and synth's predicted escape, when there is one.
    steps : int
    seconds : float
    """

    held: bool
    failed_at: str | None
    diverged: str | None
    force_held: NDArray[np.float64] = field(repr=False)
    torque_held: NDArray[np.float64] = field(repr=False)
    weight: float
    motion: NDArray[np.float64] | None = field(repr=False)
    motion_at: str | None
    motion_words: str | None
    escape_cos: float | None
    steps: int
    seconds: float

    @property
    def force_min(self) -> float:
        """The weakest push held, over the grip force."""
        return float(self.force_held.min())

    @property
    def torque_min(self) -> float:
        """The weakest torque held, over grip force times size."""
        return float(self.torque_held.min())

    def to_dict(self) -> dict[str, Any]:
        """The ``sim`` object of a grasp in a grasp file."""
        return {
            "held": self.held,
            "failed_at": self.failed_at,
            "diverged": self.diverged,
            "force_held": [float(x) for x in self.force_held],
            "torque_held": [float(x) for x in self.torque_held],
            "force_min": self.force_min,
            "torque_min": self.torque_min,
            "force_min_weights": self.force_min / self.weight if self.weight > 0 else None,
            "weight": float(self.weight),
            "motion": None if self.motion is None else [float(x) for x in self.motion],
            "motion_at": self.motion_at,
            "motion_words": self.motion_words,
            "escape_cos": self.escape_cos,
            "steps": int(self.steps),
            "seconds": float(self.seconds),
        }


def _unit(mo: NDArray[np.float64], size: float) -> NDArray[np.float64] | None:
    u = np.concatenate([mo[:3], mo[3:] * size / 2])
    n = float(np.linalg.norm(u))
    return None if not np.isfinite(n) or n == 0 else u / n


def _words(mo: NDArray[np.float64], scene: Scene) -> str:
    """A finite motion (displacement, rotation vector) in words, in mesh coordinates; a
    rotation that moves the part's surface less than a tenth of its displacement is left out
    (a translation with a little wobble is a translation)."""
    v, w = mo[:3] / scene.scale, mo[3:]
    length = scene.settings.size / scene.scale
    if np.linalg.norm(w) * length / 2 < 0.1 * np.linalg.norm(v):
        w = np.zeros(3)
    twist = np.concatenate([v, w])
    text = describe_twist(twist, scene.origin, length=length)
    return text.replace("free to ", "")


def label_run(run: SimRun, scene: Scene, escape: Escape | None) -> SimLabel:
    """Turn raw measurements into a grasp's label (relative loads, failure motion).

    Parameters
    ----------
    run : SimRun
    scene : Scene
        The simulated grasp.
    escape : Escape or None
        synth's prediction (:func:`predicted_escape`).
    """
    st = scene.settings
    forces = run.pushes[:6] / st.grip
    torques = run.pushes[6:] / (st.grip * st.size)
    row: int | None
    if run.diverged is not None:
        failed, row, at = "diverged", None, None
    elif run.failed_at is not None:
        failed, row, at = run.failed_at, 12, run.failed_at
    else:
        failed = None
        row = int(np.argmin(forces))
        at = DIRECTIONS[row]
    motion = None if row is None else _unit(run.motions[row], st.size)
    words = None if motion is None or row is None else _words(run.motions[row], scene)
    cos = None
    if motion is not None and escape is not None:
        c = float(motion @ escape.twist)
        cos = abs(c) if escape.both_senses else c
    return SimLabel(run.held, failed, run.diverged, forces, torques, scene.weight / st.grip,
                    motion, at, words, cos, run.steps, run.seconds)
