"""``synth rank MESH CANDIDATES``: score contact sets from elsewhere on a mesh."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from synth.cli.checks import integer, output_path, real
from synth.cli.options import (
    add_finger_options,
    add_friction_options,
    add_grip,
    add_part_options,
    add_rank_by,
    add_weight_options,
    check_finger_options,
    check_grip,
    check_part_options,
    check_weight_options,
    finger_overrides,
)
from synth.cli.vocabulary import (
    DEFAULT_ROWS,
    add_json,
    add_out,
    add_quiet,
    add_top,
    check_top,
    exit_epilog,
)
from synth.errors import InputError
from synth.files import write_atomic
from synth.limits import MAX_EDGES, MAX_LENGTH, MAX_MU, MIN_EDGES

__all__ = ["add_parser", "run", "counts_line", "STATUS_HELP"]

#: The statuses of ``synth rank``'s candidates, contact sets and gripper poses alike.
STATUS_HELP = ("Each candidate gets one status: ok (scored; the fingers or the gripper fit), "
               "tolerance (ok, but its placement tolerance is below --min-tolerance), "
               "collision (scored, but the hand hits the part or crosses --table), misses the "
               "part (a point farther than --max-distance from the surface; a pad meeting no "
               "part of the mesh), no contact (a point on hidden surface, where no finger can "
               "touch; jaws without a trustworthy two-pad contact), malformed (not readable "
               "as a candidate, or too few contacts).")


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth rank``."""
    p = sub.add_parser(
        "rank",
        help="rank candidate grasps from another tool on a mesh",
        description="Snap each candidate's points to the mesh surface, resolve their normals "
        "with the part model (given normals are ignored), check the fingers with FCL, score "
        "by d* and print the candidates ranked. CANDIDATES is JSON (a list of {points[, name]}"
        " or an object with a 'candidates' or 'grasps' list) or NPZ; with --gripper, gripper "
        "poses: ACRONYM .h5, GraspGen .json, isaac_grasp .yaml, an NPZ or JSON of (n, 4, 4) "
        "poses, or a synth gripper grasp file. A synth plan (or ranking) records its "
        "length unit (mesh.units): its candidates are in it, so it is taken when --units is "
        "not given, and another --units is refused.",
        epilog=exit_epilog("ranked (every candidate read, usable or not)", None,
                           "a malformed candidate, reported on its own line while the others "
                           "are still ranked; or no candidate could be used, the line giving "
                           "the first one's reason, and nothing is written") + ". "
        + STATUS_HELP,
    )
    p.add_argument("mesh", metavar="MESH", help="mesh file: STL, OBJ, PLY, OFF, GLB/GLTF or 3MF")
    p.add_argument("candidates", metavar="CANDIDATES",
                   help="candidate file (.json or .npz; with --gripper also .h5 or .yaml)")
    add_friction_options(p, "0; 0.5 with --gripper")
    p.add_argument("--max-distance", type=float, default=None, metavar="D",
                   help="largest distance from a point to the surface that is snapped, in mesh "
                   f"units, in [0, {MAX_LENGTH:g}] (default: 1%% of the part's bounding-box "
                   "diagonal)")
    p.add_argument("--regions", action="store_true",
                   help="compute each closure candidate's contact regions and placement "
                   "tolerance (as synth plan --regions)")
    add_grip(p, "candidate")
    from synth.plan.gripper_params import GRIPPER_RANK_BY

    add_rank_by(p, "candidates; tolerance computes the regions", extra=GRIPPER_RANK_BY)
    p.add_argument("--min-tolerance", type=float, default=0.0, metavar="R",
                   help="give collision-free candidates whose placement tolerance is below R "
                   f"(mesh units, in [0, {MAX_LENGTH:g}]) the status 'tolerance', ranked "
                   "after the usable ones (default 0)")
    add_top(p, "candidates", DEFAULT_ROWS, listing=True,
            note="--out and --json hold every one")
    add_part_options(p)
    add_finger_options(p)
    add_weight_options(p)
    o = p.add_argument_group("output")
    add_out(o, "every candidate ranked")
    add_json(o, "every candidate ranked")
    add_quiet(o, "rank")
    from synth.cli.rank_gripper import add_rank_gripper_options

    add_rank_gripper_options(p)
    p.set_defaults(run=run, mu=None, rank_by=None)  # their defaults differ with --gripper


