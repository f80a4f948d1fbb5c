"""What a gripper plan searches for (:class:`GripperParams`) and the words its options take.

Kept apart from the gripper planner (:mod:`synth.plan.gripper`), which loads numpy, scipy and
FCL, so that the command line can state the defaults in ``--help`` without loading them.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["APPROACHES", "GRIPPER_RANK_BY", "GripperParams"]

#: Approach directions tried about each closing axis (every 360 / APPROACHES degrees).
APPROACHES: int = 4
#: Orders gripper grasps can be ranked by.
GRIPPER_RANK_BY: tuple[str, ...] = ("margin", "d_star", "mu_min", "epsilon")


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
