"""What a simulated hand is and how the part is loaded: :class:`SimSettings`.

Point fingers are simulated in SI units on a copy of the part scaled so that its bounding-box
diagonal is ``size`` metres (default 0.1 m, a hand-held object), filled with a material of
``density`` (default 1000 kg/m^3, water): a mesh in millimetres, metres or of unknown unit is
simulated the same way, and the label does not depend on the scale chosen beyond the ratio of
the part's weight to the grip force. A gripper has a real size and a rated force, so gripper
grasps are simulated at the part's real size (its unit is known: gripper plans need it).

Hands
-----
``balanced`` (default): stiff position-controlled fingers that close to contact, then press
with the grasp's own balanced squeeze (:mod:`synth.scores.hold`: internal forces that leave the
part at rest, sized so that no finger exceeds the grip force while the part's weight turns in
every direction), and then hold their positions. The label is about the grasp: a grasp held
with that squeeze is held by this hand.
``saturated``: every finger aims ``2 grip / stiffness`` into the part and presses with the full
grip force. Equal forces do not balance a form-closure grasp, so the squeeze itself pushes the
part until some finger lets go: this hand labels its controller as much as the grasp; it is
kept to compare with earlier labels.

Motion thresholds
-----------------
A part has moved when its centre of mass is displaced by more than ``TRANSLATION_RTOL * size``
plus the fingers' elastic travel ``stroke`` (the grip force over the stiffness), or when it
turns by more than that length over half the size (a point of its surface moves about as far).
The field's protocols allow more (5 cm and 15 degrees in DexGraspBench); a grasp that holds
here holds there.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from synth.errors import InputError, shown

__all__ = ["SimSettings", "SIMULATOR", "HANDS", "TRANSLATION_RTOL", "MAX_TIMESTEP", "RANGES"]

#: Name and version of the simulation that makes a label. Every label carries it, and a
#: database never holds labels of two versions (its build parameters include it).
SIMULATOR: str = "synth.sim 3"
#: The simulated hands (see the module notes).
HANDS: tuple[str, ...] = ("balanced", "saturated")
#: A part held still moves less than this fraction of its size (plus the fingers' stroke).
TRANSLATION_RTOL: float = 0.02
#: The largest time step: a fingertip's contact is about as stiff as MuJoCo's time constant
#: of two steps allows; 2e-4 s keeps its penetration under 10 N near 0.1% of the default size.
MAX_TIMESTEP: float = 2e-4

#: Accepted range of each number (beyond them MuJoCo's numbers stop meaning anything: a part
#: of 1e-10 kg is refused by its compiler, a servo of 1e10 N/m needs steps of 1e-7 s).
RANGES: dict[str, tuple[float, float]] = {
    "stiffness": (1.0, 1e9), "grip": (1e-3, 1e6), "size": (1e-3, 1e3),
    "density": (1.0, 1e5), "finger_mass": (1e-9, 1e3), "shake": (0.0, 100.0),
    "shake_hz": (0.1, 100.0),
}
#: Accepted range of each count.
COUNTS: dict[str, tuple[int, int]] = {"iterations": (1, 10_000), "noslip": (0, 1_000)}


@dataclass(frozen=True)
class SimSettings:
    """The simulated hand, the part's material and the solver.

    Attributes
    ----------
    hand : {"balanced", "saturated"}
        How point fingers press (module notes); gripper jaws always press with the
        gripper's rated force.
    stiffness : float
        Gain of each point finger's position servo, N/m (default 1e5: a stiff finger).
    grip : float
        Force limit of each point finger, N (default 10).
    size : float
        The point-finger part's bounding-box diagonal in the simulation, m (default 0.1).
    density : float
        kg/m^3 (default 1000); the part's mass follows from its closed bodies' volume.
    finger_mass : float
        Mass of each fingertip or jaw finger, kg (default 0.02); its weight is compensated.
    shake : float
        Peak acceleration of the shake, in g (default 1): the hand is shaken along its x,
        then y, then z, two periods each at ``shake_hz``; 0: no shake.
    shake_hz : float
        Frequency of the shake (default 4 Hz).
    timestep : float or None
        Integration step, s; None picks ``MAX_TIMESTEP`` or less, a tenth of a finger's
        period on its servo.
    iterations : int
        Iterations of MuJoCo's constraint solver (default 100).
    noslip : int
        Iterations of MuJoCo's noslip solver (default 10): without it soft friction lets a
        squeezed part creep under a steady load.

    The simulation is deterministic: the same settings give the same labels.
    """

    hand: str = "balanced"
    stiffness: float = 1e5
    grip: float = 10.0
    size: float = 0.1
    density: float = 1000.0
    finger_mass: float = 0.02
    shake: float = 1.0
    shake_hz: float = 4.0
    timestep: float | None = None
    iterations: int = 100
    noslip: int = 10

    def __post_init__(self) -> None:
        if self.hand not in HANDS:
            raise InputError(f"hand: expected one of {', '.join(HANDS)}, got {shown(self.hand)}")
        for name, (lo, hi) in RANGES.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or \
                    not (math.isfinite(v) and lo <= v <= hi):
                raise InputError(f"{name}: expected a number from {lo:g} to {hi:g}, got "
                                 f"{shown(v)}")
        for name, (lo, hi) in COUNTS.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise InputError(f"{name}: expected an integer from {lo} to {hi:,}, got "
                                 f"{shown(v)}")
        if self.timestep is not None and (
                isinstance(self.timestep, bool) or not isinstance(self.timestep, (int, float))
                or not (math.isfinite(self.timestep) and 0 < self.timestep <= 0.01)):
            raise InputError(f"timestep: expected seconds in (0, 0.01] or None, got "
                             f"{shown(self.timestep)}")

    @property
    def stroke(self) -> float:
        """How far a point finger's servo travels at the grip force, m: ``grip / stiffness``
        (twice that for the saturated hand, which aims that far into the part)."""
        return (2.0 if self.hand == "saturated" else 1.0) * self.grip / self.stiffness

    @property
    def dt(self) -> float:
        """The integration step, s."""
        if self.timestep is not None:
            return float(self.timestep)
        period = 2 * math.pi * math.sqrt(self.finger_mass / self.stiffness)
        return min(MAX_TIMESTEP, period / 10)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary of every setting, and the simulator's name and version."""
        return {"simulator": SIMULATOR, **asdict(self)}

    @classmethod
    def from_dict(cls, values: dict[str, Any], where: str = "sim") -> SimSettings:
        """Settings from :meth:`to_dict`'s form (absent settings take their defaults).

        Raises
        ------
        InputError
            An unknown setting, a bad value, or labels of another simulator version
            (``simulator`` is not ``SIMULATOR``); the message starts with ``where``.
        """
        if not isinstance(values, dict):
            raise InputError(f"{where}: expected an object of simulation settings, got "
                             f"{shown(values)}")
        given = dict(values)
        version = given.pop("simulator", SIMULATOR)
        if version != SIMULATOR:
            raise InputError(f"{where}: settings of {shown(version)}, not of this synth's "
                             f"{SIMULATOR!r} (labels of two simulator versions never mix)")
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(given) - known)
        if unknown:
            raise InputError(f"{where}: unknown setting {unknown[0]!r}; valid: "
                             f"{', '.join(sorted(known))}")
        try:
            return cls(**given)
        except InputError as e:
            raise InputError(f"{where}: {e}") from None
