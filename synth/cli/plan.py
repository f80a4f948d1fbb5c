"""``synth plan MESH``: synthesise the best collision-free grasps of a mesh."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from synth.cli.checks import check_finger_options, check_part_options, integer, output_path, real

__all__ = ["add_parser", "run", "add_finger_options", "add_part_options", "format_plan_table",
           "load_part_from_args", "report_part"]


def add_part_options(p: argparse.ArgumentParser) -> None:
    """Options of mesh loading, shared by ``plan`` and ``rank``."""
    from synth.scores.surface import DEFAULT_SURFACE, SURFACES

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
    g.add_argument("--surface", choices=SURFACES, default=DEFAULT_SURFACE,
                   help="which normals a grasp must hold with: 'both' (default) the mesh's "
                   "own facets and the smooth surface they may approximate, d* the smaller; "
                   "'mesh' the facets alone (the mesh is the object, as a simulator's "
                   "collision mesh); 'smooth' the interpolated normals alone (the mesh "
                   "approximates a smooth part, as a scan)")


def load_part_from_args(args: argparse.Namespace):
    """``load_part`` with the mesh options of the command line."""
    from synth.part import load_part

    try:
        body: int | str = int(args.body)
    except ValueError:
        body = args.body
    return load_part(args.mesh, units=args.units, body=body,
                     sharp_angle=math.radians(args.sharp_angle))


def report_part(part, quiet: bool) -> None:  # type: ignore[no-untyped-def]
    """Say on stderr what loading did: one line per dropped body (always, ``--quiet`` too),
    and unless quiet one line per repair, the bodies held as one part, and each warning."""
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
        print(f"warning: {w}", file=sys.stderr)


def add_finger_options(p: argparse.ArgumentParser) -> None:
    """Options of the finger model, shared by ``plan`` and ``rank``."""
    from synth.limits import MAX_LENGTH

    g = p.add_argument_group("fingers")
    g.add_argument("--finger-radius", type=float, default=None, metavar="R",
                   help=f"fingertip radius in the mesh's units, in (0, {MAX_LENGTH:g}] "
                   "(default: 2.5%% of the part's bounding-box diagonal)")
    g.add_argument("--body-length", type=float, default=None, metavar="L",
                   help=f"finger body length, in (0, {MAX_LENGTH:g}] (default: 10 tip radii)")
    g.add_argument("--body-radius", type=float, default=None, metavar="R",
                   help="finger body radius, positive and at most the tip radius (default: "
                   "0.75 tip radius)")
    g.add_argument("--approach-cone", type=float, default=0.0, metavar="DEG",
                   help="half-angle of the cone of approach directions tried around the "
                   "contact normal, in [0, 90) degrees (default 0: straight out)")


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth plan``."""
    p = sub.add_parser(
        "plan",
        help="synthesise the best collision-free grasps of a mesh (STL, OBJ, PLY, ...)",
        description="Search a mesh for the point-contact grasps with the highest d* "
        "(Trinkle 1992), check fingers for collisions with FCL, print a ranked table and "
        "write JSON, PNG and GLB files.",
        epilog="The JSON, PNG and GLB of one run carry the same run id (JSON 'run_id', the "
        "PNG's title, the GLB scene's extras). Exit status: 0 grasps found; 1 none found (the "
        "message names the motion left free) or a file could not be written; 2 bad input (the "
        "line says what is wrong); 3 internal error (a bug in synth).",
    )
    p.add_argument("mesh", help="mesh file: STL, OBJ, PLY, OFF, GLB/GLTF or 3MF")
    from synth.plan import params as lim

    d = lim.PlanParams()
    p.add_argument("--contacts", type=int, default=d.contacts, metavar="K",
                   help=f"contacts per grasp, one fingertip each: 7 to {lim.MAX_CONTACTS} "
                   f"without friction, 3 to {lim.MAX_CONTACTS} with (default {d.contacts})")
    p.add_argument("--fingers", default=None, metavar="N|auto",
                   help="plan grasps of N fingertips instead of --contacts: a tip in a groove "
                   "makes 2 contacts, in an inside corner 3; N from 2 to "
                   f"{lim.MAX_FINGERS}; 'auto' finds the fewest fingers, 2 to "
                   f"{lim.AUTO_MAX_FINGERS}, that hold the part, each count with the whole "
                   "budget (default: one fingertip per contact, see --contacts)")
    p.add_argument("--mu", type=float, default=0.0, metavar="MU",
                   help=f"Coulomb friction coefficient, in [0, {lim.MAX_MU:g}] (default 0: "
                   "frictionless form closure)")
    p.add_argument("--top", type=int, default=d.top, metavar="N",
                   help=f"grasps to return, 1 to {lim.MAX_TOP} (default {d.top})")
    p.add_argument("--time", type=float, default=d.time, metavar="SECONDS",
                   help=f"wall-clock cap in seconds, positive (default {d.time:g}; the search "
                   "usually ends sooner)")
    p.add_argument("--evals", type=int, default=d.evals, metavar="N",
                   help=f"budget of grasp evaluations, {lim.MIN_EVALS} to {lim.MAX_EVALS:,} "
                   f"(default {d.evals:,}); with --seed it fixes the result on any machine. "
                   "The search ends early when every climber has converged (about half the "
                   "default budget on simple parts), and each stage does a least amount of "
                   "work, so small budgets evaluate about 2,500 grasps")
    p.add_argument("--min-d-star", type=float, default=0.0, metavar="D",
                   help="return no grasp with a lower d*; in [0, 1], the range of d* "
                   "(default 0)")
    p.add_argument("--rank-by", choices=lim.RANK_BY, default="d_star",
                   help="order of the grasps returned (default d_star; d* values within 1e-6 "
                   "of each other, the LPs' accuracy, are ordered by conditioning; tolerance: "
                   "the placement tolerance, largest first)")
    p.add_argument("--min-tolerance", type=float, default=0.0, metavar="R",
                   help="return no grasp whose placement tolerance (how far every contact may "
                   "slide on its face or edge and the grasp stays form closure) is below R, "
                   "in the mesh's units (default 0)")
    p.add_argument("--regions", action="store_true",
                   help="compute each grasp's contact regions and placement tolerance (up to "
                   "0.1 s per grasp; on with --rank-by tolerance or --min-tolerance)")
    p.add_argument("--seed", type=int, default=d.seed, metavar="SEED",
                   help=f"random seed, 0 to 2**63 - 1 (default {d.seed})")
    p.add_argument("--table", type=float, default=None, metavar="Z",
                   help="a support plane z = Z under the part that fingers must not cross; "
                   f"|Z| at most {lim.MAX_LENGTH:g}")
    add_part_options(p)
    add_finger_options(p)
    o = p.add_argument_group("output")
    o.add_argument("--out", default=None, metavar="JSON",
                   help="grasp file, ending in .json (default: MESHNAME.grasps.json in the "
                   "current folder)")
    o.add_argument("--png", default=None, metavar="PNG",
                   help="picture, ending in .png (default: the --out name with .png, else "
                   "MESHNAME.grasps.png)")
    o.add_argument("--glb", default=None, metavar="GLB",
                   help="3-D scene, ending in .glb (default: the --out name with .glb, else "
                   "MESHNAME.grasps.glb)")
    o.add_argument("--no-files", action="store_true", help="write no files, only print")
    o.add_argument("--json", action="store_true", help="print the JSON document, not a table")
    o.add_argument("--quiet", action="store_true",
                   help="print only the table and the result line: no progress bar, no loading "
                   "notes (dropped objects are still said), no list of files written")
    from synth.cli.sim import add_sim_options

    add_sim_options(p, prefix="sim-")
    p.set_defaults(run=run)


