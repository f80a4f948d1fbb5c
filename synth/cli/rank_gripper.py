"""``synth rank MESH POSES --gripper NAME|FILE``: rank gripper poses from another tool."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from synth.errors import InputError, OptionError

__all__ = ["add_rank_gripper_options", "refuse_rank_gripper_options", "run_rank_gripper"]

_ONLY_GRIPPER = ("gripper", "gravity", "torsion", "table")


def add_rank_gripper_options(p: argparse.ArgumentParser) -> None:
    """The gripper options of ``synth rank``."""
    from synth.cli.gripper import add_hold_options
    from synth.cli.options import add_table
    from synth.fingers.builtin import BUILTIN_GRIPPERS

    g = p.add_argument_group("gripper (CANDIDATES are gripper poses)")
    g.add_argument("--gripper", default=None, metavar="NAME|FILE",
                   help=f"rank gripper poses of a parallel-jaw gripper: "
                   f"{', '.join(BUILTIN_GRIPPERS)} or a JSON description")
    add_hold_options(g)
    add_table(g)


def refuse_rank_gripper_options(args: argparse.Namespace) -> None:
    """Gripper options are refused when the candidates are contact sets."""
    from synth.plan.params import RANK_BY

    for name in _ONLY_GRIPPER[1:]:
        if getattr(args, name) is not None:
            raise OptionError(f"--{name} applies to gripper poses: add --gripper NAME|FILE")
    if args.rank_by is not None and args.rank_by not in RANK_BY:
        raise OptionError(f"--rank-by {args.rank_by} applies to gripper poses; contact sets "
                          f"rank by {', '.join(RANK_BY)}")


def _cell(x: float | None, spec: str, width: int) -> str:
    return f"{'-':>{width}}" if x is None else f"{x:>{width}{spec}}"


def format_table(rows: list[Any], mm: float) -> str:
    """The ranked table: ranked candidates with their measures, the others with the reason."""
    w = max([4] + [len(r.name) for r in rows])
    lines = [f"{'#':>3}  {'index':>5}  {'name':<{w}}  {'width mm':>8}  {'margin':>7}  "
             f"{'N/weight':>8}  {'mu_min':>8}  {'epsilon':>8}  {'closure':<15}  status"]
    for k, r in enumerate(rows, 1):
        g = r.grasp
        same = "" if r.same_as is None else f" (same jaw grasp as {r.same_as})"
        status = r.status + ("" if r.reason is None else f": {r.reason}") + same
        if g is None:
            nums = f"{'-':>8}  {'-':>7}  {'-':>8}  {'-':>8}  {'-':>8}  {'-':<15}"
        else:
            spw = g.squeeze_per_weight if g.closure == "frictional form" else None
            nums = (f"{g.width * mm:>8.1f}  {_cell(g.margin if spw else None, '.2f', 7)}  "
                    f"{_cell(spw, '.3f', 8)}  {g.mu_min:>8.2g}  "
                    f"{_cell(None if math.isnan(g.epsilon) else g.epsilon, '.4f', 8)}  "
                    f"{g.closure:<15}")
        lines.append(f"{k:>3}  {r.index:>5}  {r.name:<{w}}  {nums}  {status}")
    return "\n".join(lines)


def _warn_other_gripper(args: argparse.Namespace, named: str | None) -> None:
    """A warning (not refused: the poses may be tried on another hand on purpose) when the pose
    file names a built-in gripper other than ``--gripper``'s."""
    from synth.fingers.builtin import builtin_named

    theirs, ours = builtin_named(named), builtin_named(args.gripper)
    if theirs is not None and ours is not None and theirs != ours:
        print(f"warning: {args.candidates} holds poses of the {theirs} gripper (its "
              f"gripper/type is {named!r}), ranked here as the {ours}'s", file=sys.stderr)