def _cell(value: float, spec: str, width: int) -> str:
    """A number of the table, or ``-`` when it was not computed (NaN)."""
    return f"{'-':>{width}}" if math.isnan(value) else f"{value:>{width}{spec}}"


def run(args: argparse.Namespace) -> int:
    """Run ``synth rank``: exit status 2 when a candidate was malformed (the others are
    ranked and written) or when none could be used."""
    from synth.cli.plan import load_part_from_args, report_part
    from synth.cli.rank_contacts import (
        SCORED,
        STATUSES,
        RankedCandidate,
        order_rows,
        rank_candidates,
    )
    from synth.fingers import default_fingers
    from synth.grasps import read_candidate_table

    if args.gripper is not None:
        from synth.cli.rank_gripper import run_rank_gripper

        return run_rank_gripper(args)
    from synth.cli.rank_gripper import refuse_rank_gripper_options

    refuse_rank_gripper_options(args)
    args.mu = 0.0 if args.mu is None else args.mu
    args.rank_by = args.rank_by or "d_star"
    real("--mu", args.mu, 0, MAX_MU)
    integer("--edges", args.edges, MIN_EDGES, MAX_EDGES)
    real("--max-distance", args.max_distance, 0, MAX_LENGTH, unit=" (mesh units)")
    real("--min-tolerance", args.min_tolerance, 0, MAX_LENGTH, unit=" (mesh units)")
    check_top(args.top, listing=True)
    real("--grip", args.grip, 0, MAX_LENGTH, open_lo=True, unit=" N")
    check_part_options(args)
    check_finger_options(args)
    unit_from_file = args.units is None  # a plan records its unit: known once it is read
    check_weight_options(argparse.Namespace(**{**vars(args), "units": "m"}) if unit_from_file
                         else args)
    check_grip(args)
    out = None if args.out is None else output_path("--out", args.out, ".json",
                                                    [args.mesh, args.candidates])
    _refuse_named_gripper_poses(args.candidates)
    table = read_candidate_table(args.candidates, require_normals=False)
    if not table.groups:  # every candidate malformed: say so before loading the mesh
        more = f" (and {len(table.errors) - 1} more malformed)" if len(table.errors) > 1 else ""
        raise InputError(f"no candidate could be used: {table.errors[0][1]}{more}")
    _take_recorded_unit(args, table.mesh)
    _take_recorded_load(args, table.mesh)
    if unit_from_file:
        check_weight_options(args)  # --density needs a unit, the file's or --units
    part = load_part_from_args(args)
    report_part(part, args.quiet)
    fingers = default_fingers(part, **finger_overrides(args))
    max_d = args.max_distance if args.max_distance is not None else 0.01 * part.length
    from synth.plan import PlanParams
    from synth.plan.search import part_weight

    weight = part_weight(part, PlanParams(mass=args.mass, density=args.density))
    index = sorted(i for g in table.groups for i in g.index.tolist())
    rows = rank_candidates(part, table.candidates(), args.mu, fingers, max_d,
                           regions=args.regions, rank_by=args.rank_by,
                           min_tolerance=args.min_tolerance, edges=args.edges, index=index,
                           surface=args.surface, weight=weight, grip=args.grip)
    rows = order_rows(rows + [RankedCandidate(table.names[i], "malformed", message, index=i)
                              for i, message in table.errors], args.rank_by)
    unusable = [r for r in rows if r.status not in SCORED]
    misses = sum(r.status == "misses the part" for r in rows)
    other = _another_mesh(table.mesh, part.sha256, args.candidates) if misses else None
    if len(unusable) == len(rows):
        more = f" (and {len(rows) - 1} more unusable)" if len(rows) > 1 else ""
        planned = "" if other is None else f" planned on another mesh ({other}), not " \
            f"{args.mesh}: rank it on that mesh;"  # first: a long line is cut at its end
        raise InputError(f"{args.candidates}:{planned} no candidate could be used: "
                         f"{unusable[0].reason}{more}")
    if other is not None and not args.quiet:
        print(f"warning: {args.candidates} was planned on another mesh ({other}); {misses} of "
              f"its {len(rows)} candidates miss {args.mesh}", file=sys.stderr)
    from synth.paths import stored_mesh_path
    from synth.plan.result import load_record

    doc = {"format": "synth.ranked", "version": 2, "mesh": {
           "path": stored_mesh_path(part.source, out),
           "sha256": part.sha256, "units": part.units, "load": load_record(part),
           "length": part.length},
           "mu": args.mu, "edges": args.edges, "surface": args.surface,
           "fingers": fingers.to_dict(),
           "candidates": [r.to_dict() for r in rows]}
    text = json.dumps(doc, indent=1) + "\n"
    if out is not None:
        write_atomic(out, text)
    shown = rows if args.top == 0 else rows[:args.top]
    if args.json:
        print(text, end="")
    else:
        w = max([4] + [len(r.name) for r in shown])
        show = args.regions or args.rank_by == "tolerance" or args.min_tolerance > 0
        margin = any(r.margin is not None for r in shown)
        print(f"{'#':>3}  {'name':<{w}}  {'d*':>8}  {'closure':<15}  {'cond':>7}  "
              f"{'epsilon':>8}  {'N/weight':>8}  " + (f"{'margin':>7}  " if margin else "")
              + (f"{'tolerance':>10}  " if show else "") + "status")
        for i, r in enumerate(shown, 1):
            status = r.status if r.reason is None else f"{r.status}: {r.reason}"
            reg = r.contact_regions
            tol = "-" if reg is None else f"{reg.tolerance:.3g}" + ("" if reg.certified else "~")
            print(f"{i:>3}  {r.name:<{w}}  {_cell(r.d_star, '.5f', 8)}  "
                  f"{r.closure or '-':<15}  {_cell(r.conditioning, '.4f', 7)}  "
                  f"{_cell(r.epsilon, '.5f', 8)}  {_cell(r.squeeze_per_weight, '.3f', 8)}  "
                  + (f"{_cell(math.nan if r.margin is None else r.margin, '.2f', 7)}  "
                     if margin else "") + (f"{tol:>10}  " if show else "") + status)
    # every malformed candidate on a line of its own, in file order: the reader's (a NaN, a
    # missing field) and the ranking's (too few contacts, 2-D points)
    malformed = sorted((r for r in rows if r.status == "malformed"),
                       key=lambda r: -1 if r.index is None else r.index)
    for r in malformed:
        reason = r.reason or ""
        where = "" if reason.startswith(f"{args.candidates}: ") else f"{args.candidates}: "
        print(f"synth: error: {where}{reason}", file=sys.stderr)
    if out is not None and not args.quiet:
        print(f"wrote {out}")
    if not args.quiet:
        print(counts_line(len(rows), {s: sum(r.status == s for r in rows) for s in STATUSES},
                          len(shown)), file=sys.stderr)
    return 2 if malformed else 0


