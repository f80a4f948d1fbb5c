"""``synth sim GRASPS.json``: simulate every grasp of a grasp file in MuJoCo and label it."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from synth.cli.checks import output_path, real
from synth.cli.vocabulary import add_json, add_out, add_quiet, check_top, exit_epilog
from synth.limits import MAX_TOP

__all__ = ["add_parser", "add_sim_options", "run", "format_sim_table", "settings_from_args",
           "summary"]

#: Every simulation option takes this prefix, in ``synth sim`` as in ``plan --sim`` and
#: ``db build --sim``: ``--sim-grip`` is one thing everywhere.
PREFIX = "sim-"


def add_sim_options(p: argparse.ArgumentParser, switch: bool = False) -> None:
    """The simulated hand's options (``--sim-...``); ``switch`` adds ``--sim`` itself (for
    ``synth plan`` and ``synth db build``)."""
    from synth.sim.settings import COUNTS, HANDS, RANGES, SimSettings

    d = SimSettings()

    def rng(name: str) -> str:
        lo, hi = RANGES[name] if name in RANGES else COUNTS[name]
        return f"{lo:g} to {hi:g}"

    g = p.add_argument_group("simulation (MuJoCo)")
    if switch:
        g.add_argument("--sim", action="store_true",
                       help="simulate every grasp found in MuJoCo, as 'synth sim' does, and "
                       "store its label with the grasp ('sim'); needs pip install 'synth[sim]'")
    g.add_argument("--sim-hand", choices=HANDS, default=d.hand,
                   help="point fingers: 'balanced' presses with the grasp's own balanced "
                   "squeeze; 'saturated' presses every finger with the full grip (default "
                   f"{d.hand})")
    g.add_argument("--sim-grip", type=float, default=d.grip, metavar="NEWTONS",
                   help=f"force limit of each point finger, N, {rng('grip')} (default "
                   f"{d.grip:g}); a gripper presses with its rated force")
    g.add_argument("--sim-stiffness", type=float, default=d.stiffness, metavar="N/M",
                   help=f"gain of each finger's position servo, N/m, {rng('stiffness')} "
                   f"(default {d.stiffness:g}); the time step goes as one over its square root, "
                   "so a stiffer servo costs more: 1e9 takes about 40 s a grasp")
    g.add_argument("--sim-size", type=float, default=d.size, metavar="M",
                   help="a point-finger part's bounding-box diagonal in the simulation, m, "
                   f"{rng('size')} (default {d.size:g}); gripper parts keep their real size")
    g.add_argument("--sim-density", type=float, default=d.density, metavar="KG/M3",
                   help=f"the simulated part's density, {rng('density')} (default "
                   f"{d.density:g}, water); a gripper plan's own --mass or --density wins")
    g.add_argument("--sim-shake", type=float, default=d.shake, metavar="G",
                   help=f"peak acceleration of the shake along x, y and z, in g, "
                   f"{rng('shake')} (default {d.shake:g}; 0: no shake)")


def refuse_sim_options(args: argparse.Namespace) -> None:
    """Refuse ``--sim-...`` options changed from their defaults without ``--sim`` (``synth
    plan``, ``synth db build``): they would be ignored."""
    from synth.cli.checks import given as was_given
    from synth.errors import OptionError
    from synth.sim.settings import SimSettings

    if args.sim:
        return
    d = SimSettings()
    given = [f"--{PREFIX}{name}" for name in ("hand", "grip", "stiffness", "size", "density",
                                              "shake")
             if was_given(args, f"sim_{name}") or getattr(args, f"sim_{name}") != getattr(d, name)]
    if given:
        raise OptionError(f"{', '.join(given)}: the simulated hand's options apply with --sim "
                          "only (simulate the grasps found); add --sim or leave them out")


def settings_from_args(args: argparse.Namespace):  # type: ignore[no-untyped-def]
    """:class:`synth.sim.SimSettings` from the ``--sim-...`` options, each checked against its
    range."""
    from synth.sim.settings import RANGES, SimSettings

    values = {name: getattr(args, f"sim_{name}") for name in
              ("grip", "stiffness", "size", "density", "shake")}
    for name, value in values.items():
        real(f"--{PREFIX}{name}", value, *RANGES[name], unit=" g" if name == "shake" else "")
    return SimSettings(hand=args.sim_hand, **values)


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth sim``."""
    from synth.limits import MAX_MU

    p = sub.add_parser(
        "sim",
        help="simulate the grasps of a grasp file in MuJoCo: held or not, where it failed, "
        "how the part moved",
        description="Simulate every grasp of a grasp file (written by 'synth plan --out', "
        "point fingers or --gripper; or a ranking of gripper poses from elsewhere, 'synth rank "
        "--gripper --out', whose candidates that landed are simulated) in MuJoCo on the part "
        "that was planned (the mesh "
        "loaded again with the plan's options): the fingers close onto the part and squeeze "
        "it, then the part's weight pulls along +-x, +-y, +-z of the hand in turn, then the "
        "hand is shaken. Point fingers press with the grasp's balanced squeeze, each "
        "limited to --sim-grip; a gripper's pads close, coupled, with its rated force. Each "
        "grasp gets a 'sim' label in the JSON. Needs pip install 'synth[sim]' (mujoco). See "
        "docs/simulation.md.",
        epilog=exit_epilog(
            "every grasp simulated (held or not; one synth could not simulate is labelled "
            "'error' with the reason)", "the file could not be written",
            "also when mujoco is not installed"),
    )
    p.add_argument("grasps", metavar="GRASPS.json",
                   help="grasp file written by synth plan (point fingers or --gripper), or "
                   "a ranking written by synth rank --gripper")
    p.add_argument("--mesh", default=None, metavar="MESH",
                   help="the mesh file, when it is no longer where the grasp file's mesh.path "
                   "says (it must have the same content)")
    p.add_argument("--top", type=int, default=0, metavar="N",
                   help=f"simulate only the file's first N grasps (a ranking: its first N "
                   f"that landed), best first, 1 to {MAX_TOP:,}, or 0 for all (default 0); "
                   "the others are left without a label (an earlier one is removed: the file's "
                   "labels are all of one run)")
    p.add_argument("--mu", type=float, default=None, metavar="MU",
                   help=f"simulate with this friction coefficient, in [0, {MAX_MU:g}] "
                   "(default: the grasps' own)")
    add_sim_options(p)
    o = p.add_argument_group("output")
    add_out(o, "the labelled grasp file", "GRASPS.json, updated in place")
    o.add_argument("--no-files", action="store_true", help="write no files, only print")
    add_json(o, "the labelled grasp file")
    add_quiet(o, "sim")
    p.set_defaults(run=run)