def run_rank_gripper(args: argparse.Namespace) -> int:
    """Run ``synth rank --gripper``; exit status 2 when a candidate was malformed (the others
    are ranked), or none could be read or none meets the part (nothing is written then)."""
    import trimesh

    from synth.cli.checks import output_path
    from synth.cli.gripper import gripper_params, refuse_point_options
    from synth.cli.options import check_part_options
    from synth.cli.plan import load_part_from_args, report_part
    from synth.cli.rank import counts_line
    from synth.cli.vocabulary import check_top
    from synth.files import write_atomic
    from synth.filetype import POSES, require
    from synth.fingers.gripper import load_gripper
    from synth.formats import read_gripper_poses
    from synth.plan.gripper_rank import rank_gripper_poses

    if args.regions or args.min_tolerance or args.max_distance is not None:
        raise OptionError("--regions, --min-tolerance and --max-distance apply to contact "
                          "sets, not to gripper poses")
    check_top(args.top, listing=True)
    refuse_point_options(args)
    check_part_options(args)
    args.seed, args.samples = 0, None
    top = args.top
    args.top = 1  # gripper_params checks the planner's --top; rank prints its own
    params = gripper_params(args)
    args.top = top
    load_gripper(args.gripper)  # a bad description is refused before any file is read
    out = None if args.out is None else output_path("--out", args.out, ".json",
                                                    [args.mesh, args.candidates, args.gripper])
    require(args.candidates, POSES)  # a mesh, a database: named as such
    poses = read_gripper_poses(args.candidates)
    _warn_other_gripper(args, poses.gripper)
    if len(poses.errors) == len(poses.poses):
        more = f" (and {len(poses.errors) - 1} more malformed)" if len(poses.errors) > 1 else ""
        first = poses.errors[0][1] if poses.errors else f"{args.candidates}: no poses"
        raise InputError(f"no candidate could be used: {first}{more}")
    if params.mass is None and params.density is None and poses.object_mass is not None:
        from dataclasses import replace

        params = replace(params, mass=poses.object_mass)  # the file's own object mass
        if not args.quiet:
            print(f"mass: {poses.object_mass:.6g} kg, the pose file's object mass (--mass "
                  "overrides it)", file=sys.stderr)
    part = load_part_from_args(args)
    metres = None if part.units is None else float(
        trimesh.units.unit_conversion(part.units, "meters"))
    where = poses.to_part(metres, part.units)
    # a mesh of unknown unit takes the pose file's object scale, which the next line says
    report_part(part, args.quiet, unit_known=poses.object_scale is not None)
    if not args.quiet:
        print(f"poses: {where.applied}", file=sys.stderr)
    shown_n = args.top
    ranking = rank_gripper_poses(part, where.poses, where.metres_per_unit, params,
                                 dict(poses.errors), poses.names, poses.labels,
                                 None if shown_n == 0 else shown_n, where.widths)
    rows = list(ranking.rows)
    unusable = [r for r in rows if r.status in ("misses the part", "malformed")]
    if len(unusable) == len(rows):  # none where the part is: a pose file of another frame?
        more = f" (and {len(rows) - 1} more unusable)" if len(rows) > 1 else ""
        raise InputError(f"{args.candidates}: no candidate could be used: "
                         f"{unusable[0].name}: {unusable[0].status}: {unusable[0].reason}{more}"
                         "; are the poses in the mesh's frame and unit?")
    p = params
    from synth.cli.gripper import store_gripper_source
    from synth.paths import stored_mesh_path
    from synth.plan.result import load_record

    doc = {"format": "synth.ranked_gripper", "version": 1,
           "mesh": {"path": stored_mesh_path(part.source, out), "sha256": part.sha256,
                    "units": part.units,
                    "metres_per_unit": where.metres_per_unit, "length": part.length,
                    "load": load_record(part)},
           "poses": {"path": poses.path, "format": poses.format, "unit": poses.unit_name,
                     "object_scale": poses.object_scale, "object_file": poses.object_file,
                     "object_mass": poses.object_mass,
                     "label": poses.label_name, "applied": where.applied},
           "gripper": ranking.gripper.to_json(),
           "model": {"mu": p.mu, "torsion": ranking.torsion, "mass": ranking.mass,
                     "gravity": None if p.gravity is None else list(p.gravity),
                     "rank_by": p.rank_by, "edges": p.edges,
                     "epsilon": "computed for every ranked grasp" if shown_n == 0 or
                     p.rank_by in ("mu_min", "epsilon") else f"computed for the best {shown_n} "
                     "ranked grasps (--top; null for the others)"},
           "counts": ranking.counts, "seconds": ranking.seconds,
           "candidates": [r.to_dict() for r in rows]}
    store_gripper_source(doc, out)
    text = json.dumps(doc, indent=1) + "\n"
    if out is not None:
        write_atomic(out, text)
    shown = rows if shown_n == 0 else rows[:shown_n]
    if args.json:
        print(text, end="")
    else:
        print(format_table(shown, 1000.0 * where.metres_per_unit))
    for _, message in poses.errors:
        print(f"synth: error: {message}", file=sys.stderr)
    if out is not None and not args.quiet:
        print(f"wrote {out}")
    if not args.quiet:
        print(counts_line(len(rows), ranking.counts, len(shown)), file=sys.stderr)
    return 2 if poses.errors else 0