def recorded_unit(mesh: Any) -> str | None:
    """The length unit a plan's (or a ranking's) ``mesh`` object records, as
    :func:`synth.load_part` reads it (its ``load.units``, else its ``units``, as ``synth sim``
    reads a plan's); None when it records none, or one that is no length unit."""
    if not isinstance(mesh, dict):
        return None
    load = mesh.get("load")
    unit = load.get("units") if isinstance(load, dict) and "units" in load else mesh.get("units")
    if not isinstance(unit, str):
        return None
    from synth.part.load import length_unit

    return length_unit(unit)


def _take_recorded_unit(args: argparse.Namespace, mesh: Any) -> None:
    """The length unit of a plan's candidates, which its file records (``mesh.units``): taken
    when ``--units`` is not given (said unless quiet), and ``--units`` of another unit refused
    (the plan's coordinates are in its recorded unit)."""
    from trimesh import units as trimesh_units

    from synth.part.load import length_unit

    planned = recorded_unit(mesh)
    if planned is None:
        return
    if args.units is None:
        args.units = planned
        if not args.quiet:
            print(f"units: {planned}, the unit {args.candidates} records",
                  file=sys.stderr)
        return
    given = length_unit(args.units)
    # the same length in other words ('decimeter', 'dm', 'Decimeters') is the same unit
    if given is not None and not math.isclose(trimesh_units.to_inch(given),
                                              trimesh_units.to_inch(planned), rel_tol=1e-12):
        raise InputError(f"--units {args.units}: {args.candidates} records its coordinates in "
                         f"{planned}, and a plan's coordinates are in its recorded unit: leave "
                         f"--units out, or give --units {planned}")


