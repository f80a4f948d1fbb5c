"""``synth plan MESH``: synthesise the best collision-free grasps of a mesh."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from synth.cli.checks import output_path
from synth.cli.options import add_planning_options, check_planning_options, planning_params
from synth.cli.vocabulary import add_json, add_out, add_quiet, exit_epilog
from synth.errors import OptionError

__all__ = ["add_parser", "run", "format_plan_table", "load_part_from_args", "report_part"]


def load_part_from_args(args: argparse.Namespace):
    """``load_part`` with the mesh options of the command line."""
    from synth.part import load_part
    from synth.plan import load_options

    return load_part(args.mesh, **load_options(vars(args)))


def report_part(part, quiet: bool, unit_known: bool = False) -> None:  # type: ignore[no-untyped-def]
    """Say on stderr what loading did: one line per dropped body (always, ``--quiet`` too),
    and unless quiet one line per repair, the bodies held as one part, and each warning.
    ``unit_known``: the mesh's unit, which its file does not say, is known from elsewhere (a
    pose file's object scale), so its warning is not said."""
    from synth.part.load import UNIT_UNKNOWN

    for line in part.dropped:
        print(f"synth: {line}", file=sys.stderr)
    if quiet:
        return
    for line in part.repairs:
        print(f"repair: {line}", file=sys.stderr)
    if len(part.bodies) > 1:
        n_closed = sum(b.closed for b in part.bodies)
        area = sum(b.area for b in part.bodies)
        hidden = 1.0 - sum(b.exposed_area for b in part.bodies) / area
        print(f"bodies: {len(part.bodies)} bodies ({n_closed} closed, "
              f"{len(part.bodies) - n_closed} open) held as one rigid part; {100 * hidden:.0f}% "
              "of their surface lies against or inside another body and is never touched",
              file=sys.stderr)
    for w in part.warnings:
        if not (unit_known and w.startswith(UNIT_UNKNOWN)):
            print(f"warning: {w}", file=sys.stderr)


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth plan``."""
    p = sub.add_parser(
        "plan",
        help="synthesise the best collision-free grasps of a mesh (STL, OBJ, PLY, ...)",
        description="Search a mesh for the point-contact grasps with the highest d* "
        "(Trinkle 1992), check fingers for collisions with FCL, print a ranked table and "
        "write JSON, PNG and GLB files.",
        epilog="The JSON, PNG and GLB of one run carry the same run id (JSON 'run_id', the "
        "PNG's title, the GLB scene's extras). " + exit_epilog(
            "grasps found", "none found (the message names the motion left free), or a file "
            "could not be written"),
    )
    p.add_argument("mesh", metavar="MESH", help="mesh file: STL, OBJ, PLY, OFF, GLB/GLTF or 3MF")
    from synth.cli.gripper import add_gripper_options
    from synth.plan.gripper_params import GRIPPER_RANK_BY
    from synth.plan.params import PlanParams

    add_planning_options(p, time=PlanParams().time, rank_by_extra=GRIPPER_RANK_BY)
    add_gripper_options(p)
    p.set_defaults(mu=None, rank_by=None)  # their defaults differ with --gripper
    o = p.add_argument_group("output")
    add_out(o, "the grasps", "MESHNAME.grasps.json in the current folder")
    o.add_argument("--png", default=None, metavar="PNG",
                   help="picture, ending in .png (default: the --out name with .png, else "
                   "MESHNAME.grasps.png)")
    o.add_argument("--glb", default=None, metavar="GLB",
                   help="3-D scene of the best grasp, ending in .glb (default: the --out name "
                   "with .glb, else MESHNAME.grasps.glb)")
    o.add_argument("--no-files", action="store_true", help="write no files, only print")
    add_json(o, "the grasps")
    add_quiet(o)
    from synth.cli.sim import add_sim_options

    add_sim_options(p, switch=True)
    p.set_defaults(run=run)


def format_plan_table(plan) -> str:
    """Ranked table of a plan's grasps (a tolerance column when regions were computed; with
    the part's mass, the least squeeze in newtons, and with the grip too, the margin).
    ``N/weight``: the least force each finger must press with, in the part's weights, to
    hold it in every orientation; ``squeeze N`` the same in newtons."""
    show = any(g.contact_regions is not None for g in plan.grasps)
    newtons = any(g.least_squeeze is not None for g in plan.grasps)
    margin = any(g.margin is not None for g in plan.grasps)
    lines = [f"{'#':>3}  {'d*':>8}  {'closure':<15}  {'cond':>7}  {'epsilon':>8}  "
             f"{'N/weight':>8}  " + (f"{'squeeze N':>9}  " if newtons else "")
             + (f"{'margin':>7}  " if margin else "")
             + (f"{'tolerance':>10}  " if show else "") + f"{'features':<18}  regions"]
    for i, g in enumerate(plan.grasps, 1):
        feats = ", ".join(f"{g.features.count(k)} {k}" for k in ("face", "edge", "vertex")
                          if g.features.count(k))
        regs = " ".join(str(int(r)) for r in g.regions)
        r = g.contact_regions
        tol = "-" if r is None else f"{r.tolerance:.3g}" + ("" if r.certified else "~")
        lines.append(f"{i:>3}  {g.d_star:>8.5f}  {g.closure:<15}  {g.conditioning:>7.4f}  "
                     f"{g.epsilon:>8.5f}  {g.squeeze_per_weight:>8.3f}  "
                     + (_number(g.least_squeeze, ".2f", 9) if newtons else "")
                     + (_number(g.margin, ".2f", 7) if margin else "")
                     + (f"{tol:>10}  " if show else "") + f"{feats:<18}  {regs}")
    return "\n".join(lines)


def _number(value: float | None, spec: str, width: int) -> str:
    """A table cell: ``value`` in ``spec``, or ``-`` where there is none."""
    return f"{'-' if value is None else format(value, spec):>{width}}  "


def refuse_file_names(args: argparse.Namespace) -> None:
    """Refuse ``--out``, ``--png`` or ``--glb`` with ``--no-files``, which would drop them."""
    named = [f"--{o}" for o in ("out", "png", "glb") if getattr(args, o, None) is not None]
    if named:
        raise OptionError(f"{', '.join(named)} and --no-files: give files to write or none")


def _output_paths(args: argparse.Namespace) -> tuple[Path, Path, Path]:
    """The JSON, PNG and GLB files of a plan, checked before any work: ``--png`` and ``--glb``
    default to the folder and name of ``--out``, which defaults to MESHNAME.grasps.json."""
    stem = Path(args.mesh).name.rsplit(".", 1)[0]
    out = output_path("--out", args.out or f"{stem}.grasps.json", ".json", [args.mesh])
    png = output_path("--png", args.png or out.with_suffix(".png"), ".png", [args.mesh])
    glb = output_path("--glb", args.glb or out.with_suffix(".glb"), ".glb", [args.mesh])
    return out, png, glb


def simulate_planned(doc: dict, mesh: str, part: Any, settings: Any, quiet: bool) -> dict:
    """The plan's document with every grasp simulated (``--sim``) on the part just planned.
    A simulation synth cannot run never discards the plan: its grasps get error labels
    (:func:`synth.sim.unsimulated`) and the files are written."""
    from synth.cli.progress import LineProgress
    from synth.sim import simulate_plan, unsimulated

    bar = LineProgress(enabled=not quiet)
    try:
        return simulate_plan(doc, mesh, settings, part=part,
                             progress=lambda i, n: bar(i / n, f"simulating grasp {i} of {n}"))
    except Exception as e:  # noqa: BLE001 - synth's own failure: the plan is kept
        return unsimulated(doc, f"simulation raised {type(e).__name__}: {e}", settings)
    finally:
        bar.close()


def run(args: argparse.Namespace) -> int:
    """Run ``synth plan``; exit status 1 when no grasp was found.

    Options and output names are checked before the mesh is read; the three files are
    written together at the end (none is replaced when making any of them fails).
    """
    from synth.cli.progress import LineProgress
    from synth.files import atomic_paths, writing
    from synth.paths import stored_mesh_path
    from synth.plan import LOAD_KEYS, PlanParams, export_glb, plan_part, render_png

    if args.gripper is not None:
        from synth.cli.gripper import run_gripper

        return run_gripper(args)
    from synth.cli.gripper import refuse_gripper_options

    refuse_gripper_options(args)
    args.rank_by = args.rank_by or PlanParams().rank_by
    args.mu = PlanParams().mu if args.mu is None else args.mu
    check_planning_options(args)
    settings = None
    from synth.cli.sim import refuse_sim_options

    refuse_sim_options(args)
    if args.sim:
        from synth.cli.sim import settings_from_args
        from synth.sim import require_sim

        settings = settings_from_args(args)
        require_sim()
    given = planning_params(args)
    params = PlanParams(**{k: v for k, v in given.items() if k not in LOAD_KEYS})
    if args.no_files:
        refuse_file_names(args)
    paths = None if args.no_files else _output_paths(args)
    part = load_part_from_args(args)
    report_part(part, args.quiet)
    bar = LineProgress(enabled=not (args.quiet))
    try:
        plan = plan_part(part, params, progress=bar)
    finally:
        bar.close()
    doc = plan.to_json()
    doc["mesh"] = {**doc["mesh"], "path": stored_mesh_path(
        part.source, None if paths is None else paths[0])}  # relative to the JSON's folder
    if settings is not None and plan.grasps:
        doc = simulate_planned(doc, args.mesh, part, settings, args.quiet)
    text = json.dumps(doc, indent=1) + "\n"
    if paths is not None:
        with atomic_paths(paths) as (tmp_out, tmp_png, tmp_glb):  # all three, or none
            with writing(paths[0]):
                tmp_out.write_text(text, encoding="utf-8")
            with writing(paths[1]):
                render_png(part, plan, tmp_png, atomic=False)
            with writing(paths[2]):
                export_glb(part, plan, tmp_glb, atomic=False)
    if args.json:
        print(text, end="")
    else:
        if plan.grasps:
            print(format_plan_table(plan))
        print(plan.message)
        if "sim" in doc:
            from synth.cli.sim import format_sim_table, summary

            print(format_sim_table(doc))
            print(summary(doc))
        if paths is not None and not args.quiet:
            print(f"wrote {', '.join(map(str, paths))} (run {plan.run_id})")
    return 0 if plan.grasps else 1
