"""``synth sim GRASPS.json``: simulate every grasp of a grasp file in MuJoCo and label it."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from synth.cli.checks import integer, output_path, real

__all__ = ["add_parser", "add_sim_options", "run", "format_sim_table", "settings_from_args"]


def add_sim_options(p: argparse.ArgumentParser, prefix: str = "") -> None:
    """The simulated hand's options (``prefix`` "sim-" for ``synth plan --sim`` and ``synth db
    build --sim``)."""
    from synth.sim.settings import RANGES, SimSettings

    d = SimSettings()

    def rng(name: str) -> str:
        lo, hi = RANGES[name]
        return f"{lo:g} to {hi:g}"

    g = p.add_argument_group(f"simulation (MuJoCo; the part scaled to --{prefix}size)")
    if prefix:
        g.add_argument("--sim", action="store_true",
                       help="simulate every grasp found in MuJoCo, as 'synth sim' does, and "
                       "store its label with the grasp ('sim'); needs pip install 'synth[sim]'")
    g.add_argument(f"--{prefix}stiffness", type=float, default=d.stiffness, metavar="N/M",
                   help=f"gain of each finger's position servo, N/m, {rng('stiffness')} "
                   f"(default {d.stiffness:g})")
    g.add_argument(f"--{prefix}grip", type=float, default=d.grip, metavar="N",
                   help=f"force limit of each finger, N, {rng('grip')} (default {d.grip:g})")
    g.add_argument(f"--{prefix}size", type=float, default=d.size, metavar="M",
                   help=f"the part's bounding-box diagonal in the simulation, m, {rng('size')} "
                   f"(default {d.size:g})")
    g.add_argument(f"--{prefix}density", type=float, default=d.density, metavar="KG/M3",
                   help=f"the part's density, {rng('density')} (default {d.density:g}, water)")
    g.add_argument(f"--{prefix}shake", type=float, default=d.shake, metavar="G",
                   help=f"peak acceleration of the shake along x, y and z, in g, 0 to 100 "
                   f"(default {d.shake:g}; 0: no shake)")


def settings_from_args(args: argparse.Namespace, prefix: str = "", seed: int = 0):
    """:class:`synth.sim.SimSettings` from the options, each checked against its range."""
    from synth.sim.settings import RANGES, SimSettings

    key = prefix.replace("-", "_")
    values = {name: getattr(args, key + name) for name in
              ("stiffness", "grip", "size", "density", "shake")}
    for name, value in values.items():
        option = f"--{prefix}{name}"
        if name == "shake":
            real(option, value, 0, 100, unit=" g")
        else:
            real(option, value, *RANGES[name])
    return SimSettings(seed=seed, **values)


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth sim``."""
    from synth.limits import MAX_MU

    p = sub.add_parser(
        "sim",
        help="simulate the grasps of a grasp file in MuJoCo: held or not, the largest push "
        "held, the motion at failure",
        description="Simulate every grasp of a grasp file (written by 'synth plan --out') "
        "in MuJoCo with force-limited point fingers: squeeze, gravity, pushes along and "
        "torques about +-x, +-y, +-z of the part until it moves, and a shake. Each grasp "
        "gets a 'sim' label in the JSON. A gripper grasp file ('synth plan --gripper') is "
        "simulated as the scorer scored it, one soft fingertip pressing at each pad's "
        "contact; name its mesh with --mesh. Needs pip install 'synth[sim]' (mujoco, coacd).",
        epilog="Exit status: 0 every grasp simulated (held or not; a simulation that "
        "diverged is labelled so); 1 the file could not be written; 2 bad input (the line "
        "says what is wrong, also when mujoco is not installed); 3 internal error (a bug in "
        "synth). Non-convex bodies are decomposed with CoACD, cached in $SYNTH_CACHE_DIR "
        "(default ~/.cache/synth).",
    )
    p.add_argument("grasps", metavar="GRASPS.json",
                   help="grasp file written by synth plan (point fingers or --gripper)")
    p.add_argument("--mesh", default=None, metavar="MESH",
                   help="the mesh file, when it is no longer where the grasp file's mesh.path "
                   "says (it must have the same content); required for a gripper grasp file")
    p.add_argument("--mu", type=float, default=None, metavar="MU",
                   help=f"simulate with this friction coefficient, in [0, {MAX_MU:g}] "
                   "(default: the grasps' own, params.mu)")
    p.add_argument("--seed", type=int, default=0, metavar="SEED",
                   help="seed of the convex decomposition of non-convex bodies (default 0)")
    add_sim_options(p)
    o = p.add_argument_group("output")
    o.add_argument("--out", default=None, metavar="JSON",
                   help="write the labelled grasp file here, ending in .json (default: "
                   "update GRASPS.json in place)")
    o.add_argument("--no-files", action="store_true", help="write no file, only print")
    o.add_argument("--json", action="store_true",
                   help="print the labelled JSON document, not a table")
    o.add_argument("--quiet", action="store_true", help="no progress bar, no file list")
    p.set_defaults(run=run)