def format_sim_table(doc: dict) -> str:
    """Table of a labelled document's grasps: measures beside the simulation's labels, in
    the plan tables' decimals (conditioning to 4, N/weight to 3)."""
    jaws = doc.get("format") == "synth.gripper_grasps"  # its measures are kept apart
    lines = [f"{'#':>3}  {'d*':>8}  {'cond' if not jaws else 'N/weight':>8}  {'held':<5}  "
             f"{'failed at':<11}  motion"]

    def num(value: Any, spec: str, width: int) -> str:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        return format(value, spec) if ok else f"{'-':>{width}}"

    for i, g in enumerate(doc["grasps"], 1):
        s = g["sim"]
        held = "-" if s["held"] is None else ("yes" if s["held"] else "no")
        m = g["measures"] if jaws else g
        second = m.get("squeeze_per_weight") if jaws else m.get("conditioning")
        what = s.get("motion_at") or s.get("failed_at") or "-"
        detail = s["motion_words"] or s.get("reason") or ""
        lines.append(f"{i:>3}  {num(m.get('d_star'), '>8.5f', 8)}  "
                     f"{num(second, '>8.3f' if jaws else '>8.4f', 8)}  {held:<5}  {what:<11}  "
                     f"{detail or '-'}"
                     + ("" if s.get("escape_cos") is None else
                        f" (cos {s['escape_cos']:+.2f} to the predicted escape)"))
    return "\n".join(lines)


def summary(doc: dict) -> str:
    """One line: how many grasps held, with which hand and part."""
    s = doc["sim"]
    n = len(doc["grasps"])
    st = s["settings"]
    jaws = doc.get("format") == "synth.gripper_grasps"
    hand = s.get("hand") if jaws else (f"{st['hand']} point fingers, grip {st['grip']:g} N "
                                       f"each, part scaled to {st['size']:g} m")
    n_f = s.get("faceted_bodies") or 0
    dec = "" if not n_f else (f"; {n_f} non-convex bod{'y' if n_f == 1 else 'ies'} of the part "
                              "simulated as thin convex slabs under the facets near the hand, "
                              "as MuJoCo collides convex shapes")
    errors = f", {s['errors']} not simulated ({s['error'] or 'see each label'})" \
        if s.get("errors") else ""
    return (f"{s['held']} of {n} grasps held{errors} ({hand}; weight along +-x, +-y, +-z, "
            f"shake {st['shake']:g} g; the protocol of {st['simulator']}, docs/simulation.md)"
            f"{dec}; {s['seconds']:.1f} s")


