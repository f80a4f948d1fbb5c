"""Planner parameters, with their documented defaults and limits.

The limits bound what one plan may ask for, so that a typing slip (``--evals 1e12``,
``--contacts 1000``) is refused at once instead of exhausting memory or running for hours,
and so that every number reaching the linear programs is one they can solve meaningfully.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, fields
from typing import Any, TypeGuard

from synth.errors import InputError, shown
from synth.limits import (
    AUTO_MAX_FINGERS,
    DEFAULT_SURFACE,
    MAX_CONTACTS,
    MAX_EDGES,
    MAX_EVALS,
    MAX_FINGERS,
    MAX_LENGTH,
    MAX_MU,
    MAX_SEED,
    MAX_TOP,
    MIN_EDGES,
    MIN_EVALS,
    SURFACES,
)

__all__ = ["PlanParams", "RANK_BY", "MAX_SQUEEZE", "BUILD_TIME", "MAX_FINGERS",
           "AUTO_MAX_FINGERS", "MAX_CONTACTS",
           "MIN_EDGES", "MAX_EDGES", "MIN_EVALS", "MAX_EVALS", "MAX_MU", "MAX_TOP", "MAX_SEED",
           "MAX_LENGTH"]

#: Orders the planner can rank its grasps by (``margin``: the least squeeze per weight,
#: smallest first, so the largest margin whatever the part's mass).
RANK_BY: tuple[str, ...] = ("d_star", "conditioning", "epsilon", "tolerance", "margin")
#: The physical floor: a grasp whose fingers must each press with more than this many times
#: the part's weight to hold it in every orientation (:mod:`synth.scores.hold`) is not
#: returned. Chosen by measurement (``scripts/bench_sim.py``; the README's "What holds").
MAX_SQUEEZE: float = 4.0
#: The wall-clock cap of each mesh's plan in a database build (``synth db build --time``):
#: far above a normal plan's, so that the evaluation budget (not the machine's speed) decides
#: the result.
BUILD_TIME: float = 600.0


def _integer(value: object) -> TypeGuard[int]:
    """A Python or numpy integer, not a bool (numpy registers its integers as
    ``numbers.Integral``; this module does not import numpy, so that the command line's
    ``--help`` need not load it). To the type checker an ``int``: numpy's integers compare
    as ints do."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def from_dict(cls: Any, given: dict[str, Any], what: str, also: tuple[str, ...] = ()) -> Any:
    """``cls(**given)`` for a parameter dataclass, with a key it has no field for named
    (``what``: the function or file the dict came to; ``also``: the other keys it takes,
    listed as valid) instead of Python's TypeError."""
    names = [f.name for f in fields(cls)]
    unknown = sorted(map(str, (k for k in given if k not in names)))
    if unknown:
        raise InputError(f"{what}: unknown parameter{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join(map(repr, unknown))}; valid: "
                         f"{', '.join(names + list(also))}")
    return cls(**given)


def _real(value: object) -> bool:
    """A finite int or float, Python's or numpy's (not a bool, not a string)."""
    if _integer(value):
        return True
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and math.isfinite(value))  # type: ignore[arg-type]