def format_sim_table(doc: dict) -> str:
    """Table of a labelled document's grasps: measures beside the simulation's labels."""
    lines = [f"{'#':>3}  {'d*':>8}  {'cond':>7}  {'held':<4}  {'failed at':<9}  "
             f"{'force':>6}  {'torque':>6}  motion"]
    jaws = doc.get("format") == "synth.gripper_grasps"  # its measures are kept apart

    def num(value: Any, spec: str, width: int) -> str:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        return format(value, spec) if ok else f"{'-':>{width}}"

    for i, g in enumerate(doc["grasps"], 1):
        s = g["sim"]
        failed = s["failed_at"] or "-"
        m = g["measures"] if jaws else g
        lines.append(f"{i:>3}  {num(m.get('d_star'), '>8.5f', 8)}  "
                     f"{num(m.get('conditioning'), '>7.4f', 7)}  "
                     + f"{'yes' if s['held'] else 'no':<4}  {failed:<9}  "
                     f"{s['force_min']:>6.3f}  {s['torque_min']:>6.3f}  "
                     + (f"{s['motion_at']}: {s['motion_words']}" if s["motion_words"] else "-")
                     + ("" if s["escape_cos"] is None else
                        f" (cos {s['escape_cos']:+.2f} to the predicted escape)"))
    return "\n".join(lines)


def summary(doc: dict) -> str:
    """One line: how many grasps held and what the figures mean."""
    s = doc["sim"]
    n = len(doc["grasps"])
    st = s["settings"]
    bodies = f"{s['decomposed']} bod{'y' if s['decomposed'] == 1 else 'ies'}"
    dec = "" if not s["decomposed"] else (
        f"; {bodies} decomposed into {s['pieces']} convex pieces with the others (volume "
        f"error {s['decomposition_error']:.1%})" if s["decomposition_error"] is not None
        else f"; {bodies} (open) decomposed into {s['pieces']} convex pieces with the others")
    return (f"{s['held']} of {n} grasps held (fingers {st['stiffness']:g} N/m, grip "
            f"{st['grip']:g} N, shake {st['shake']:g} g; force and torque: the weakest push "
            f"held, over the grip force and grip force x size){dec} in {s['seconds']:.1f} s")