def _refuse_named_gripper_poses(candidates: str) -> None:
    """An ACRONYM file of poses given as contact sets: when it names one of the built-in
    grippers (``gripper/type``), the line says which ``--gripper`` to give (the candidate
    reader's own line says to give one)."""
    from synth.filetype import kind_of

    if kind_of(candidates) != "hdf5":  # by its first bytes, as the candidate reader tells
        return
    from synth.fingers.builtin import builtin_named
    from synth.formats.acronym import recorded_gripper

    named = recorded_gripper(candidates)
    hand = builtin_named(named)
    if hand is not None:
        raise InputError(f"{candidates}: gripper poses (ACRONYM .h5) of the {hand} gripper (its "
                         f"gripper/type is {named!r}), not contact sets: rank them with synth "
                         f"rank MESH {candidates} --gripper {hand}")


def _take_recorded_load(args: argparse.Namespace, mesh: Any) -> None:
    """The other options a plan's part was loaded with (``mesh.load``: ``body``,
    ``sharp_angle``, ``decimate``), taken where the command line does not give them, so
    that the candidates are ranked on the part they were planned on; said unless quiet."""
    load = mesh.get("load") if isinstance(mesh, dict) else None
    if not isinstance(load, dict):
        return
    from synth.cli.checks import given
    from synth.sim.document import load_keywords

    load_keywords(mesh, str(args.candidates))  # the recorded values, checked
    taken = []
    for dest, option, default in (("body", "--body", "largest"),
                                  ("sharp_angle", "--sharp-angle", 30.0),
                                  ("decimate", "--decimate", None)):
        value = load.get(dest, default)
        if not given(args, dest) and value != getattr(args, dest):
            setattr(args, dest, value)
            taken.append(f"{option} {value}")
    if taken and not args.quiet:
        print(f"load: {', '.join(taken)}, as {args.candidates} records its part was loaded",
              file=sys.stderr)


def _another_mesh(mesh: Any, sha256: str | None, candidates: str) -> str | None:
    """The mesh a plan's (or a ranking's) ``mesh`` object records, in words (its path, found
    from the candidate file's folder, and its sha256), when its sha256 is not ``sha256``, that
    of the mesh file given; None when it is, or the file records none."""
    import os

    recorded = mesh.get("sha256") if isinstance(mesh, dict) else None
    if not isinstance(recorded, str) or sha256 is None or recorded == sha256:
        return None
    digest = f"sha256 {recorded[:12]}..."
    path = mesh.get("path")
    if not isinstance(path, str) or not path:
        return digest
    from synth.paths import resolve_mesh_path

    try:
        found = resolve_mesh_path(path, candidates)
        relative = os.path.relpath(found)
    except (InputError, ValueError, OSError):  # a path no file can have (a NUL in it)
        return digest
    return f"{found if relative.startswith('..') else relative}, {digest}"


def counts_line(n: int, counts: dict[str, int], shown: int) -> str:
    """The last line of ``synth rank``, contact sets and gripper poses alike: how many
    candidates got each status, and how many rows the table showed."""
    more = f"; showing the best {shown} (--top 0 for all)" if shown < n else ""
    return f"{n} candidates: " + ", ".join(f"{v} {k}" for k, v in counts.items()) + more
