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
from synth.errors import InputError, OptionError, shown
from synth.files import write_atomic
from synth.limits import MAX_EDGES, MAX_LENGTH, MAX_MU, MIN_EDGES

__all__ = ["add_parser", "run"]

#: Rows printed (and explained) when ``--top`` is not given.
DEFAULT_TOP = 20


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth score``."""
    p = sub.add_parser(
        "score",
        help="rank candidate contact sets (JSON or NPZ) by Trinkle's d*",
        description="Score candidate contact sets by Trinkle's form-closure measure d* and "
        "print them ranked. FILE is JSON (a list of {points, normals[, name, mu]}, or an "
        "object with a 'candidates' or 'grasps' list) or NPZ (arrays points, normals of "
        "shape (B, k, 3), optional names (B,) and mu). Normals point into the part.",
        epilog="A malformed candidate is reported on its own line and the others are still "
        "scored; the exit status is then 2. When no candidate can be scored, one line says "
        "why and nothing is written. Ranking: closure grasps first, then by d*.",
    )
    p.add_argument("file", help="candidate file (.json or .npz)")
    p.add_argument(
        "--mu",
        type=float,
        default=0.0,
        help=f"Coulomb friction coefficient for candidates that do not give one, in [0, "
        f"{MAX_MU:g}] (default 0: frictionless form closure)",
    )
    p.add_argument(
        "--torsion", type=float, default=0.0, metavar="GAMMA",
        help=f"torsional friction of soft contacts, a length in the candidates' unit, in [0, "
        f"{MAX_LENGTH:g}] (default 0: point contacts); each contact then also resists a "
        "moment about its normal, MuJoCo's condim-4 cone (linearised), and two contacts can "
        "close",
    )
    p.add_argument(
        "--edges", type=int, default=8,
        help=f"edges of each linearised friction cone, {MIN_EDGES} to {MAX_EDGES} (default 8)",
    )
    p.add_argument("--top", type=int, default=None, metavar="N",
                   help=f"rows to print and explain, N >= 0 (default {DEFAULT_TOP}; 0 for all)")
    p.add_argument("--out", default=None, metavar="JSON",
                   help="write every candidate's score as JSON to this file, ending in .json "
                   "(as plan --out and rank --out); the table is printed too")
    p.add_argument("--json", nargs="?", const=True, default=False, metavar="",
                   help="print every candidate's score as JSON instead of the table (as plan "
                   "--json and rank --json); --out writes it to a file")
    p.set_defaults(run=run)


def _json_or_null(value: Any) -> str:
    """``json.dumps(value)``, without its call for the ``None`` of every row not shown."""
    return "null" if value is None else json.dumps(value)


def run(args: argparse.Namespace) -> int:
    """Run ``synth score``."""
    import numpy as np

    from synth.cli.score_table import explain, format_table, score_table
    from synth.grasps import read_candidate_table

    real("--mu", args.mu, 0, MAX_MU)
    real("--torsion", args.torsion, 0, MAX_LENGTH)
    integer("--edges", args.edges, MIN_EDGES, MAX_EDGES)
    integer("--top", args.top, 0)
    if args.json is not True and args.json is not False:  # the old form, --json PATH
        raise OptionError(f"--json takes no file name: it prints the JSON, as plan --json and "
                          f"rank --json do; write it to a file with --out {shown(args.json, 60)}")
    if args.out is not None:
        output_path("--out", args.out, ".json")
    table = read_candidate_table(args.file)
    scores = score_table(table, args.mu, args.edges, args.torsion)
    order = scores.order()
    if not len(order):
        more = f" (and {len(scores.errors) - 1} more malformed)" if len(scores.errors) > 1 else ""
        raise InputError(f"no candidate could be scored: {scores.errors[0][1]}{more}")
    top = DEFAULT_TOP if args.top is None else args.top
    rows_shown = order if top == 0 else order[:top]
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
    n_closure = int((scores.closure[order] != "force").sum())
    more = (f"; showing the best {len(rows_shown)} (--top 0 for all)"
            if len(rows_shown) < len(order) and not args.json else "")
    print(f"{len(order)} candidates scored, {n_closure} with closure"
          f"{f', {len(scores.errors)} malformed' if scores.errors else ''}{more}",
          file=sys.stderr)
    return 2 if scores.errors else 0