def run(args: argparse.Namespace) -> int:
    """Run ``synth sim``."""
    from synth.cli.progress import LineProgress
    from synth.limits import MAX_MU, MAX_SEED
    from synth.sim import (
        ContactModel,
        check_document,
        check_jaw_document,
        labelled_document,
        read_json,
        require_sim,
        simulate_file,
    )
    from synth.sim.document import JAW_FORMAT

    real("--mu", args.mu, 0, MAX_MU)
    integer("--seed", args.seed, 0, MAX_SEED, "2**63 - 1")
    settings = settings_from_args(args, seed=args.seed)
    out = None if args.no_files else output_path("--out", args.out or args.grasps, ".json")
    doc = read_json(args.grasps)  # a bad file is said first, installed or not
    if isinstance(doc, dict) and doc.get("format") == JAW_FORMAT:
        return _run_jaws(args, check_jaw_document(doc, str(args.grasps)), settings, out)
    file = check_document(doc, str(args.grasps))
    require_sim()
    if args.mesh is not None:
        from dataclasses import replace

        file = replace(file, mesh_path=Path(args.mesh))
    contact = None if args.mu is None else ContactModel(args.mu)
    bar = LineProgress(enabled=not (args.quiet or args.json))
    try:
        report = simulate_file(file, settings, contact=contact,
                               progress=lambda i, n: bar(i / n, f"grasp {i} of {n}"))
    finally:
        bar.close()
    _write(args, labelled_document(file, report), out)
    return 0


def _run_jaws(args: argparse.Namespace, doc: dict, settings: Any, out: Path | None) -> int:
    """``synth sim`` of a gripper grasp file: two soft fingertips per grasp, as
    :func:`synth.sim.simulate_jaw_document` builds them, on the mesh given by ``--mesh``."""
    import numpy as np

    from synth.cli.progress import LineProgress
    from synth.errors import InputError
    from synth.part import load_part
    from synth.part.resolve import closest_points
    from synth.plan import load_options
    from synth.sim import require_sim, simulate_jaw_document

    if args.mesh is None:
        raise InputError(f"{args.grasps}: a gripper grasp file does not record its mesh's path: "
                         "name the mesh it was planned on with --mesh")
    if args.mu is not None and args.mu <= 0:
        raise InputError(f"--mu: a gripper's soft contacts need friction: expected mu > 0, got "
                         f"{args.mu:g}")
    require_sim()
    mesh = doc["mesh"]
    part = load_part(args.mesh, **load_options({"units": mesh["units"],
                                                "body": mesh.get("body", "largest"),
                                                "sharp_angle": mesh.get("sharp_angle", 30.0)}))
    planned = float(mesh["length"])
    if abs(part.length - planned) > 1e-6 * planned:
        raise InputError(f"{args.mesh}: not the mesh these grasps were planned on (its size "
                         f"is {part.length:.9g} {mesh['units']}, the file's mesh.length "
                         f"is {planned:.9g})")
    P = np.array([c["point"] for g in doc["grasps"] for c in g["contacts"]], float)
    lo, hi = part.mesh.bounds
    with np.errstate(over="ignore"):
        off = np.linalg.norm(np.maximum(0.0, np.maximum(lo - P, P - hi)), axis=1)  # to the box
    near = off <= part.surface_tolerance
    off[near] = closest_points(part, P[near])[2]
    worst = int(np.argmax(off))
    if off[worst] > part.surface_tolerance:
        how = f"{off[worst]:.3g} {mesh['units']}" if np.isfinite(off[worst]) else "far"
        raise InputError(f"{args.mesh}: not the mesh these grasps were planned on (contact "
                         f"{worst % 2} of grasp {worst // 2 + 1} lies {how} off its surface)")
    bar = LineProgress(enabled=not (args.quiet or args.json))
    try:
        labelled = simulate_jaw_document(
            doc, part, args.mesh, settings, mu=args.mu,
            progress=lambda i, n: bar(i / n, f"grasp {i} of {n}"))
    finally:
        bar.close()
    _write(args, labelled, out)
    return 0


def _write(args: argparse.Namespace, doc: dict, out: Path | None) -> None:
    """Write the labelled document to ``out`` and print the table (or the JSON)."""
    from synth.files import write_atomic

    text = json.dumps(doc, indent=1) + "\n"
    if out is not None:
        write_atomic(out, text)
    if args.json:
        print(text, end="")
    else:
        print(format_sim_table(doc))
        print(summary(doc))
        if out is not None and not args.quiet:
            print(f"wrote {out}")
