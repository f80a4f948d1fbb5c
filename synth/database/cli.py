"""The ``synth db`` command: ``build``, ``info``, ``top`` and ``export``.

``add_db_parser(subparsers)`` adds the ``db`` command to the main parser; ``run_db(args)`` runs
it and returns the exit status (errors print one ``synth: error: ...`` line, no traceback).
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
from dataclasses import asdict
from typing import Any

from synth.cli.options import (
    add_planning_options,
    check_part_options,
    check_planning_options,
    planning_params,
)
from synth.cli.vocabulary import add_json, add_quiet, exit_epilog, top_help
from synth.errors import shown
from synth.filetype import MESH_FORMATS
from synth.limits import MAX_TOP
from synth.plan.gripper_params import GRIPPER_RANK_BY
from synth.plan.params import BUILD_TIME, RANK_BY, PlanParams

__all__ = ["add_db_parser", "run_db"]

_DESCRIPTION = (
    "Build and query offline grasp databases: 'synth db build' plans grasps for many meshes "
    "into one SQLite file; 'info', 'top' and 'export' read it without writing anything, so "
    "they work on a database in a read-only folder and while a build runs."
)

_BUILD_DESCRIPTION = """\
Plan the best grasps of every mesh found in the sources and store them in one SQLite
database. A build is resumable: run the same command again after an interruption and only
the meshes not yet recorded are planned. Meshes that cannot be loaded, or on which no grasp
is found, are recorded as failed with the reason (see 'synth db info').

Results are deterministic: the seed and the evaluation budget (--evals) fix every mesh's
grasps, whatever the number of workers or the engine.
"""

_BUILD_EPILOG = """\
evals: a database build defaults to the same evaluation budget as 'synth plan', so the
database holds the grasps plan would give; a smaller --evals trades quality for throughput.

stopping: Ctrl-C or SIGTERM stop the workers and keep the meshes finished (exit status 130
or 143); even after SIGKILL no worker process outlives the build, and rerunning the command
finishes the database. One build at a time writes a database: another build of the same
--out file is refused as busy (exit status 1).

planner hook: set SYNTH_DB_PLANNER=module:function (or --planner) to plan with any function
plan_mesh_file(path, params) -> dict returning synth's grasp document.