def run(args: argparse.Namespace) -> int:
    """Run ``synth sim``."""
    from dataclasses import replace

    from synth.cli.progress import LineProgress
    from synth.errors import MeshError, OptionError
    from synth.filetype import GRASPS, MESH, read_json, require
    from synth.limits import MAX_MU
    from synth.sim import ContactModel, labelled_document, require_sim, simulate_file
    from synth.sim.document import (
        JAW_FORMAT,
        RANKED_JAW_FORMAT,
        check_document,
        check_jaw_document,
        ranking_as_jaw_document,
    )

    real("--mu", args.mu, 0, MAX_MU)
    check_top(args.top, listing=True)
    first = args.top or None  # how many grasps to simulate (None: all)
    settings = settings_from_args(args)
    doc = read_json(args.grasps, GRASPS)
    if args.mesh is not None:
        if Path(args.mesh).is_dir():
            raise MeshError(f"--mesh: {args.mesh} is a folder, not {MESH.what}")
        if not Path(args.mesh).is_file():
            raise MeshError(f"--mesh: {args.mesh}: no such file")
        require(args.mesh, MESH)
    if args.no_files and args.out is not None:
        raise OptionError("--out and --no-files: give a file to write or none")
    same = args.out is None or (Path(args.out).is_file()
                                and os.path.samefile(args.out, args.grasps))
    out = None if args.no_files else output_path(  # the labels go into the document read
        "--out", args.grasps if same else args.out, ".json", [args.mesh], in_place=same)
    if isinstance(doc, dict) and doc.get("format") == JAW_FORMAT:
        check_jaw_document(doc, str(args.grasps))
        labelled, mesh = _simulate_jaws(args, {**doc, "grasps": doc["grasps"][:first]},
                                        settings)
        _relabel(doc, "grasps", range(len(labelled["grasps"])), labelled)
        _write(args, doc, out, mesh, shown=labelled, left=_left(len(doc["grasps"]), first))
        return 0
    if isinstance(doc, dict) and doc.get("format") == RANKED_JAW_FORMAT:
        # a ranking of poses from elsewhere: the candidates that landed get their labels
        jaws, rows = ranking_as_jaw_document(doc, str(args.grasps))
        left = _left(len(jaws["grasps"]), first)
        jaws["grasps"], rows = jaws["grasps"][:first], rows[:first]
        labelled, mesh = _simulate_jaws(args, jaws, settings)
        _relabel(doc, "candidates", rows, labelled)
        _write(args, doc, out, mesh, shown=labelled, left=left)
        return 0
    file = check_document(doc, str(args.grasps))
    left = _left(len(file.grasps), first)
    file = replace(file, grasps=file.grasps[:first])
    if args.mesh is not None:
        file = replace(file, mesh_path=Path(args.mesh))
    require_sim()
    from synth.sim import load_planned_part

    part = load_planned_part(file)
    contact = None if args.mu is None else ContactModel(args.mu)
    bar = LineProgress(enabled=not args.quiet)
    try:
        report = simulate_file(file, settings, contact=contact, part=part,
                               progress=lambda i, n: bar(i / n, f"grasp {i} of {n}"))
    finally:
        bar.close()
    labelled = labelled_document(file, report)
    _write(args, labelled, out, file.mesh_path,
           shown={**labelled, "grasps": labelled["grasps"][:len(report.labels)]}, left=left)
    return 0


def _left(n: int, first: int | None) -> int:
    """How many of ``n`` grasps ``--top`` (``first``; None: all) leaves without a label."""
    return max(0, n - first) if first else 0


def _relabel(doc: dict[str, Any], key: str, rows: Sequence[int],
             labelled: dict[str, Any]) -> None:
    """Put the labels of this run only on ``doc``: every earlier ``sim`` of ``doc[key]``
    removed, those of ``labelled``'s grasps on the items ``rows``, and the run's summary."""
    for item in doc[key]:
        if isinstance(item, dict):
            item.pop("sim", None)
    for i, g in zip(rows, labelled["grasps"], strict=True):
        doc[key][i]["sim"] = g["sim"]
    doc["sim"] = labelled["sim"]


