"""``synth plan MESH``: synthesise the best collision-free grasps of a mesh."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["add_parser", "run", "add_finger_options", "add_part_options", "format_plan_table",
           "load_part_from_args"]


def add_part_options(p: argparse.ArgumentParser) -> None:
    """Options of mesh loading, shared by ``plan`` and ``rank``."""
    g = p.add_argument_group("mesh")
    g.add_argument("--units", default=None,
                   help="length unit of the mesh when the file does not say (e.g. mm)")
    g.add_argument("--body", default="largest",
                   help="which body of a file with several: 'largest' (default), an index, a "
                   "name, or 'all' to keep them together")
    g.add_argument("--sharp-angle", type=float, default=30.0, metavar="DEG",
                   help="dihedral angle above which an edge is sharp (default 30)")


def load_part_from_args(args: argparse.Namespace):
    """``load_part`` with the mesh options of the command line."""
    import math

    from synth.part import load_part

    body = int(args.body) if str(args.body).lstrip("-").isdigit() else args.body
    return load_part(args.mesh, units=args.units, body=body,
                     sharp_angle=math.radians(args.sharp_angle))


def add_finger_options(p: argparse.ArgumentParser) -> None:
    """Options of the finger model, shared by ``plan`` and ``rank``."""
    g = p.add_argument_group("fingers")
    g.add_argument("--finger-radius", type=float, default=None, metavar="R",
                   help="fingertip radius in the mesh's units (default: 2.5%% of the part's "
                   "bounding-box diagonal)")
    g.add_argument("--body-length", type=float, default=None, metavar="L",
                   help="finger body length (default: 10 tip radii)")
    g.add_argument("--body-radius", type=float, default=None, metavar="R",
                   help="finger body radius, at most the tip radius (default: 0.75 tip radius)")
    g.add_argument("--approach-cone", type=float, default=0.0, metavar="DEG",
                   help="half-angle of the cone of approach directions tried around the "
                   "contact normal, degrees (default 0: straight out)")


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth plan``."""
    p = sub.add_parser(
        "plan",
        help="synthesise the best collision-free grasps of a mesh (STL, OBJ, PLY, ...)",
        description="Search a mesh for the point-contact grasps with the highest d* "
        "(Trinkle 1992), check fingers for collisions with FCL, print a ranked table and "
        "write JSON, PNG and GLB files.",
    )
    p.add_argument("mesh", help="mesh file: STL, OBJ, PLY, OFF, GLB/GLTF or 3MF")
    p.add_argument("--contacts", type=int, default=7, help="contacts per grasp (default 7)")
    p.add_argument("--mu", type=float, default=0.0,
                   help="Coulomb friction coefficient (default 0: frictionless form closure)")
    p.add_argument("--top", type=int, default=10, help="grasps to return (default 10)")
    p.add_argument("--time", type=float, default=10.0,
                   help="wall-clock cap in seconds (default 10; the search usually ends sooner)")
    p.add_argument("--evals", type=int, default=20_000,
                   help="grasp evaluations (default 20000); with --seed this fixes the result")
    p.add_argument("--min-d-star", type=float, default=0.0, help="drop grasps below this d*")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--table", type=float, default=None, metavar="Z",
                   help="a support plane z = Z under the part that fingers must not cross")
    add_part_options(p)
    add_finger_options(p)
    o = p.add_argument_group("output")
    o.add_argument("--out", default=None, metavar="JSON",
                   help="grasp file (default: MESHNAME.grasps.json in the current folder)")
    o.add_argument("--png", default=None, help="picture (default: MESHNAME.grasps.png)")
    o.add_argument("--glb", default=None, help="3-D scene (default: MESHNAME.grasps.glb)")
    o.add_argument("--no-files", action="store_true", help="write no files, only print")
    o.add_argument("--json", action="store_true", help="print the JSON document, not a table")
    o.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(run=run)


def format_plan_table(plan) -> str:
    """Ranked table of a plan's grasps."""
    lines = [f"{'#':>3}  {'d*':>8}  {'closure':<15}  {'cond':>7}  {'epsilon':>8}  "
             f"{'features':<18}  regions"]
    for i, g in enumerate(plan.grasps, 1):
        feats = ", ".join(f"{g.features.count(k)} {k}" for k in ("face", "edge", "vertex")
                          if g.features.count(k))
        regs = " ".join(str(int(r)) for r in g.regions)
        lines.append(f"{i:>3}  {g.d_star:>8.5f}  {g.closure:<15}  {g.conditioning:>7.4f}  "
                     f"{g.epsilon:>8.5f}  {feats:<18}  {regs}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``synth plan``; exit status 1 when no grasp was found."""
    from synth.cli.progress import LineProgress
    from synth.plan import PlanParams, export_glb, plan_part, render_png

    params = PlanParams(
        contacts=args.contacts, mu=args.mu, top=args.top, time=args.time, evals=args.evals,
        seed=args.seed, finger_radius=args.finger_radius, body_length=args.body_length,
        body_radius=args.body_radius, approach_cone=args.approach_cone,
        min_d_star=args.min_d_star, support_z=args.table,
    )
    part = load_part_from_args(args)
    bar = LineProgress(enabled=not (args.quiet or args.json))
    try:
        plan = plan_part(part, params, progress=bar)
    finally:
        bar.close()
    doc = plan.to_json()
    stem = Path(args.mesh).name.rsplit(".", 1)[0]
    written = []
    if not args.no_files:
        out = Path(args.out or f"{stem}.grasps.json")
        out.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        png = render_png(part, plan, args.png or f"{stem}.grasps.png")
        glb = export_glb(part, plan, args.glb or f"{stem}.grasps.glb")
        written = [str(out), str(png), str(glb)]
    if args.json:
        print(json.dumps(doc, indent=1))
    else:
        if not args.quiet:
            for w in part.warnings:
                print(f"warning: {w}", file=sys.stderr)
        if plan.grasps:
            print(format_plan_table(plan))
        print(plan.message)
        if written and not args.quiet:
            print("wrote " + ", ".join(written))
    return 0 if plan.grasps else 1
