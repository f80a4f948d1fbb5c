"""``synth plan MESH --gripper NAME|FILE``: parallel-jaw grasps as gripper poses."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from synth.cli.checks import given, integer, output_path, real
from synth.cli.options import check_weight_options
from synth.cli.vocabulary import check_top
from synth.errors import OptionError
from synth.limits import MAX_LENGTH
from synth.plan.gripper_params import MAX_MARGIN, MAX_SAMPLES

__all__ = ["add_gripper_options", "add_hold_options", "refuse_gripper_options",
           "refuse_finger_options", "gripper_params", "run_gripper", "format_gripper_table",
           "store_gripper_source"]

_ONLY_GRIPPER = ("gravity", "torsion", "samples", "min_margin")


def add_hold_options(g: argparse._ArgumentGroup) -> None:
    """How the pads hold the part: ``--torsion``, ``--gravity`` (``synth plan --gripper`` and
    ``synth rank --gripper``; checked by :func:`gripper_params`)."""
    g.add_argument("--torsion", type=float, default=None, metavar="GAMMA",
                   help="torsional friction of the pads, a length in the mesh's units, in [0, "
                   f"{MAX_LENGTH:g}] (default: 5 mm in the mesh's units, MuJoCo's default "
                   "torsional coefficient)")
    g.add_argument("--gravity", default=None, metavar="X,Y,Z",
                   help="hold against gravity in this direction of the part's frame only "
                   "(default: in every orientation)")


def add_gripper_options(p: argparse.ArgumentParser) -> None:
    """Options of the gripper route of ``synth plan``."""
    from synth.fingers.builtin import BUILTIN_GRIPPERS
    from synth.plan.gripper_params import APPROACHES, GripperParams

    d = GripperParams()
    g = p.add_argument_group("gripper (parallel-jaw grasps as gripper poses)")
    g.add_argument("--gripper", default=None, metavar="NAME|FILE",
                   help=f"plan grasps of a parallel-jaw gripper: {', '.join(BUILTIN_GRIPPERS)} "
                   "or a JSON description (see synth/fingers/grippers/README.md); needs the "
                   "part's unit (--units)")
    add_hold_options(g)
    g.add_argument("--min-margin", type=float, default=None, metavar="X",
                   help="with the part's mass (--mass or --density), return only grasps whose "
                   "least squeeze is within the gripper's rated force divided by X (a margin "
                   f"of at least X), 0 to {MAX_MARGIN:g} (default {d.min_margin:g}; 0: "
                   "no floor)")
    g.add_argument("--samples", type=int, default=None, metavar="N",
                   help=f"surface points drawn, each an antipodal pair tried at {APPROACHES} "
                   f"approach angles, 1 to {MAX_SAMPLES:,} (default {d.samples})")


def refuse_point_options(args: argparse.Namespace) -> None:
    """Point-finger options are refused with ``--gripper`` (a gripper presses with its rated
    force and is held to its own measures)."""
    for option, value in (("--grip", getattr(args, "grip", None)),
                          ("--max-squeeze", getattr(args, "max_squeeze", None))):
        if value is not None:
            raise OptionError(f"{option} applies to point fingers: a gripper presses with its "
                              "rated force (its description's grip_force)")


def refuse_gripper_options(args: argparse.Namespace) -> None:
    """Options that only mean something with ``--gripper`` are refused without it."""
    from synth.plan import params as lim

    for name in _ONLY_GRIPPER:
        if getattr(args, name) is not None:
            raise OptionError(f"--{name.replace('_', '-')} applies to gripper grasps: add "
                              "--gripper NAME|FILE")
    if args.rank_by is not None and args.rank_by not in lim.RANK_BY:
        raise OptionError(f"--rank-by {args.rank_by} applies to gripper grasps; point-finger "
                         f"plans rank by {', '.join(lim.RANK_BY)}")


def refuse_finger_options(args: argparse.Namespace, time: float) -> None:
    """Options of point-finger plans are refused with ``--gripper``, by name, when given a
    value other than their default (``time``: the command's ``--time`` default)."""
    from synth.limits import DEFAULT_SURFACE
    from synth.plan.params import PlanParams

    refuse_point_options(args)  # --grip, --max-squeeze
    d = PlanParams()
    defaults = {"contacts": d.contacts, "fingers": None, "evals": d.evals, "time": time,
                "min_d_star": d.min_d_star, "min_tolerance": d.min_tolerance,
                "regions": False, "finger_radius": None, "body_length": None,
                "body_radius": None, "approach_cone": 0.0, "surface": DEFAULT_SURFACE}
    for name, default in defaults.items():
        if given(args, name) or getattr(args, name, default) != default:
            option = "--" + name.replace("_", "-")
            raise OptionError(f"{option} applies to point-finger grasps, not to --gripper "
                              "(a gripper plan's options: --mu, --edges, --top, --seed, "
                              "--rank-by, --table, --samples, --torsion, --mass, --density, "
                              "--gravity, --min-margin and the mesh options)")


def _gravity(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        v = tuple(float(x) for x in text.split(","))
    except ValueError:
        v = ()
    if len(v) != 3 or not all(math.isfinite(x) for x in v) or not any(v):
        raise OptionError(f"--gravity: expected three numbers X,Y,Z, not all 0, got {text[:40]!r}")
    top = max(abs(x) for x in v)  # a direction: scaled so that its length cannot overflow
    return tuple(x / top for x in v)  # type: ignore[return-value]


def format_gripper_table(grasps: Sequence[Any], mm_per_unit: float,
                         labels: Sequence[dict[str, Any] | None] | None = None,
                         ranks: Sequence[int] | None = None) -> str:
    """Ranked table of gripper grasps (:class:`synth.plan.gripper.GripperGrasp` or stored
    :class:`synth.database.schema.GripperGraspRecord`: ``width``, ``margin``,
    ``least_squeeze``, ``squeeze_per_weight``, ``mu_min``, ``epsilon``, ``d_star``,
    ``points``); with simulation ``labels`` (one per grasp, None where not simulated),
    whether each held and where it failed; ``ranks`` numbers the rows (default 1, 2, ...).
    The margin and squeeze columns are shown when the part's mass gave them."""
    sim = labels is not None and any(lab is not None for lab in labels)
    # the margin and the squeeze in newtons need the part's mass: no columns of dashes
    weighed = any(g.least_squeeze is not None for g in grasps)
    lines = [f"{'#':>3}  {'width mm':>8}  "
             + (f"{'margin':>7}  {'squeeze N':>9}  " if weighed else "")
             + f"{'N/weight':>8}  {'mu_min':>8}  {'epsilon':>8}  {'d*':>6}  "
             + (f"{'held':<4}  {'failed at':<9}  " if sim else "") + "contacts"]
    for i, g in enumerate(grasps):
        margin = "-" if g.margin is None else f"{g.margin:.2f}"
        squeeze = "-" if g.least_squeeze is None else f"{g.least_squeeze:.2f}"
        newtons = f"{margin:>7}  {squeeze:>9}  " if weighed else ""
        mu_min = "-" if g.mu_min is None else f"{g.mu_min:.2g}"
        pts = "  ".join("(" + ", ".join(f"{c:.4g}" for c in p) + ")" for p in g.points)
        held = ""
        if sim:
            lab = labels[i]  # type: ignore[index]
            held = (f"{'-':<4}  {'-':<9}  " if lab is None else
                    f"{'yes' if lab['held'] else 'no':<4}  {lab['failed_at'] or '-':<9}  ")
        rank = i + 1 if ranks is None else ranks[i]
        lines.append(f"{rank:>3}  {g.width * mm_per_unit:>8.1f}  {newtons}"
                     f"{g.squeeze_per_weight:>8.3f}  {mu_min:>8}  {g.epsilon:>8.4f}  "
                     f"{g.d_star:>6.3f}  {held}{pts}")
    return "\n".join(lines)


def store_gripper_source(doc: dict[str, Any], out: Path | None) -> None:
    """A gripper description given as a file is stored in ``doc["gripper"]["source"]``
    relative to the file ``out`` that will hold the document (as its mesh is), so that
    ``synth sim`` finds it from anywhere; a built-in name stays as it is."""
    from synth.paths import stored_mesh_path

    source = doc.get("gripper", {}).get("source")
    if isinstance(source, str) and Path(source).suffix and Path(source).is_file():
        doc["gripper"]["source"] = stored_mesh_path(source, out)


def gripper_params(args: argparse.Namespace) -> Any:
    """The :class:`synth.plan.gripper.GripperParams` of checked gripper options (``synth
    plan --gripper`` and ``synth db build --gripper``)."""
    from synth.limits import MAX_MU, MAX_SEED
    from synth.plan.gripper_params import GRIPPER_RANK_BY, GripperParams

    mu = 0.5 if args.mu is None else args.mu
    real("--mu", mu, 0, MAX_MU, open_lo=True)
    check_top(args.top, listing=False)
    integer("--seed", args.seed, 0, MAX_SEED, "2**63 - 1")
    real("--table", args.table, -MAX_LENGTH, MAX_LENGTH)
    real("--torsion", args.torsion, 0, MAX_LENGTH)
    check_weight_options(args)
    samples = GripperParams().samples if args.samples is None else args.samples
    integer("--samples", samples, 1, MAX_SAMPLES)
    given = getattr(args, "min_margin", None)  # a plan's and a build's, not rank's
    real("--min-margin", given, 0, MAX_MARGIN)
    min_margin = GripperParams().min_margin if given is None else (given or None)
    rank_by = args.rank_by or "margin"
    if rank_by not in GRIPPER_RANK_BY:
        raise OptionError(f"--rank-by {rank_by}: gripper grasps rank by "
                          f"{', '.join(GRIPPER_RANK_BY)}")
    return GripperParams(gripper=args.gripper, mu=mu, torsion=args.torsion, mass=args.mass,
                         density=args.density, gravity=_gravity(args.gravity), top=args.top,
                         samples=samples, seed=args.seed, rank_by=rank_by, table=args.table,
                         edges=args.edges, min_margin=min_margin)


def require_units(args: argparse.Namespace) -> None:
    """Refuse, before the mesh is read, a file whose format never says its length unit when
    ``--units`` is not given: gripper sizes are physical (the same words as
    :func:`synth.plan.gripper.unit_scale`, which checks the loaded part)."""
    from synth.part.load import UNITLESS_FORMATS

    ext = Path(args.mesh).suffix.lower().lstrip(".")
    if args.units is None and ext in UNITLESS_FORMATS:
        raise OptionError(f"--gripper: the part's length unit is unknown ({ext.upper()} files "
                         "do not say it) and gripper sizes are physical: give --units (mm, "
                         "cm, m, in, ...)")


def run_gripper(args: argparse.Namespace) -> int:
    """Run ``synth plan --gripper``; exit status 1 when no grasp was found."""
    from synth.cli.plan import load_part_from_args, report_part
    from synth.files import atomic_paths, writing
    from synth.paths import stored_mesh_path
    from synth.plan.gripper import loaded_with, plan_gripper
    from synth.plan.params import PlanParams
    from synth.plan.render_gripper import export_gripper_glb, render_gripper_png

    refuse_finger_options(args, PlanParams().time)
    params = gripper_params(args)
    settings = None
    if hasattr(args, "sim"):
        from synth.cli.sim import refuse_sim_options

        refuse_sim_options(args)
    if getattr(args, "sim", False):
        from synth.cli.sim import settings_from_args
        from synth.sim import require_sim

        settings = settings_from_args(args)
        require_sim()
    from synth.fingers.gripper import load_gripper

    load_gripper(args.gripper)  # a bad description is refused before the mesh is read
    require_units(args)
    paths = None
    if args.no_files:
        from synth.cli.plan import refuse_file_names

        refuse_file_names(args)
    else:
        stem = Path(args.mesh).name.rsplit(".", 1)[0]
        inputs = [args.mesh, args.gripper]  # a gripper description may be a file
        out = output_path("--out", args.out or f"{stem}.grasps.json", ".json", inputs)
        paths = (out, output_path("--png", args.png or out.with_suffix(".png"), ".png", inputs),
                 output_path("--glb", args.glb or out.with_suffix(".glb"), ".glb", inputs))
    part = load_part_from_args(args)
    report_part(part, args.quiet)
    plan = plan_gripper(part, params)
    doc = plan.to_json()
    # where the mesh is (relative to the JSON's folder) and how it was loaded, so that any
    # command reading the file loads the same part
    doc["mesh"].update(path=stored_mesh_path(part.source, None if paths is None else paths[0]),
                       **loaded_with(vars(args)))
    if settings is not None and plan.grasps:
        from synth.cli.plan import simulate_planned

        doc = simulate_planned(doc, args.mesh, part, settings, args.quiet)
    store_gripper_source(doc, None if paths is None else paths[0])
    text = json.dumps(doc, indent=1) + "\n"
    if paths is not None:
        with atomic_paths(paths) as (tmp_out, tmp_png, tmp_glb):
            with writing(paths[0]):
                tmp_out.write_text(text, encoding="utf-8")
            with writing(paths[1]):
                render_gripper_png(part, plan, tmp_png)
            with writing(paths[2]):
                export_gripper_glb(part, plan, tmp_glb)
    if args.json:
        print(text, end="")
    else:
        if plan.grasps:
            print(format_gripper_table(plan.grasps, 1000.0 / plan.gripper.unit_scale,
                                       [g.get("sim") for g in doc["grasps"]]))
        print(plan.message)
        if "sim" in doc:
            from synth.cli.sim import summary

            print(summary(doc))
        if paths is not None and not args.quiet:
            print(f"wrote {', '.join(map(str, paths))} (run {plan.run_id})")
    return 0 if plan.grasps else 1