def format_plan_table(plan) -> str:
    """Ranked table of a plan's grasps (a tolerance column when regions were computed)."""
    show = any(g.contact_regions is not None for g in plan.grasps)
    lines = [f"{'#':>3}  {'d*':>8}  {'closure':<15}  {'cond':>7}  {'epsilon':>8}  "
             + (f"{'tolerance':>10}  " if show else "") + f"{'features':<18}  regions"]
    for i, g in enumerate(plan.grasps, 1):
        feats = ", ".join(f"{g.features.count(k)} {k}" for k in ("face", "edge", "vertex")
                          if g.features.count(k))
        regs = " ".join(str(int(r)) for r in g.regions)
        r = g.contact_regions
        tol = "-" if r is None else f"{r.tolerance:.3g}" + ("" if r.certified else "~")
        lines.append(f"{i:>3}  {g.d_star:>8.5f}  {g.closure:<15}  {g.conditioning:>7.4f}  "
                     f"{g.epsilon:>8.5f}  " + (f"{tol:>10}  " if show else "")
                     + f"{feats:<18}  {regs}")
    return "\n".join(lines)


def _fingers(text: str | None) -> int | str | None:
    """``--fingers``: None, 'auto' or a number of fingertips."""
    from synth.limits import MAX_FINGERS

    if text is None or text == "auto":
        return text
    try:
        n = int(text)
    except ValueError:
        from synth.errors import InputError

        raise InputError(f"--fingers: expected a number of fingertips from 2 to {MAX_FINGERS} "
                         f"or 'auto', got {text[:40]!r}") from None
    integer("--fingers", n, 2, MAX_FINGERS)
    return n