@dataclass(frozen=True)
class PlanParams:
    """What the planner searches for and how long it may take.

    Attributes
    ----------
    contacts : int
        Point contacts per grasp (default 7, the fewest for frictionless form closure in
        space; with friction, 3 or more; at most ``MAX_CONTACTS`` = 64). Ignored when
        ``fingers`` is given.
    fingers : int, "auto" or None
        Plan grasps of this many fingertips instead, the contacts following from where they
        land (one on a face, edge or vertex; two in a groove; three in an inside corner):
        see :mod:`synth.plan.placements`. ``"auto"`` searches for the fewest fingers (2 to
        ``AUTO_MAX_FINGERS``) that give (frictional) form closure. None (default): one
        fingertip per contact.
    mu : float
        Coulomb friction coefficient, 0 to ``MAX_MU`` = 100; 0 ranks by frictionless d*,
        > 0 by the frictional d*.
    top : int
        Grasps wanted, 1 to ``MAX_TOP`` = 1000.
    time : float
        Wall-clock cap in seconds (positive, finite). The search normally ends before it
        (see ``evals``); a run cut by the cap is flagged in the plan and is no longer
        reproducible from the seed.
    evals : int
        Budget of grasp evaluations (default 50,000; from ``MIN_EVALS`` = 100 to
        ``MAX_EVALS`` = 10,000,000): with the seed it fixes the search, so
        the same inputs give the same grasps on any machine. The search may stop short of it
        when every climber has converged, or pass it by less than one round.
    seed : int
        Seed of every random choice, 0 to ``MAX_SEED`` = 2**63 - 1.
    finger_radius : float or None
        Fingertip radius in the mesh's units, at most ``MAX_LENGTH`` = 1e15; None picks a
        size from the part (:func:`synth.fingers.default_fingers`).
    body_length, body_radius : float or None
        Finger body (capsule) size, positive and at most ``MAX_LENGTH``; None for the
        defaults of :func:`synth.default_fingers`.
    approach_cone : float
        Half-angle in degrees, in [0, 90), of the cone of approach directions tried around
        the normal.
    support_z : float or None
        Height of a table (the plane z = support_z, part above it) that fingers must not
        cross, |support_z| at most ``MAX_LENGTH``; None for no table.
    min_d_star : float
        Grasps with a lower d* are not returned; in [0, 1], the range of d*.
    min_conditioning : float
        Grasps whose scaled wrench matrix has ``sigma_min / sigma_max`` below this are not
        returned (default 0: the physical floor ``max_squeeze`` decides).
    max_squeeze : float or None
        The physical floor: the most finger force per unit of the part's weight a returned
        grasp may need to hold the part in every orientation (:mod:`synth.scores.hold`),
        positive; None for no floor (default ``MAX_SQUEEZE``).
    grip : float or None
        Force limit of each finger, N; with ``mass`` or ``density`` each grasp reports its
        ``margin``, the grip over the least squeeze that holds the part.
    mass : float or None
        The part's mass, kg (each grasp then reports its least squeeze in newtons).
    density : float or None
        Or its density, kg/m^3, times the closed bodies' volume (needs the part's unit).
    diversity : float
        Returned grasps differ pairwise by at least this fraction of the part's length
        (Hausdorff distance between their contact sets; default 0.05).
    edges : int
        Edges of each linearised friction cone, ``MIN_EDGES`` = 3 to ``MAX_EDGES`` = 64.
    rank_by : {"d_star", "conditioning", "epsilon", "tolerance"}
        Order of the returned grasps (default d*, ties within the LPs' accuracy broken by
        conditioning; "tolerance" is the placement tolerance of :mod:`synth.robust`).
    regions : bool
        Compute contact regions and the placement tolerance of each returned grasp
        (:func:`synth.contact_regions`; default False: it costs up to 0.1 s per grasp).
        ``rank_by="tolerance"`` and a positive ``min_tolerance`` turn it on.
    min_tolerance : float
        Grasps whose placement tolerance is below this length (the mesh's units) are not
        returned (default 0).
    surface : {"both", "mesh", "smooth"}
        Which normals a grasp must hold with (:mod:`synth.scores.surface`): the mesh's own
        facets and the smooth surface they may approximate, both (default; d* is the smaller
        of the two), or only one of them.
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
    min_conditioning: float = 0.0
    max_squeeze: float | None = MAX_SQUEEZE
    grip: float | None = None
    mass: float | None = None
    density: float | None = None
    diversity: float = 0.05
    edges: int = 8
    rank_by: str = "d_star"
    regions: bool = False
    min_tolerance: float = 0.0
    surface: str = DEFAULT_SURFACE

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> InputError:
            return InputError(f"{name}: expected {expected}, got {shown(getattr(self, name))}")

        def integer(name: str, lo: int, hi: int) -> None:
            v = getattr(self, name)
            if not (_integer(v) and lo <= v <= hi):
                raise bad(name, f"an integer from {lo} to {hi:,}")

        def length(name: str, what: str) -> None:
            v = getattr(self, name)
            if v is not None and not (_real(v) and 0 < v <= MAX_LENGTH):
                raise bad(name, f"{what} in (0, {MAX_LENGTH:g}] in the mesh's units")

        integer("contacts", 2, MAX_CONTACTS)
        if not (_real(self.mu) and 0 <= self.mu <= MAX_MU):
            raise bad("mu", f"a number from 0 to {MAX_MU:g}")
        if self.fingers is not None and self.fingers != "auto" and not (
                _integer(self.fingers) and 2 <= self.fingers <= MAX_FINGERS):
            raise bad("fingers", f"an integer from 2 to {MAX_FINGERS}, 'auto' or None")
        if self.fingers is None and self.mu == 0 and self.contacts < 7:
            raise InputError(
                f"contacts: frictionless form closure in space needs at least 7 contacts, got "
                f"{self.contacts} (give --mu > 0 for friction)"
            )
        if self.fingers is None and self.mu > 0 and self.contacts < 3:
            raise bad("contacts", "at least 3 with friction")
        integer("top", 1, MAX_TOP)
        if not (_real(self.time) and self.time > 0):
            raise bad("time", "a positive, finite number of seconds")
        integer("evals", MIN_EVALS, MAX_EVALS)
        integer("seed", 0, MAX_SEED)
        length("finger_radius", "a radius")
        length("body_length", "a length")
        length("body_radius", "a radius")
        if self.support_z is not None and not (_real(self.support_z)
                                               and abs(self.support_z) <= MAX_LENGTH):
            raise bad("support_z", f"a height from -{MAX_LENGTH:g} to {MAX_LENGTH:g}")
        if not (_real(self.approach_cone) and 0 <= self.approach_cone < 90):
            raise bad("approach_cone", "degrees in [0, 90)")
        if not (_real(self.min_d_star) and 0 <= self.min_d_star <= 1):
            raise bad("min_d_star", "a number in [0, 1] (d* lies in [0, 1])")
        if not (_real(self.min_conditioning) and 0 <= self.min_conditioning < 1):
            raise bad("min_conditioning", "a number in [0, 1)")
        if self.max_squeeze is not None and not (_real(self.max_squeeze)
                                                 and self.max_squeeze > 0):
            raise bad("max_squeeze", "a positive, finite number of weights, or None")
        for name, what in (("grip", "a force in newtons"), ("mass", "a mass in kg"),
                           ("density", "a density in kg/m^3")):
            v = getattr(self, name)
            if v is not None and not (_real(v) and 0 < v <= MAX_LENGTH):
                raise bad(name, f"{what}, positive and finite")
        if self.mass is not None and self.density is not None:
            raise InputError("mass, density: give one of them, not both")
        if self.grip is not None and self.mass is None and self.density is None:
            raise InputError("grip: a margin is the grip over the least squeeze in newtons, "
                             "which needs the part's weight: give mass or density too")
        if not (_real(self.diversity) and 0 <= self.diversity < 1):
            raise bad("diversity", "a fraction in [0, 1)")
        integer("edges", MIN_EDGES, MAX_EDGES)
        if self.rank_by not in RANK_BY:
            raise bad("rank_by", f"one of {', '.join(RANK_BY)}")
        if not isinstance(self.regions, bool):
            raise bad("regions", "True or False")
        if not (_real(self.min_tolerance) and 0 <= self.min_tolerance <= MAX_LENGTH):
            raise bad("min_tolerance", f"a length in [0, {MAX_LENGTH:g}] in the mesh's units")
        if self.surface not in SURFACES:
            raise bad("surface", f"one of {', '.join(SURFACES)}")

    @property
    def floor(self) -> float:
        """The physical floor as a number (``inf`` for none)."""
        return math.inf if self.max_squeeze is None else float(self.max_squeeze)

    @property
    def wants_regions(self) -> bool:
        """Whether the returned grasps get contact regions and tolerances."""
        return self.regions or self.rank_by == "tolerance" or self.min_tolerance > 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary of every parameter."""
        return asdict(self)