def _simulate_jaws(args: argparse.Namespace, doc: dict, settings: Any) -> tuple[dict, Path]:
    """``synth sim`` of a gripper grasp document: its pads, as :func:`synth.sim.
    simulate_jaw_document` builds them, on the mesh the file names (or ``--mesh``), loaded
    as its ``mesh.load`` says (else its ``units``, ``body`` and ``sharp_angle``); the
    labelled document, and the mesh file simulated."""
    import numpy as np

    from synth.cli.progress import LineProgress
    from synth.errors import InputError
    from synth.part import load_part
    from synth.part.resolve import closest_points
    from synth.paths import resolve_mesh_path
    from synth.plan import load_options
    from synth.sim import require_sim, simulate_jaw_document

    mesh = doc["mesh"]
    path = args.mesh if args.mesh is not None or mesh.get("path") is None else \
        resolve_mesh_path(mesh["path"], args.grasps)
    if path is None:
        raise InputError(f"{args.grasps}: a gripper grasp file of an older synth does not "
                         "record its mesh's path: name the mesh it was planned on with --mesh")
    if args.mesh is None and not Path(path).is_file():
        raise InputError(f"{path}: no such file (the mesh {args.grasps} names; --mesh gives "
                         "its new place)")
    if args.mu is not None and args.mu <= 0:
        raise InputError(f"--mu: a gripper's soft contacts need friction: expected mu > 0, got "
                         f"{args.mu:g}")
    require_sim()
    if isinstance(mesh.get("sha256"), str) and Path(path).is_file():
        import hashlib

        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        if digest != mesh["sha256"]:
            what = (f"{path}: not the mesh these grasps were planned on" if args.mesh else
                    f"{args.grasps}: field mesh.sha256: {path} has changed since the grasps "
                    "were planned")
            raise InputError(f"{what} (sha256 {digest[:12]}..., the file says "
                             f"{mesh['sha256'][:12]}...)")
    if "load" in mesh:
        from synth.sim.document import load_keywords

        part = load_part(path, **load_keywords(mesh, str(args.grasps)))
    else:  # a file of an older synth
        part = load_part(path, **load_options({"units": mesh["units"],
                                               "body": mesh.get("body", "largest"),
                                               "sharp_angle": mesh.get("sharp_angle", 30.0)}))
    planned = float(mesh["length"])
    if abs(part.length - planned) > 1e-6 * planned:
        raise InputError(f"{path}: not the mesh these grasps were planned on (its size "
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
        raise InputError(f"{path}: not the mesh these grasps were planned on (contact "
                         f"{worst % 2} of grasp {worst // 2 + 1} lies {how} off its surface)")
    found = _gripper_file(doc, args.grasps)
    if found is not None:
        doc = {**doc, "gripper": {**doc["gripper"], "source": str(found)}}
    bar = LineProgress(enabled=not args.quiet)
    try:
        labelled = simulate_jaw_document(doc, part, settings, mu=args.mu,
                                         progress=lambda i, n: bar(i / n, f"grasp {i} of {n}"))
    finally:
        bar.close()
    return labelled, Path(path)


def _gripper_file(doc: dict, grasps: Path) -> Path | None:
    """The gripper description file a grasp document names, found where it was stored
    (relative to the grasp file; older files: to the folder the plan ran in; an absolute
    path stays itself); None for a built-in gripper's name or a file that is not there."""
    from synth.paths import resolve_mesh_path
    from synth.sim.document import jaw_gripper_source

    source = jaw_gripper_source(doc)
    if not isinstance(source, str) or not Path(source).suffix:
        return None
    found = resolve_mesh_path(source, grasps)
    return found if found.is_file() else None


def _write(args: argparse.Namespace, doc: dict, out: Path | None, mesh: Path,
           shown: dict | None = None, left: int = 0) -> None:
    """Write the labelled document to ``out`` and print the table of ``shown`` (default
    ``doc``) and how many grasps ``--top`` ``left`` unsimulated, or the JSON. The written
    file names ``mesh``, the mesh simulated, relative to its own folder
    (:func:`synth.paths.stored_mesh_path`), so that it resolves wherever the file was
    written."""
    from synth.files import write_atomic
    from synth.paths import stored_mesh_path

    if out is not None and isinstance(doc.get("mesh"), dict):
        doc["mesh"]["path"] = stored_mesh_path(mesh, out)
    found = _gripper_file(doc, args.grasps)
    if out is not None and found is not None:  # stored relative to the file written
        doc["gripper"]["source"] = stored_mesh_path(found, out)

    text = json.dumps(doc, indent=1) + "\n"
    if out is not None:
        write_atomic(out, text)
    if args.json:
        print(text, end="")
    else:
        print(format_sim_table(shown or doc))
        print(summary(shown or doc))
        if left and not args.quiet:
            print(f"{left} more grasp{'s' * (left > 1)} of the file left without a label "
                  f"(--top {args.top})")
        if out is not None and not args.quiet:
            print(f"wrote {out}")
