"""Planner parameters, with their documented defaults."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from synth.errors import InputError

__all__ = ["PlanParams", "RANK_BY", "MAX_FINGERS", "AUTO_MAX_FINGERS"]

#: Orders the planner can rank its grasps by.
RANK_BY: tuple[str, ...] = ("d_star", "conditioning", "epsilon")
#: Most fingers a grasp may have.
MAX_FINGERS = 12
#: Most fingers ``fingers="auto"`` tries: seven single contacts hold any part that the
#: contact planner can hold, so more fingers only help when tips cannot be placed apart.
AUTO_MAX_FINGERS = 7


@dataclass(frozen=True)
class PlanParams:
    """What the planner searches for and how long it may take.

    Attributes
    ----------
    contacts : int
        Point contacts per grasp (default 7, the fewest for frictionless form closure in
        space; with friction, 3 or more). Ignored when ``fingers`` is given.
    fingers : int, "auto" or None
        Plan grasps of this many fingertips instead, the contacts following from where they
        land (one on a face, edge or vertex; two in a groove; three in an inside corner):
        see :mod:`synth.plan.placements`. ``"auto"`` searches for the fewest fingers (2 to
        ``AUTO_MAX_FINGERS``) that give (frictional) form closure. None (default): one fingertip per contact.
    mu : float
        Coulomb friction coefficient; 0 ranks by frictionless d*, > 0 by the frictional d*.
    top : int
        Grasps wanted.
    time : float
        Wall-clock cap in seconds. The search normally ends before it (see ``evals``); a run
        cut by the cap is flagged in the plan and is no longer reproducible from the seed.
    evals : int
        Budget of grasp evaluations (default 50,000): with the seed it fixes the search, so
        the same inputs give the same grasps on any machine. The search may stop short of it
        when every climber has converged, or pass it by less than one round.
    seed : int
        Seed of every random choice.
    finger_radius : float or None
        Fingertip radius in the mesh's units; None picks a size from the part
        (:func:`synth.fingers.default_fingers`).
    body_length, body_radius : float or None
        Finger body (capsule) size; None for the defaults of :func:`synth.default_fingers`.
    approach_cone : float
        Half-angle in degrees of the cone of approach directions tried around the normal.
    support_z : float or None
        Height of a table (the plane z = support_z, part above it) that fingers must not
        cross; None for no table.
    min_d_star : float
        Grasps with a lower d* are not returned.
    min_conditioning : float
        Grasps whose scaled wrench matrix has ``sigma_min / sigma_max`` below this are
        near-degenerate and not returned (default 1e-3).
    diversity : float
        Returned grasps differ pairwise by at least this fraction of the part's length
        (Hausdorff distance between their contact sets; default 0.05).
    edges : int
        Edges of each linearised friction cone.
    rank_by : {"d_star", "conditioning", "epsilon"}
        Order of the returned grasps (default d*, ties within the LPs' accuracy broken by
        conditioning).
    """

    contacts: int = 7
    fingers: int | str | None = None
    mu: float = 0.0
    top: int = 10
    time: float = 10.0
    evals: int = 50_000
    seed: int = 0
    finger_radius: float | None = None
    body_length: float | None = None
    body_radius: float | None = None
    approach_cone: float = 0.0
    support_z: float | None = None
    min_d_star: float = 0.0
    min_conditioning: float = 1e-3
    diversity: float = 0.05
    edges: int = 8
    rank_by: str = "d_star"

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> InputError:
            return InputError(f"{name}: expected {expected}, got {getattr(self, name)!r}")

        if not isinstance(self.contacts, (int, np.integer)) or self.contacts < 2:
            raise bad("contacts", "an integer >= 2")
        if not np.isfinite(self.mu) or self.mu < 0:
            raise bad("mu", "a finite number >= 0")
        if self.fingers is not None and self.fingers != "auto" and not (
                isinstance(self.fingers, (int, np.integer)) and 2 <= self.fingers <= MAX_FINGERS):
            raise bad("fingers", f"an integer from 2 to {MAX_FINGERS}, 'auto' or None")
        if self.fingers is None and self.mu == 0 and self.contacts < 7:
            raise InputError(
                f"contacts: frictionless form closure in space needs at least 7 contacts, got "
                f"{self.contacts} (give --mu > 0 for friction)"
            )
        if self.fingers is None and self.mu > 0 and self.contacts < 3:
            raise bad("contacts", "at least 3 with friction")
        if self.top < 1:
            raise bad("top", "an integer >= 1")
        if not self.time > 0:
            raise bad("time", "a positive number of seconds")
        if self.evals < 100:
            raise bad("evals", "at least 100")
        for name in ("finger_radius", "body_length", "body_radius"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise bad(name, "a positive length in the mesh's units")
        if self.support_z is not None and not np.isfinite(self.support_z):
            raise bad("support_z", "a finite height")
        if not 0 <= self.approach_cone < 90:
            raise bad("approach_cone", "degrees in [0, 90)")
        if not 0 <= self.min_conditioning < 1:
            raise bad("min_conditioning", "a number in [0, 1)")
        if not 0 <= self.diversity < 1:
            raise bad("diversity", "a fraction in [0, 1)")
        if self.edges < 3:
            raise bad("edges", "an integer >= 3")
        if self.rank_by not in RANK_BY:
            raise bad("rank_by", f"one of {', '.join(RANK_BY)}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary of every parameter."""
        return asdict(self)
