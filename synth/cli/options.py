"""The options commands share, defined once, with one vocabulary.

A planning option added to :func:`add_planning_options` (and :func:`planning_params`) is an
option of ``synth plan`` and of ``synth db build`` both, so a database holds what ``plan``
gives for the same part. The mesh options (:func:`add_part_options`) and the finger options
(:func:`add_finger_options`) are ``rank``'s too; ``--rank-by`` takes the same words and
``--top`` counts results everywhere.

Every value is checked against its documented range after parsing, before any file is read
or written (:func:`check_planning_options`); a bad value is one line naming the option.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from synth.cli.checks import given, integer, real
from synth.cli.vocabulary import add_top, check_top
from synth.errors import OptionError, shown
from synth.limits import (
    AUTO_MAX_FINGERS,
    DEFAULT_SURFACE,
    MAX_CONTACTS,
    MAX_EDGES,
    MAX_EVALS,
    MAX_FACES,
    MAX_FINGERS,
    MAX_LENGTH,
    MAX_MU,
    MAX_SEED,
    MIN_EDGES,
    MIN_EVALS,
    SURFACES,
)
from synth.plan.params import RANK_BY, PlanParams

__all__ = ["add_part_options", "add_finger_options", "add_rank_by", "add_planning_options",
           "add_friction_options", "add_grip", "add_table", "add_weight_options",
           "check_part_options", "check_finger_options", "check_planning_options", "check_grip",
           "check_weight_options", "planning_params", "finger_overrides"]


def add_part_options(p: argparse.ArgumentParser) -> None:
    """How the mesh is loaded and read: ``--units``, ``--body``, ``--sharp-angle``,
    ``--decimate``, ``--surface``."""
    g = p.add_argument_group("mesh")
    g.add_argument("--units", default=None, metavar="UNIT",
                   help="length unit of the mesh when the file does not say (STL never does): "
                   "mm, cm, dm, m, um, in, ft or a trimesh unit name (default: the file's own "
                   "unit if it states one, else unknown, with a warning; results are then in "
                   "the file's numbers)")
    g.add_argument("--body", default="largest", metavar="WHICH",
                   help="which object to plan when the file holds several far apart: "
                   "'largest' (default), an index, the name of one of its bodies, or 'all'. "
                   "Bodies that touch or overlap, like the pieces of a convex decomposition, "
                   "are always one part")
    g.add_argument("--sharp-angle", type=float, default=30.0, metavar="DEG",
                   help="dihedral angle above which an edge is sharp, in (0, 180) degrees "
                   "(default 30)")
    g.add_argument("--decimate", type=int, default=None, metavar="N",
                   help=f"reduce the mesh to about N faces on loading, 4 to {MAX_FACES:,} (quadric "
                   "decimation with fast-simplification; the surface error it makes is "
                   f"reported): for meshes of more than {MAX_FACES:,} faces, which load only "
                   "so (default: no)")
    g.add_argument("--surface", choices=SURFACES, default=DEFAULT_SURFACE,
                   help="which normals a grasp must hold with: 'both' (default) the mesh's "
                   "own facets and the smooth surface they may approximate, d* the smaller; "
                   "'mesh' the facets alone (the mesh is the object, as a simulator's "
                   "collision mesh); 'smooth' the interpolated normals alone (the mesh "
                   "approximates a smooth part, as a scan)")


def add_finger_options(p: argparse.ArgumentParser) -> None:
    """The finger model: ``--finger-radius``, ``--body-length``, ``--body-radius``,
    ``--approach-cone``."""
    g = p.add_argument_group("fingers")
    g.add_argument("--finger-radius", type=float, default=None, metavar="R",
                   help=f"fingertip radius in the mesh's units, in (0, {MAX_LENGTH:g}] "
                   "(default: 2.5%% of the part's bounding-box diagonal)")
    g.add_argument("--body-length", type=float, default=None, metavar="L",
                   help=f"finger body length in the mesh's units, in (0, {MAX_LENGTH:g}] "
                   "(default: 10 tip radii)")
    g.add_argument("--body-radius", type=float, default=None, metavar="R",
                   help="finger body radius in the mesh's units, positive and at most the tip "
                   "radius (default: 0.75 tip radius)")
    g.add_argument("--approach-cone", type=float, default=0.0, metavar="DEG",
                   help="half-angle of the cone of approach directions tried around the "
                   "contact normal, in [0, 90) degrees (default 0: straight out)")


def add_rank_by(p: argparse.ArgumentParser | Any, what: str = "grasps",
                extra: tuple[str, ...] = ()) -> None:
    """``--rank-by``, with the same words in every command (``extra``: more words, such as
    the gripper measures of ``synth plan``)."""
    more = tuple(e for e in extra if e not in RANK_BY)
    p.add_argument("--rank-by", choices=RANK_BY + more, default="d_star",
                   help=f"order of the {what} (default d_star: by d* as printed, 5 decimals, "
                   "then by conditioning; conditioning, epsilon or tolerance, the placement "
                   "tolerance: by that measure, largest first, then as by d*; margin: by the "
                   "least squeeze per weight, smallest first, which puts the largest margin "
                   "of --grip first)"
                   + (f"; with --gripper: margin (the default), {', '.join(extra[1:])}"
                      if more else ""))


def add_planning_options(p: argparse.ArgumentParser, time: float,
                         rank_by_extra: tuple[str, ...] = ()) -> None:
    """Every option of the planner (``synth plan`` and ``synth db build``): the search, the
    mesh and the fingers. ``time`` is the default of ``--time``; ``rank_by_extra`` are more
    words for ``--rank-by``."""
    d = PlanParams()
    s = p.add_argument_group("search")
    s.add_argument("--contacts", type=int, default=d.contacts, metavar="K",
                   help=f"contacts per grasp, one fingertip each: 7 to {MAX_CONTACTS} "
                   f"without friction, 3 to {MAX_CONTACTS} with (default {d.contacts})")
    s.add_argument("--fingers", default=None, metavar="N|auto",
                   help="plan grasps of N fingertips instead of --contacts: a tip in a groove "
                   f"makes 2 contacts, in an inside corner 3; N from 2 to {MAX_FINGERS}; "
                   f"'auto' finds the fewest fingers, 2 to {AUTO_MAX_FINGERS}, that hold the "
                   "part, each count with the whole budget (default: one fingertip per "
                   "contact, see --contacts)")
    add_friction_options(s, "0: frictionless form closure; 0.5 with --gripper")
    add_top(s, "grasps", d.top, listing=False)
    s.add_argument("--time", type=float, default=time, metavar="SECONDS",
                   help=f"wall-clock cap in seconds, positive (default {time:g}; the search "
                   "usually ends sooner)")
    s.add_argument("--evals", type=int, default=d.evals, metavar="N",
                   help=f"budget of grasp evaluations, {MIN_EVALS} to {MAX_EVALS:,} "
                   f"(default {d.evals:,}); with --seed it fixes the result on any machine. "
                   "The search ends early when every climb has converged (a default plan "
                   "of a corpus part evaluates about 10,000), and each stage does a least "
                   "amount of work, so a small budget evaluates more: about 1,200 to 2,000 "
                   "grasps for 7 contacts without friction, about 3,000 with friction or "
                   "another number of contacts")
    s.add_argument("--seed", type=int, default=d.seed, metavar="SEED",
                   help=f"random seed, 0 to 2**63 - 1 (default {d.seed})")
    s.add_argument("--max-squeeze", type=float, default=None, metavar="WEIGHTS",
                   help="the physical floor: return no grasp whose fingers must each press with "
                   "more than this many times the part's weight to hold it in every "
                   f"orientation, positive (default {d.max_squeeze:g}; 0: no floor)")
    add_grip(s, "grasp")
    s.add_argument("--min-d-star", type=float, default=d.min_d_star, metavar="D",
                   help="return no grasp with a lower d*; in [0, 1], the range of d* "
                   "(default 0)")
    add_rank_by(s, extra=rank_by_extra)
    s.add_argument("--min-tolerance", type=float, default=d.min_tolerance, metavar="R",
                   help="return no grasp whose placement tolerance (how far every contact may "
                   "slide on its face or edge and the grasp stays form closure) is below R, "
                   "in the mesh's units (default 0)")
    s.add_argument("--regions", action="store_true",
                   help="compute each grasp's contact regions and placement tolerance (up to "
                   "0.1 s per grasp; on with --rank-by tolerance or --min-tolerance)")
    add_table(s)
    add_part_options(p)
    add_finger_options(p)
    add_weight_options(p)


def add_friction_options(g: argparse.ArgumentParser | Any, default: str,
                         what: str = "") -> None:
    """``--mu`` (its default in words: ``default``; ``what``: more words on whom it applies
    to) and ``--edges``, in every command that scores grasps."""
    g.add_argument("--mu", type=float, default=None, metavar="MU",
                   help=f"Coulomb friction coefficient{what}, in [0, {MAX_MU:g}] (default "
                   f"{default})")
    g.add_argument("--edges", type=int, default=PlanParams().edges, metavar="N",
                   help=f"edges of each linearised friction cone, {MIN_EDGES} to {MAX_EDGES} "
                   f"(default {PlanParams().edges})")


def add_grip(g: argparse.ArgumentParser | Any, what: str) -> None:
    """``--grip``: the force limit of each point finger (``what``: grasp or candidate)."""
    g.add_argument("--grip", type=float, default=None, metavar="NEWTONS",
                   help="force limit of each point finger in newtons, positive: with --mass "
                   f"or --density each {what} reports its margin, the grip over the least "
                   "squeeze that holds the part")


def add_table(g: argparse.ArgumentParser | Any) -> None:
    """``--table``: a support plane the hand may not cross (one help text wherever)."""
    g.add_argument("--table", type=float, default=None, metavar="Z",
                   help="a support plane z = Z in the part's frame and units that the fingers "
                   f"or the gripper may not cross, |Z| at most {MAX_LENGTH:g} (the JSON's "
                   "params.support_z); synth rank takes it for gripper poses only")


def add_weight_options(p: argparse.ArgumentParser) -> None:
    """The part's weight: ``--mass`` or ``--density`` (checked by
    :func:`check_weight_options`)."""
    g = p.add_argument_group("the part's weight (least squeeze in newtons, margins)")
    g.add_argument("--mass", type=float, default=None, metavar="KG",
                   help="the part's mass in kg, positive: each grasp then says its least "
                   "squeeze in newtons and its margin, the grip (--grip, or a gripper's rated "
                   "force) over that squeeze")
    g.add_argument("--density", type=float, default=None, metavar="KG/M3",
                   help="or its density in kg/m^3, positive, times the closed bodies' volume "
                   "(the mesh's unit must be known)")


def check_weight_options(args: argparse.Namespace) -> None:
    """``--mass`` and ``--density``: positive, not both."""
    real("--mass", args.mass, 0, math.inf, open_lo=True, open_hi=True, unit=" kg")
    real("--density", args.density, 0, math.inf, open_lo=True, open_hi=True, unit=" kg/m^3")
    if args.mass is not None and args.density is not None:
        raise OptionError("give --mass or --density, not both")
    from synth.part.load import UNITLESS_FORMATS

    ext = Path(getattr(args, "mesh", None) or "").suffix.lower().lstrip(".")
    if args.density is not None and getattr(args, "units", None) is None \
            and ext in UNITLESS_FORMATS:
        raise OptionError(f"--density: the part's volume in m^3 needs its length unit, which "
                          f"{ext.upper()} files do not say: give --units, or --mass instead")


def check_grip(args: argparse.Namespace) -> None:
    """``--grip`` gives margins only with the part's weight: refused without ``--mass`` or
    ``--density`` (it would be ignored)."""
    if args.grip is not None and args.mass is None and args.density is None:
        raise OptionError("--grip: a margin is the grip over the least squeeze in newtons, "
                          "which needs the part's weight: add --mass KG or --density KG/M3")


def check_part_options(args: argparse.Namespace) -> None:
    """The mesh options (see :func:`add_part_options`)."""
    real("--sharp-angle", args.sharp_angle, 0, 180, open_lo=True, open_hi=True, unit=" degrees")
    integer("--decimate", getattr(args, "decimate", None), 4, MAX_FACES)


def check_finger_options(args: argparse.Namespace) -> None:
    """The finger options (see :func:`add_finger_options`)."""
    for option, value in (("--finger-radius", args.finger_radius),
                          ("--body-length", args.body_length),
                          ("--body-radius", args.body_radius)):
        real(option, value, 0, MAX_LENGTH, open_lo=True, unit=" (mesh units)")
    real("--approach-cone", args.approach_cone, 0, 90, open_hi=True, unit=" degrees")


def _fingers(text: str | None) -> int | str | None:
    """``--fingers``: None, 'auto' or a number of fingertips."""
    if text is None or text == "auto":
        return text
    try:
        n = int(text)
    except ValueError:
        raise OptionError(f"--fingers: expected a number of fingertips from 2 to {MAX_FINGERS} "
                         f"or 'auto', got {text[:40]!r}") from None
    integer("--fingers", n, 2, MAX_FINGERS)
    return n


def check_planning_options(args: argparse.Namespace) -> None:
    """Every planning option against its documented range (see :func:`add_planning_options`)."""
    real("--mu", args.mu, 0, MAX_MU)
    # the range --help gives: closure in space takes 7 contacts without friction, 3 with
    lo, how = (3, "with friction (--mu > 0)") if args.mu else (
        7, "without friction (3 or more with --mu > 0)")
    if args.contacts is not None and not lo <= args.contacts <= MAX_CONTACTS:
        raise OptionError(f"--contacts: expected an integer from {lo} to {MAX_CONTACTS} {how}, "
                          f"got {shown(args.contacts)}")
    if _fingers(args.fingers) is not None and (given(args, "contacts")
                                                or args.contacts != PlanParams().contacts):
        raise OptionError("give --fingers or --contacts, not both (with --fingers each tip "
                          "makes one to three contacts, as the surface allows)")
    integer("--edges", args.edges, MIN_EDGES, MAX_EDGES)
    check_top(args.top, listing=False)
    real("--time", args.time, 0, math.inf, open_lo=True, open_hi=True, unit=" seconds")
    integer("--evals", args.evals, MIN_EVALS, MAX_EVALS)
    real("--min-d-star", args.min_d_star, 0, 1)
    real("--max-squeeze", args.max_squeeze, 0, MAX_LENGTH)
    real("--grip", args.grip, 0, MAX_LENGTH, open_lo=True, unit=" N")
    real("--min-tolerance", args.min_tolerance, 0, MAX_LENGTH)
    integer("--seed", args.seed, 0, MAX_SEED, "2**63 - 1")
    real("--table", args.table, -MAX_LENGTH, MAX_LENGTH)
    check_part_options(args)
    check_finger_options(args)
    check_weight_options(args)
    check_grip(args)


def planning_params(args: argparse.Namespace) -> dict[str, Any]:
    """The planner's parameters from checked options: the :class:`synth.PlanParams` fields
    and the mesh options (``units``, ``body``, ``sharp_angle`` in degrees), as
    :func:`synth.plan.plan_mesh_file` takes them."""
    return {
        "contacts": args.contacts, "fingers": _fingers(args.fingers), "mu": args.mu,
        "edges": args.edges, "top": args.top, "time": args.time, "evals": args.evals,
        "seed": args.seed, "finger_radius": args.finger_radius,
        "body_length": args.body_length, "body_radius": args.body_radius,
        "approach_cone": args.approach_cone, "min_d_star": args.min_d_star,
        "support_z": args.table, "rank_by": args.rank_by, "regions": args.regions,
        "min_tolerance": args.min_tolerance, "surface": args.surface,
        "max_squeeze": (PlanParams().max_squeeze if args.max_squeeze is None
                        else args.max_squeeze or None),
        "grip": args.grip,
        "mass": getattr(args, "mass", None), "density": getattr(args, "density", None),
        "units": args.units, "body": args.body, "sharp_angle": args.sharp_angle,
        "decimate": args.decimate,
    }  # fmt: skip


def finger_overrides(args: argparse.Namespace) -> dict[str, float]:
    """Keyword arguments of :func:`synth.default_fingers` from the finger options given."""
    over = {k: float(v) for k, v in (("tip_radius", args.finger_radius),
                                     ("body_length", args.body_length),
                                     ("body_radius", args.body_radius)) if v is not None}
    if args.approach_cone:
        over["approach_cone"] = math.radians(args.approach_cone)
    return over
