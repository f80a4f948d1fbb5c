"""What a gripper plan searches for (:class:`GripperParams`) and the words its options take.

Kept apart from the gripper planner (:mod:`synth.plan.gripper`), which loads numpy, scipy and
FCL, so that the command line can state the defaults in ``--help`` without loading them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from synth.errors import InputError, shown
from synth.limits import MAX_EDGES, MAX_LENGTH, MAX_MU, MAX_SEED, MAX_TOP, MIN_EDGES
from synth.plan.params import _integer, _real

__all__ = ["APPROACHES", "GRIPPER_RANK_BY", "MAX_MARGIN", "MAX_SAMPLES", "GripperParams"]

#: Approach directions tried about each closing axis (every 360 / APPROACHES degrees).
APPROACHES: int = 4
#: Orders gripper grasps can be ranked by.
GRIPPER_RANK_BY: tuple[str, ...] = ("margin", "d_star", "mu_min", "epsilon")
#: Most surface points a gripper plan may draw (``--samples``).
MAX_SAMPLES = 1_000_000
#: Largest ``min_margin`` (``--min-margin``).
MAX_MARGIN = 1000.0


@dataclass(frozen=True)
class GripperParams:
    """What a gripper plan searches for.

    Attributes
    ----------
    gripper : str
        Built-in name or description file.
    mu : float
        Friction coefficient of the pads (> 0).
    torsion : float or None
        Torsional coefficient gamma in the part's unit (default
        :data:`synth.plan.gripper.TORSION_M` metres).
    mass : float or None
        Part mass in kg; or ``density`` (kg/m^3) times the closed bodies' volume.
    density : float or None
    gravity : (3,) tuple or None
        A gravity direction in the part's frame; None: every orientation.
    top : int
    samples : int
        Surface points drawn (each a candidate pair, times ``APPROACHES`` poses).
    seed : int
    rank_by : str
        One of ``GRIPPER_RANK_BY``.
    table : float or None
        Support plane z = table in the part's frame.
    edges : int
        Cone edges of the linearised contacts.
    min_margin : float or None
        When the part's mass is known, only grasps whose least squeeze is within the
        gripper's rated force divided by this are returned (a margin of at least
        ``min_margin``); None: no such floor. Without a mass it does nothing.
    """

    gripper: str = "franka"
    mu: float = 0.5
    torsion: float | None = None
    mass: float | None = None
    density: float | None = None
    gravity: tuple[float, float, float] | None = None
    top: int = 10
    samples: int = 500
    seed: int = 0
    rank_by: str = "margin"
    table: float | None = None
    edges: int = 8
    min_margin: float | None = 1.0

    def __post_init__(self) -> None:
        """Every field against the range the command line's options have."""
        def bad(name: str, expected: str) -> InputError:
            return InputError(f"{name}: expected {expected}, got {shown(getattr(self, name))}")

        def within(name: str, lo: float, hi: float, low_open: bool = False,
                   optional: bool = False) -> None:
            v = getattr(self, name)
            if optional and v is None:
                return
            if not (_real(v) and (lo < v if low_open else lo <= v) and v <= hi):
                raise bad(name, f"a number in {'(' if low_open else '['}{lo:g}, {hi:g}]"
                          + (" or None" if optional else ""))

        def count(name: str, lo: int, hi: int) -> None:
            if not (_integer(getattr(self, name)) and lo <= getattr(self, name) <= hi):
                raise bad(name, f"an integer from {lo} to {hi:,}")

        if not isinstance(self.gripper, str) or not self.gripper:
            raise bad("gripper", "a built-in gripper's name or a description file's path")
        within("mu", 0.0, MAX_MU, low_open=True)
        within("torsion", 0.0, MAX_LENGTH, optional=True)
        within("mass", 0.0, math.inf, low_open=True, optional=True)
        within("density", 0.0, math.inf, low_open=True, optional=True)
        if self.mass is not None and self.density is not None:
            raise InputError("give mass or density, not both")
        g = self.gravity
        if g is not None and not (
                not isinstance(g, (str, bytes)) and hasattr(g, "__len__") and len(g) == 3
                and all(_real(x) for x in g) and any(x != 0 for x in g)):
            raise bad("gravity", "three finite numbers, not all 0, or None")
        count("top", 1, MAX_TOP)
        count("samples", 1, MAX_SAMPLES)
        count("seed", 0, MAX_SEED)
        if self.rank_by not in GRIPPER_RANK_BY:
            raise bad("rank_by", f"one of {', '.join(GRIPPER_RANK_BY)}")
        within("table", -MAX_LENGTH, MAX_LENGTH, optional=True)
        count("edges", MIN_EDGES, MAX_EDGES)
        within("min_margin", 0.0, MAX_MARGIN, optional=True)
