"""``synth score FILE``: rank candidate contact sets by d*."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from typing import Any

import numpy as np

from synth.errors import CandidateError, InputError

__all__ = ["add_parser", "run", "score_candidates", "ScoredCandidate", "format_table"]


@dataclass(frozen=True)
class ScoredCandidate:
    """One row of ``synth score``'s output."""

    name: str
    contacts: int
    mu: float
    d_star: float
    closure: str
    rank: int
    why_not: str | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "name": self.name,
            "contacts": self.contacts,
            "mu": self.mu,
            "d_star": self.d_star,
            "closure": self.closure,
            "rank": self.rank,
            "why_not": self.why_not,
        }


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth score``."""
    p = sub.add_parser(
        "score",
        help="rank candidate contact sets (JSON or NPZ) by Trinkle's d*",
        description="Score candidate contact sets by Trinkle's form-closure measure d* and "
        "print them ranked. FILE is JSON (a list of {points, normals[, name, mu]}, or an "
        "object with a 'candidates' or 'grasps' list) or NPZ (arrays points, normals of "
        "shape (B, k, 3)). Normals point into the part.",
    )
    p.add_argument("file", help="candidate file (.json or .npz)")
    p.add_argument(
        "--mu",
        type=float,
        default=0.0,
        help="Coulomb friction coefficient for candidates that do not give one (default 0: "
        "frictionless form closure)",
    )
    p.add_argument(
        "--edges", type=int, default=8, help="edges of each linearised friction cone (default 8)"
    )
    p.add_argument("--top", type=int, default=None, help="print only the best N rows")
    p.add_argument(
        "--json",
        nargs="?",
        const="-",
        default=None,
        metavar="PATH",
        help="write the ranked results as JSON to PATH (or to stdout without PATH)",
    )
    p.set_defaults(run=run)


def score_candidates(cands: list[Any], mu: float = 0.0, edges: int = 8) -> list[ScoredCandidate]:
    """Score candidates (see :func:`synth.grasps.read_candidates`) and sort them, best first."""
    from synth.grasps import min_contacts
    from synth.scores import form_closure, form_closure_batch, frictional_form_closure
    from synth.scores.wrench import wrench_matrix

    rows: list[ScoredCandidate | None] = [None] * len(cands)
    batch_groups: dict[tuple[int, int], list[int]] = {}
    for i, c in enumerate(cands):
        m = c.mu if c.mu is not None else mu
        need = min_contacts(c.points.shape[1], m)
        if len(c) < need:
            kind = "with friction" if m > 0 else "without friction (use --mu for friction)"
            space = "in space" if c.points.shape[1] == 3 else "in the plane"
            raise CandidateError(
                f"candidate {i} ({c.name}): {len(c)} contacts, but at least {need} are needed "
                f"{space} {kind}"
            )
        if m == 0:
            batch_groups.setdefault((len(c), c.points.shape[1]), []).append(i)
        else:
            r = frictional_form_closure(c.points, c.normals, m, edges=edges)
            rows[i] = ScoredCandidate(c.name, len(c), m, r.d_star, r.closure, r.rank, r.escape_words)
    for idx in batch_groups.values():
        W = np.stack([wrench_matrix(cands[i].points, cands[i].normals) for i in idx])
        res = form_closure_batch(W)
        for j, i in enumerate(idx):
            closure = "form" if res.closure[j] else "force"
            why = None
            if not res.closure[j]:
                why = form_closure(W[j]).escape_words
            rows[i] = ScoredCandidate(
                cands[i].name, len(cands[i]), 0.0, float(res.d_star[j]), closure,
                int(res.rank[j]), why,
            )
    done = [r for r in rows if r is not None]
    order = sorted(range(len(done)), key=lambda k: (-done[k].d_star, k))
    return [done[k] for k in order]


def format_table(rows: list[ScoredCandidate]) -> str:
    """A plain-text table, one candidate per line, best first."""
    name_w = max([len("name")] + [len(r.name) for r in rows])
    lines = [f"{'#':>4}  {'name':<{name_w}}  {'k':>3}  {'mu':>5}  {'d*':>8}  {'closure':<15}  "
             f"{'rank':>4}  why not"]
    for i, r in enumerate(rows, 1):
        lines.append(
            f"{i:>4}  {r.name:<{name_w}}  {r.contacts:>3}  {r.mu:>5.2f}  {r.d_star:>8.5f}  "
            f"{r.closure:<15}  {r.rank:>4}  {r.why_not or ''}".rstrip()
        )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``synth score``."""
    from synth.grasps import read_candidates

    if args.mu < 0 or not np.isfinite(args.mu):
        raise InputError(f"--mu must be finite and >= 0, got {args.mu}")
    if args.edges < 3:
        raise InputError(f"--edges must be at least 3, got {args.edges}")
    rows = score_candidates(read_candidates(args.file), args.mu, args.edges)
    shown = rows if args.top is None else rows[: max(args.top, 0)]
    if args.json is not None:
        doc = {"file": str(args.file), "candidates": [r.to_dict() for r in shown]}
        text = json.dumps(doc, indent=2)
        if args.json == "-":
            print(text)
            return 0
        with open(args.json, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    print(format_table(shown))
    n_form = sum(r.closure != "force" for r in rows)
    print(f"{len(rows)} candidates, {n_form} with closure", file=sys.stderr)
    return 0
