"""What a simulated hand is and how hard the part is pushed: :class:`SimSettings`.

The simulation runs in SI units on a copy of the part scaled so that its bounding-box
diagonal is ``size`` metres (default 0.1 m, a hand-held object) and filled with a material of
``density`` (default 1000 kg/m^3, water): a mesh in millimetres, metres or of unknown unit is
simulated the same way, and every figure it reports is relative (to the grip force, the
part's weight, its size), so it does not depend on the scale chosen.

Motion thresholds
-----------------
A part has moved when its centre of mass is displaced by more than ``TRANSLATION_RTOL *
size`` plus the fingers' elastic travel ``stroke`` (twice the grip force over the stiffness:
a compliant finger lets a held part move that far), or when it turns by more than that
length over half the size (so a point of its surface moves about as far).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from synth.errors import InputError, shown
from synth.limits import MAX_SEED

__all__ = ["SimSettings", "TRANSLATION_RTOL", "MAX_TIMESTEP", "RANGES"]

#: A part held still moves less than this fraction of its size (plus the fingers' stroke).
TRANSLATION_RTOL: float = 0.02
#: The largest time step: MuJoCo's contacts are about as stiff as their time constant, two
#: steps, allows; 2e-4 s keeps a fingertip's penetration under 10 N near 1e-4 m (0.1% of
#: the default size).
MAX_TIMESTEP: float = 2e-4


#: Accepted range of each setting (beyond them MuJoCo's numbers stop meaning anything: a part
#: of 1e-10 kg is refused by its compiler, a servo of 1e10 N/m needs steps of 1e-7 s).
RANGES: dict[str, tuple[float, float]] = {
    "stiffness": (1.0, 1e9), "grip": (1e-3, 1e6), "size": (1e-3, 1e3),
    "density": (1.0, 1e5), "finger_mass": (1e-9, 1e3), "shake_hz": (0.1, 100.0),
}


@dataclass(frozen=True)
class SimSettings:
    """The simulated hand and the disturbances.

    Attributes
    ----------
    stiffness : float
        Gain of each finger's position servo, N/m (default 1e5: a stiff finger).
    grip : float
        Force limit of each finger's servo (MuJoCo's ``forcerange``), N (default 10). The
        servo aims ``stroke = 2 grip / stiffness`` into the part, so a finger presses with the
        full grip force unless the part moves away from it.
    size : float
        The part's bounding-box diagonal in the simulation, m (default 0.1).
    density : float
        kg/m^3 (default 1000); the part's mass follows from its closed bodies' volume.
    finger_mass : float
        Mass of each fingertip, kg (default 0.02); its weight is compensated.
    shake : float
        Peak acceleration of the shake, in g (default 1): the hand is shaken along x, then y,
        then z, two periods each at ``shake_hz``; 0: no shake.
    shake_hz : float
        Frequency of the shake (default 4 Hz).
    timestep : float or None
        Integration step, s; None picks ``MAX_TIMESTEP`` or less, a tenth of a finger's
        period on its servo.
    seed : int
        Seed of the convex decomposition (CoACD); the simulation itself is deterministic.
    """

    stiffness: float = 1e5
    grip: float = 10.0
    size: float = 0.1
    density: float = 1000.0
    finger_mass: float = 0.02
    shake: float = 1.0
    shake_hz: float = 4.0
    timestep: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        for name, (lo, hi) in RANGES.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or \
                    not (math.isfinite(v) and lo <= v <= hi):
                raise InputError(f"{name}: expected a number from {lo:g} to {hi:g}, got "
                                 f"{shown(v)}")
        if isinstance(self.shake, bool) or not isinstance(self.shake, (int, float)) or \
                not (math.isfinite(self.shake) and 0 <= self.shake <= 100):
            raise InputError(f"shake: expected a number of g from 0 to 100, got "
                             f"{shown(self.shake)}")
        if self.timestep is not None and (
                isinstance(self.timestep, bool) or not isinstance(self.timestep, (int, float))
                or not (math.isfinite(self.timestep) and 0 < self.timestep <= 0.01)):
            raise InputError(f"timestep: expected seconds in (0, 0.01] or None, got "
                             f"{shown(self.timestep)}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or \
                not 0 <= self.seed <= MAX_SEED:
            raise InputError(f"seed: expected an integer from 0 to 2**63 - 1, got "
                             f"{shown(self.seed)}")

    @property
    def stroke(self) -> float:
        """How far into the part each servo aims, m: ``2 grip / stiffness``."""
        return 2.0 * self.grip / self.stiffness

    @property
    def dt(self) -> float:
        """The integration step, s."""
        if self.timestep is not None:
            return float(self.timestep)
        period = 2 * math.pi * math.sqrt(self.finger_mass / self.stiffness)
        return min(MAX_TIMESTEP, period / 10)

    @property
    def translation_limit(self) -> float:
        """Displacement of the centre of mass past which the part has moved, m."""
        return TRANSLATION_RTOL * self.size + self.stroke

    @property
    def rotation_limit(self) -> float:
        """Rotation past which the part has moved, rad."""
        return 2.0 * self.translation_limit / self.size

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary of every setting."""
        return asdict(self)
