"""``synth score FILE``: rank candidate contact sets by d*.

Every valid candidate is scored in vectorised batches (one per shape and friction
coefficient); a malformed one is reported by position, name and field and the others are still
scored (exit status 2 at the end). The motion a failing grasp leaves free, and the contacts it
can still squeeze, are worked out only for the rows shown (``--top``).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from synth.cli.checks import integer, output_path, real
from synth.cli.options import add_friction_options
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

__all__ = ["add_parser", "run"]



def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth score``."""
    p = sub.add_parser(
        "score",
        help="rank candidate contact sets (JSON or NPZ) by Trinkle's d*",
        description="Score candidate contact sets by Trinkle's form-closure measure d* and "
        "print them ranked. CANDIDATES is JSON (a list of {points, normals[, name, mu]}, or an "
        "object with a 'candidates' or 'grasps' list) or NPZ (arrays points, normals of "
        "shape (B, k, 3), optional names (B,) and mu). Normals point into the part.",
        epilog="Ranking: closure grasps first, then by d*. " + exit_epilog(
            "every candidate scored", None, "a malformed candidate, reported on its own line "
            "while the others are still scored; or no candidate could be scored, the line "
            "saying why, and nothing is written"),
    )
    p.add_argument("file", metavar="CANDIDATES", help="candidate file (.json or .npz)")
    add_friction_options(p, "0: frictionless form closure", " of the candidates that give "
                         "none")
    p.add_argument(
        "--torsion", type=float, default=0.0, metavar="GAMMA",
        help=f"torsional friction of soft contacts, a length in the candidates' unit, in [0, "
        f"{MAX_LENGTH:g}] (default 0: point contacts); each contact then also resists a "
        "moment about its normal, MuJoCo's condim-4 cone (linearised), and two contacts can "
        "close",
    )
    add_top(p, "candidates", DEFAULT_ROWS, listing=True, note="each failing one is printed "
            "with the motion it leaves free; --out and --json hold every one")
    o = p.add_argument_group("output")
    add_out(o, "every candidate's score")
    add_json(o, "every candidate's score")
    add_quiet(o, "score")
    p.set_defaults(run=run)


def _json_or_null(value: Any) -> str:
    """``json.dumps(value)``, without its call for the ``None`` of every row not shown."""
    return "null" if value is None else json.dumps(value)


def run(args: argparse.Namespace) -> int:
    """Run ``synth score``."""
    import numpy as np

    from synth.cli.score_table import explain, format_table, score_table
    from synth.grasps import read_candidate_table

    args.mu = 0.0 if args.mu is None else args.mu
    real("--mu", args.mu, 0, MAX_MU)
    real("--torsion", args.torsion, 0, MAX_LENGTH)
    integer("--edges", args.edges, MIN_EDGES, MAX_EDGES)
    check_top(args.top, listing=True)
    if args.out is not None:
        output_path("--out", args.out, ".json", [args.file])
    table = read_candidate_table(args.file)
    scores = score_table(table, args.mu, args.edges, args.torsion)
    order = scores.order()
    if not len(order):
        more = f" (and {len(scores.errors) - 1} more malformed)" if len(scores.errors) > 1 else ""
        raise InputError(f"no candidate could be scored: {scores.errors[0][1]}{more}")
    rows_shown = order if args.top == 0 else order[:args.top]
    why = explain(table, scores, rows_shown, args.edges, args.torsion)
    if args.json or args.out is not None:
        rank_of = np.zeros(len(scores.names), np.int64)
        rank_of[order] = np.arange(1, len(order) + 1)
        def row(i: int) -> str:  # one JSON object, without json.dumps' per-call overhead
            words, squeeze = why.get(i, (None, None))
            return (f'{{"rank": {rank_of[i]}, "index": {i}, "name": {json.dumps(scores.names[i])}, '
                    f'"contacts": {scores.contacts[i]}, "mu": {float(scores.mu[i])!r}, '
                    f'"d_star": {float(scores.d_star[i])!r}, "closure": "{scores.closure[i]}", '
                    f'"matrix_rank": {scores.rank[i]}, "why_not": {_json_or_null(words)}, '
                    f'"squeezable": {_json_or_null(squeeze)}}}')

        rows = [row(i) for i in order.tolist()]
        errs = [{"index": i, "name": scores.names[i], "error": e} for i, e in scores.errors]
        # one candidate per line: readable, and json's fast C encoder (indent= is pure Python)
        text = ('{"format": "synth.scores", "version": 1, "file": ' + json.dumps(str(args.file))
                + ',\n "candidates": [\n' + ",\n".join(rows)
                + '],\n "errors": [\n' + ",\n".join(map(json.dumps, errs)) + "]}")
        if args.out is not None:
            write_atomic(args.out, text + "\n")
        if args.json:
            print(text)
    if not args.json:
        print(format_table(scores, rows_shown, why))
    for _, message in scores.errors:
        print(f"synth: error: {message}", file=sys.stderr)
    if args.out is not None and not args.quiet:
        print(f"wrote {args.out}")
    if not args.quiet:
        n_closure = int((scores.closure[order] != "force").sum())
        more = (f"; showing the best {len(rows_shown)} (--top 0 for all)"
                if len(rows_shown) < len(order) else "")
        print(f"{len(order)} candidate{'s' * (len(order) != 1)} scored, {n_closure} with "
              "closure"
              f"{f', {len(scores.errors)} malformed' if scores.errors else ''}{more}",
              file=sys.stderr)
    return 2 if scores.errors else 0