def _check_options(args: argparse.Namespace) -> None:
    """Every numeric option of ``synth plan`` against its documented range."""
    from synth.plan import params as lim

    integer("--contacts", args.contacts, 2, lim.MAX_CONTACTS)
    real("--mu", args.mu, 0, lim.MAX_MU)
    integer("--top", args.top, 1, lim.MAX_TOP)
    real("--time", args.time, 0, math.inf, open_lo=True, open_hi=True, unit=" seconds")
    integer("--evals", args.evals, lim.MIN_EVALS, lim.MAX_EVALS)
    real("--min-d-star", args.min_d_star, 0, 1)
    real("--min-tolerance", args.min_tolerance, 0, lim.MAX_LENGTH)
    integer("--seed", args.seed, 0, lim.MAX_SEED, "2**63 - 1")
    real("--table", args.table, -lim.MAX_LENGTH, lim.MAX_LENGTH)
    check_part_options(args)
    check_finger_options(args)


def _output_paths(args: argparse.Namespace) -> tuple[Path, Path, Path]:
    """The JSON, PNG and GLB files of a plan, checked before any work: ``--png`` and ``--glb``
    default to the folder and name of ``--out``, which defaults to MESHNAME.grasps.json."""
    stem = Path(args.mesh).name.rsplit(".", 1)[0]
    out = output_path("--out", args.out or f"{stem}.grasps.json", ".json")
    png = output_path("--png", args.png or out.with_suffix(".png"), ".png")
    glb = output_path("--glb", args.glb or out.with_suffix(".glb"), ".glb")
    return out, png, glb


def _simulate(doc: dict, mesh: str, settings, quiet: bool) -> dict:  # type: ignore[no-untyped-def]
    """The plan's document with every grasp simulated (``--sim``)."""
    from synth.cli.progress import LineProgress
    from synth.sim import check_document, labelled_document, simulate_file

    file = check_document(doc, mesh)
    bar = LineProgress(enabled=not quiet)
    try:
        report = simulate_file(file, settings,
                               progress=lambda i, n: bar(i / n, f"simulating grasp {i} of {n}"))
    finally:
        bar.close()
    return labelled_document(file, report)


def run(args: argparse.Namespace) -> int:
    """Run ``synth plan``; exit status 1 when no grasp was found.

    Options and output names are checked before the mesh is read; the three files are
    written together at the end (none is replaced when making any of them fails).
    """
    from synth.cli.progress import LineProgress
    from synth.files import atomic_paths, writing
    from synth.plan import PlanParams, export_glb, plan_part, render_png

    _check_options(args)
    settings = None
    if args.sim:
        from synth.cli.sim import settings_from_args
        from synth.sim import require_sim

        settings = settings_from_args(args, prefix="sim-", seed=args.seed)
        require_sim()
    params = PlanParams(
        contacts=args.contacts, fingers=_fingers(args.fingers), mu=args.mu, top=args.top,
        time=args.time, evals=args.evals,
        seed=args.seed, finger_radius=args.finger_radius, body_length=args.body_length,
        body_radius=args.body_radius, approach_cone=args.approach_cone,
        min_d_star=args.min_d_star, support_z=args.table, rank_by=args.rank_by,
        regions=args.regions, min_tolerance=args.min_tolerance, surface=args.surface,
    )
    paths = None if args.no_files else _output_paths(args)
    part = load_part_from_args(args)
    report_part(part, args.quiet or args.json)
    bar = LineProgress(enabled=not (args.quiet or args.json))
    try:
        plan = plan_part(part, params, progress=bar)
    finally:
        bar.close()
    doc = plan.to_json()
    if settings is not None and plan.grasps:
        doc = _simulate(doc, args.mesh, settings, args.quiet or args.json)
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