""" + exit_epilog("built (meshes that failed are recorded with the reason: see synth db "
                  "info)", "the database is busy (another build writes it) or cannot be "
                  "written") + "; 130 interrupted; 143 stopped by SIGTERM"


# Ranges of the database's own numeric options (shown in --help, checked once parsed, before
# the database opens, in the words of every other option's check: synth.cli.checks); the
# planning options are plan's (synth.cli.options).
_WORKERS = (0, 1024)
_TIMEOUT = (0.0, 1e6)


def _integer(option: str, value: str | int | None, lo: int, hi: int) -> int | None:
    """An integer option's value, parsed from its text (None: not given) and checked against
    ``lo..hi``: a word or a number out of range is refused in one line, ``--workers: expected
    an integer from 0 to 1,024, got 'x'``, as every option's check words it (argparse's own
    types wrote ``argument --workers: ...``)."""
    if value is None or isinstance(value, int):
        number = value
    else:
        try:
            number = int(value)
        except ValueError:
            from synth.errors import OptionError

            raise OptionError(f"{option}: expected an integer from {lo:,} to {hi:,}, got "
                              f"{shown(value)}") from None
    from synth.cli.checks import integer

    integer(option, number, lo, hi)
    return number


def _real(option: str, value: str | None, lo: float, hi: float, unit: str) -> float | None:
    """A number option above ``lo`` up to ``hi`` (see :func:`_integer`)."""
    if value is None:
        return None
    try:
        number = float(value)
    except ValueError:
        number = math.nan  # refused below, as NaN is
    if not (math.isfinite(number) and lo < number <= hi):
        from synth.errors import OptionError

        raise OptionError(f"{option}: expected a number in ({lo:g}, {hi:g}]{unit}, got "
                          f"{shown(value)}")  # as synth.cli.checks.real, the text as given
    return number


def add_db_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``db`` command (and its subcommands) to an argparse ``subparsers`` object."""
    db = subparsers.add_parser(
        "db", help="build and query offline grasp databases", description=_DESCRIPTION,
        epilog="Each subcommand's --help lists its exit statuses. " + exit_epilog(
            "done", "the system refused (a busy database, a file that cannot be written)"),
    )
    sub = db.add_subparsers(dest="db_command", metavar="{build,info,top,export}")
    sub.required = True
    db.set_defaults(run=run_db)

    b = sub.add_parser(
        "build",
        help="plan grasps for many meshes into an SQLite database (resumable)",
        description=_BUILD_DESCRIPTION,
        epilog=_BUILD_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    b.add_argument("sources", nargs="+", metavar="MESH_DIR_OR_LIST",
                   help="folders (searched recursively for mesh files: "
                   f"{', '.join('.' + e for e in MESH_FORMATS)}; symbolic links to files and "
                   "folders are followed, and a folder met again through a link, as in a link "
                   "cycle, is searched once), mesh files, or text files listing mesh paths")
    b.add_argument("--out", required=True, metavar="DB",
                   help="the database file, created or resumed (one build at a time writes it)")
    add_planning_options(b, time=BUILD_TIME, rank_by_extra=GRIPPER_RANK_BY)
    b.add_argument("--workers", default=None, metavar="N",
                   help=f"worker processes, {_WORKERS[0]} to {_WORKERS[1]} (default: all CPUs; "
                   "0 = plan in this process)")
    b.add_argument("--engine", choices=("local", "dask"), default="local",
                   help="local worker processes or a Dask cluster (default local)")
    b.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address (engine dask; default: a local Dask cluster)")
    b.add_argument("--planner", default=None, metavar="MODULE:FUNCTION",
                   help="plan with this function instead of synth's (see 'planner hook')")
    from synth.cli.gripper import add_gripper_options

    add_gripper_options(b)  # --gripper: gripper grasps, stored in the table gripper_grasps
    b.set_defaults(mu=None, rank_by=None)  # their defaults differ with --gripper
    b.add_argument("--retry-failed", action="store_true", help="plan failed meshes again")
    b.add_argument("--timeout", default=None,
                   metavar="SECONDS",
                   help=f"seconds of planning per mesh, above 0 to {_TIMEOUT[1]:,.0f}, "
                   "before it is stopped and recorded as failed with kind 'timeout' (local engine; "
                   "default: none, the planner's own --time cap bounds its search)")
    add_quiet(b, "db build")
    from synth.cli.sim import add_sim_options

    add_sim_options(b, switch=True)  # --sim: each mesh's grasps simulated on the worker

    reading = exit_epilog("done", "the database is busy or cannot be read",
                          "also a file that is not a synth grasp database")
    i = sub.add_parser("info", help="counts, failures and parameters of a database",
                       description="Counts, failures and parameters of a database.",
                       epilog=reading)
    i.add_argument("database", metavar="DB", help="database file")
    add_json(i, "the counts, failures and parameters", out=False, quiet=False)

    t = sub.add_parser("top", help="best grasps of one mesh", description="Best grasps of one "
                       "mesh.", epilog=exit_epilog(
                           "done", "the database is busy or cannot be read", "also a file "
                           "that is not a synth grasp database, or a mesh it does not hold"))
    t.add_argument("database", metavar="DB", help="database file")
    t.add_argument("mesh", metavar="MESH_NAME", help="mesh name, stem, path or sha256")
    t.add_argument("--top", "-k", default=5, metavar="N",
                   help=top_help("grasps", 5, listing=True) + "; -k is its old spelling")
    t.add_argument("--rank-by", choices=tuple(dict.fromkeys(("rank",) + RANK_BY
                                                            + GRIPPER_RANK_BY)),
                   default="rank",
                   help="order of the grasps (default rank: the database's own, its build's "
                   "--rank-by). Point-finger grasps: d_star, by d* as printed, 5 decimals, then "
                   "by conditioning; conditioning, epsilon or tolerance, the placement "
                   "tolerance, which needs a database built with --regions: by that measure, "
                   "largest first. Gripper grasps: margin (least squeeze per weight first), "
                   "d_star, mu_min (smallest first) or epsilon (largest first)")
    add_json(t, "the grasps", out=False, quiet=False)

    e = sub.add_parser(
        "export", help="export a database to HDF5, NPZ or JSON, or to ACRONYM, GraspGen or "
        "isaac_grasp files", description="Export a database to HDF5, NPZ or JSON (one file, "
        "synth's columns), or its gripper grasps to the layouts of ACRONYM (HDF5), GraspGen "
        "(JSON) or isaac_grasp (YAML): one file per mesh in the folder --out, poses in metres.",
        epilog=exit_epilog("exported", "the database is busy or cannot be read, or a file "
                           "could not be written", "also a file that is not a synth grasp "
                           "database"))
    e.add_argument("database", metavar="DB", help="database file")
    e.add_argument("--format", choices=("h5", "npz", "json", "acronym", "graspgen", "isaac"),
                   default=None, help="default: from the extension of --out (h5, npz, json)")
    e.add_argument("--out", required=True, metavar="FILE|FOLDER",
                   help="the file to write (.h5, .npz or .json), whole or not at all; or a "
                   "folder for acronym, graspgen and isaac")
    e.add_argument("--units", default=None, metavar="UNIT",
                   help="length unit of meshes whose unit the database does not know (acronym, "
                   "graspgen, isaac: their poses are in metres)")
    add_quiet(e, "db export")
    return db  # type: ignore[no-any-return]


def _build(args: argparse.Namespace) -> int:
    from synth.database.build import build_database

    args.workers = _integer("--workers", args.workers, *_WORKERS)
    args.timeout = _real("--timeout", args.timeout, *_TIMEOUT, unit=" seconds")
    planner = args.planner
    if args.gripper is None:
        from synth.cli.gripper import refuse_gripper_options

        refuse_gripper_options(args)
        args.mu = PlanParams().mu if args.mu is None else args.mu
        args.rank_by = args.rank_by or PlanParams().rank_by
        check_planning_options(args)
        params = planning_params(args)
    else:  # gripper grasps (synth plan --gripper): the gripper planner's own parameters
        from synth.cli.gripper import gripper_params, refuse_finger_options

        refuse_finger_options(args, BUILD_TIME)
        check_part_options(args)
        params = {"units": args.units, "body": args.body, "sharp_angle": args.sharp_angle,
                  **asdict(gripper_params(args))}
        planner = planner or "synth.plan:plan_gripper_file"
    from synth.cli.sim import refuse_sim_options

    refuse_sim_options(args)
    if args.sim:
        from synth.cli.sim import settings_from_args

        params["sim"] = settings_from_args(args).to_dict()
    if args.scheduler is not None and args.engine != "dask":
        from synth.errors import OptionError

        raise OptionError("--scheduler: a Dask scheduler's address applies with --engine dask "
                          "only; add --engine dask or leave it out")
    report = build_database(
        args.sources, args.out, params, workers=args.workers, engine=args.engine,
        scheduler=args.scheduler, planner=planner, retry_failed=args.retry_failed,
        timeout=args.timeout, quiet=args.quiet,
    )  # fmt: skip
    if not args.quiet:
        print(report.summary(), file=sys.stderr)
    return 0


def _info(args: argparse.Namespace) -> int:
    from synth.database.store import GraspDatabase

    with GraspDatabase(args.database) as db:
        info = db.info()
    if args.json:
        print(json.dumps(info.to_dict(), indent=1))
        return 0
    params = " ".join(f"{k}={v}" for k, v in sorted(info.params.items()))
    print(f"{info.path}: synth grasp database, schema {info.schema_version}, "
          f"created by synth {info.synth_version}")  # fmt: skip
    print(f"planner: {info.planner}\nparams: {params}")
    print(f"meshes: {info.meshes} ({info.done} done, {info.failed} failed, "
          f"{info.duplicates} duplicates, {info.pending} pending)")  # fmt: skip
    kinds = [f"{info.grasps - info.gripper_grasps} point-finger"] * bool(
        info.grasps - info.gripper_grasps) + [f"{info.gripper_grasps} gripper"] * bool(
        info.gripper_grasps)
    gripper = info.params.get("gripper")
    of = f" ({', '.join(kinds)}{f', {gripper}' if gripper else ''})" if kinds else ""
    print(f"grasps: {info.grasps}{of}\nplanner time: {info.plan_s:.1f} s")
    print(_loading_line(info))
    if info.failures:
        print("failures:")
        for path, kind, error in info.failures:
            print(f"  {path}: [{kind}] {error}")
    return 0


def _loading_line(info: Any) -> str:
    """What loading did to the meshes, from their reports (``meshes.mesh_report``)."""
    if info.with_report == 0:
        why = " (schema 1 file)" if info.schema_version < 2 else ""
        return f"loading: no mesh reports{why}"
    noun = "mesh" if info.repaired == 1 else "meshes"
    return (
        f"loading: {info.repaired} {noun} repaired, {info.with_dropped} with dropped objects, "
        f"{info.with_warnings} with warnings (of {info.with_report} with a loading report)"
    )


def _top(args: argparse.Namespace) -> int:
    from synth.database.schema import GraspRecord, GripperGraspRecord
    from synth.database.store import GraspDatabase
    from synth.errors import DatabaseFileError

    args.top = _integer("--top", args.top, 0, MAX_TOP)  # as rank's and score's --top
    with GraspDatabase(args.database) as db:
        mesh = db.mesh(args.mesh)
        grasps = db.top(args.mesh, args.top or sys.maxsize, args.rank_by)  # 0: all
    if args.json:
        print(json.dumps({"mesh": mesh.path, "status": mesh.status, "error_kind":
                          mesh.error_kind, "error": mesh.error,
                          "grasps": [g.to_dict() for g in grasps]}, indent=1))
        return 0
    note = f" ({mesh.error})" if mesh.status != "done" and mesh.error else ""
    # a mesh's grasps are of one kind: gripper grasps, or point-finger grasps
    jaws = [g for g in grasps if isinstance(g, GripperGraspRecord)]
    points = [g for g in grasps if isinstance(g, GraspRecord)]
    what = (f"{jaws[0].gripper} gripper " if jaws else "") + ("grasp" if len(grasps) == 1
                                                              else "grasps")
    print(f"{mesh.path} [{mesh.status}]{note}: {len(grasps)} {what}")
    if jaws:
        import trimesh

        from synth.cli.gripper import format_gripper_table

        if mesh.units is None:  # gripper grasps are planned in known units
            raise DatabaseFileError(f"{args.database}: mesh {mesh.path!r} has gripper grasps "
                                    "but no units: the file is damaged")
        mm = float(trimesh.units.unit_conversion(mesh.units, "millimeters"))
        print(format_gripper_table(jaws, mm, [g.sim for g in jaws], [g.rank for g in jaws]))
    elif points:
        print(_point_table(points))
    return 0


def _point_table(points: list[Any]) -> str:
    """``db top``'s table of point-finger grasps (:class:`synth.database.schema.GraspRecord`):
    each grasp's place as stored (``#``, as the gripper table's; ``rank`` in synth's words is
    a wrench matrix's rank, docs/vocabulary.md), the closure measures, the least squeeze
    per weight and the margin where stored, the tolerance where measured, the simulation's
    label where simulated."""
    weight = any(g.squeeze_per_weight is not None for g in points)
    margin = any(g.margin is not None for g in points)
    show = any(g.tolerance is not None for g in points)
    sim = any(g.sim is not None for g in points)

    def value(x: float | None, spec: str) -> str:
        return "-" if x is None else format(x, spec)

    def label(g: Any) -> str:
        if g.sim is None:
            return f"{'-':<5}  {'-':<9}  "
        held = {True: "yes", False: "no", None: "error"}[g.sim.get("held")]
        return f"{held:<5}  {g.sim.get('failed_at') or '-':<9}  "

    lines = [f"{'#':>3}  {'d*':>8}  {'cond':>8}  {'epsilon':>8}  "
             + (f"{'N/weight':>8}  " if weight else "") + (f"{'margin':>8}  " if margin else "")
             + (f"{'tolerance':>10}  " if show else "")
             + (f"{'held':<5}  {'failed at':<9}  " if sim else "") + "closure"]
    for g in points:
        lines.append(f"{g.rank:>3}  {g.d_star:8.5f}  {g.conditioning:8.4f}  {g.epsilon:8.5f}  "
                     + (f"{value(g.squeeze_per_weight, '.3f'):>8}  " if weight else "")
                     + (f"{value(g.margin, '.2f'):>8}  " if margin else "")
                     + (f"{value(g.tolerance, '.3g'):>10}  " if show else "")
                     + (label(g) if sim else "") + g.closure)
    return "\n".join(lines)


def _export(args: argparse.Namespace) -> int:
    from synth.database.export import export_database
    from synth.formats import WRITERS

    if args.format in WRITERS:
        from synth.database.export_objects import export_objects

        paths = export_objects(args.database, args.out, args.format, args.units)
        if not args.quiet:
            print(f"wrote {len(paths)} {args.format} file{'s' * (len(paths) != 1)} in "
                  f"{args.out} from {args.database} "
                  "(poses in metres)")
        return 0
    if args.units is not None:
        from synth.errors import OptionError

        raise OptionError("--units applies to --format acronym, graspgen and isaac (h5, npz "
                          "and json keep each mesh's own unit)")
    fmt = export_database(args.database, args.out, args.format)
    if not args.quiet:
        print(f"wrote {args.out} ({fmt}) from {args.database}")
    return 0


def run_db(args: argparse.Namespace) -> int:
    """Run a parsed ``synth db`` command; returns the exit status.

    0 on success (a build that records failed meshes still succeeds); 130 when interrupted and
    143 when terminated by SIGTERM (what is stored is kept). Errors propagate to
    :func:`synth.cli.main`, which prints them as one ``synth: error: ...`` line and exits 2 for
    bad input, 1 otherwise.
    """
    from synth.database.build import BuildTerminated

    commands = {"build": _build, "info": _info, "top": _top, "export": _export}
    try:
        return commands[args.db_command](args)
    except BuildTerminated:
        print("synth: terminated (SIGTERM); finished meshes are stored, run the same command to "
              "resume", file=sys.stderr)  # fmt: skip
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        print("synth: interrupted; finished meshes are stored, run the same command to resume",
              file=sys.stderr)  # fmt: skip
        return 130
