"""``synth rank MESH CANDIDATES``: score contact sets from elsewhere on a mesh."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from synth.cli.checks import integer, output_path, real
from synth.cli.options import (add_finger_options, add_part_options, add_rank_by,
                               check_finger_options, check_part_options, finger_overrides)
from synth.errors import InputError
from synth.files import write_atomic
from synth.limits import MAX_EDGES, MAX_LENGTH, MAX_MU, MIN_EDGES

__all__ = ["add_parser", "run", "rank_candidates", "order_rows", "RankedCandidate",
           "DEFAULT_TOP"]

#: Rows printed when ``--top`` is not given (as ``synth score``).
DEFAULT_TOP = 20


@dataclass(frozen=True)
class RankedCandidate:
    """One candidate after snapping, normal resolution, finger checks and scoring.

    A candidate with status ``"error"`` (malformed, off the surface, on hidden surface, too
    few contacts) was never scored: its ``d_star`` and ``conditioning`` are NaN and its
    ``closure`` None (null in JSON, ``-`` in the table), never a score of 0.
    """

    name: str
    status: str  # "ok", "tolerance" (below --min-tolerance), "fingers" (collides), "error"
    reason: str | None
    d_star: float = float("nan")
    closure: str | None = None
    conditioning: float = float("nan")
    epsilon: float = float("nan")
    points: np.ndarray | None = field(default=None, repr=False)
    normals: np.ndarray | None = field(default=None, repr=False)
    features: tuple[str, ...] = ()
    fingers: dict[str, Any] | None = field(default=None, repr=False)
    contact_regions: Any = field(default=None, repr=False)
    index: int | None = None  # position in the candidate file
    smooth_normals: np.ndarray | None = field(default=None, repr=False)
    d_star_mesh: float = float("nan")
    d_star_smooth: float = float("nan")
    squeeze_per_weight: float = float("nan")
    least_squeeze: float | None = None
    margin: float | None = None

    @property
    def tolerance(self) -> float:
        """Placement tolerance (NaN when regions were not computed)."""
        r = self.contact_regions
        return float("nan") if r is None else float(r.tolerance)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "index": self.index,
            "name": self.name,
            "status": self.status,
            "reason": self.reason,
            "d_star": None if self.closure is None else self.d_star,
            "closure": self.closure,
            "conditioning": None if self.closure is None else self.conditioning,
            "epsilon": None if self.closure is None else self.epsilon,
            "points": None if self.points is None else self.points.tolist(),
            "normals": None if self.normals is None else self.normals.tolist(),
            "smooth_normals": None if self.smooth_normals is None
            else self.smooth_normals.tolist(),
            "d_star_mesh": None if self.closure is None else self.d_star_mesh,
            "d_star_smooth": None if self.closure is None else self.d_star_smooth,
            "squeeze_per_weight": None if not np.isfinite(self.squeeze_per_weight)
            else self.squeeze_per_weight,
            "least_squeeze": self.least_squeeze,
            "margin": self.margin,
            "features": list(self.features),
            "fingers": self.fingers,
            "tolerance": None if self.contact_regions is None else self.tolerance,
            "contact_regions": None if self.contact_regions is None
            else self.contact_regions.to_dict(),
        }


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth rank``."""
    p = sub.add_parser(
        "rank",
        help="rank candidate grasps from another tool on a mesh",
        description="Snap each candidate's points to the mesh surface, resolve their normals "
        "with the part model (given normals are ignored), check the fingers with FCL, score "
        "by d* and print the candidates ranked. CANDIDATES is JSON (a list of {points[, name]}"
        " or an object with a 'candidates' or 'grasps' list) or NPZ; with --gripper, gripper "
        "poses: ACRONYM .h5, GraspGen .json, isaac_grasp .yaml, an NPZ or JSON of (n, 4, 4) "
        "poses, or a synth gripper grasp file.",
        epilog="exit status: 0 ranked; 1 the --out file could not be written; 2 bad input: "
        "a malformed candidate (reported on its own line, the others still ranked), or no "
        "candidate could be used (the line gives the first one's reason; nothing is "
        "written); 3 internal error (a bug in synth).",
    )
    p.add_argument("mesh", help="mesh file")
    p.add_argument("candidates", help="candidate file (.json or .npz; with --gripper also "
                   ".h5 or .yaml)")
    p.add_argument("--mu", type=float, default=0.0,
                   help=f"friction coefficient, in [0, {MAX_MU:g}] (default 0; 0.5 with --gripper)")
    p.add_argument("--edges", type=int, default=8, metavar="N",
                   help=f"edges of each linearised friction cone, {MIN_EDGES} to {MAX_EDGES} "
                   "(default 8)")
    p.add_argument("--max-distance", type=float, default=None, metavar="D",
                   help="largest distance from a point to the surface that is snapped, in mesh "
                   f"units, in [0, {MAX_LENGTH:g}] (default: 1%% of the part's bounding-box "
                   "diagonal)")
    p.add_argument("--regions", action="store_true",
                   help="compute each closure candidate's contact regions and placement "
                   "tolerance (as synth plan --regions)")
    p.add_argument("--grip", type=float, default=None, metavar="N",
                   help="force limit of each point finger, N: with --mass or --density each "
                   "candidate reports its margin, the grip over the least squeeze that holds "
                   "the part")
    from synth.plan.gripper import GRIPPER_RANK_BY

    add_rank_by(p, "candidates (tolerance computes the regions)", extra=GRIPPER_RANK_BY)
    p.add_argument("--min-tolerance", type=float, default=0.0, metavar="R",
                   help="mark collision-free candidates whose placement tolerance is below R "
                   "(mesh units) as status 'tolerance', ranked after the usable ones "
                   "(default 0)")
    p.add_argument("--top", type=int, default=None, metavar="N",
                   help=f"rows to print, N >= 0 (default {DEFAULT_TOP}; 0 for all; the JSON "
                   "holds every candidate)")
    add_part_options(p)
    add_finger_options(p)
    p.add_argument("--out", default=None, metavar="JSON",
                   help="write the ranked candidates to this file, ending in .json")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--quiet", action="store_true", help="no summary line")
    from synth.cli.rank_gripper import add_rank_gripper_options

    add_rank_gripper_options(p)
    p.set_defaults(run=run, mu=None, rank_by=None)  # their defaults differ with --gripper


def rank_candidates(part, cands, mu: float, fingers, max_distance: float, *,
                    regions: bool = False, rank_by: str = "d_star", min_tolerance: float = 0.0,
                    weight: float | None = None, grip: float | None = None,
                    edges: int = 8, index: list[int] | None = None, surface: str = "both"
                    ) -> list[RankedCandidate]:
    """Snap, resolve, check and score candidates on a part; best first (errors last).

    With ``regions`` (implied by ``rank_by="tolerance"`` and a positive ``min_tolerance``)
    every closure candidate gets its contact regions and placement tolerance
    (:func:`synth.contact_regions`); a collision-free one whose tolerance is below
    ``min_tolerance`` gets status ``"tolerance"`` and ranks after the usable ones. A point is
    snapped to the closest point of the part's surface when it lies within
    ``max_distance`` of it; a point whose snapped place is not on the exposed surface (a
    fingertip could not reach it: against another body of the part, or in a crevice of its
    own) makes its candidate unusable. ``index`` gives each candidate's position in its file,
    for the messages (default: 0, 1, ...). Conditioning and epsilon are those ``synth plan``
    reports (with friction, of the cone-edge wrenches with ``edges`` edges). Each candidate is
    scored under the surface model ``surface`` (:mod:`synth.scores.surface`): its d*, closure,
    conditioning and epsilon are those of its weaker reading of the normals, and its least
    squeeze per weight (:mod:`synth.scores.hold`) the larger of the two; with the part's
    ``weight`` (N) its least squeeze in newtons, and with ``grip`` too its margin.
    """
    from synth.scores.hold import finger_hold_batch
    from synth.fingers import check_fingers, tip_sinks
    from synth.part.resolve import closest_points
    from synth.robust import contact_regions
    from synth.scores import form_closure, frictional_form_closure
    from synth.scores.quality import (conditioning, epsilon_quality, grasp_wrenches,
                                      scaled_wrenches)
    from synth.scores.surface import readings, surface_scores, worst_reading

    rows: list[RankedCandidate] = []
    center, L = part.center_mass, part.length
    several = len(part.bodies) > 1
    for i, c in zip(index if index is not None else range(len(cands)), cands):
        label = f"candidate {i} ({c.name})"
        if c.points.shape[1] != 3:
            rows.append(RankedCandidate(c.name, "error", f"{label}: points must be 3-D",
                                        index=i))
            continue
        closest, _, dist = closest_points(part, c.points)
        far = np.nonzero(dist > max_distance)[0]
        if far.size:
            j = int(far[0])
            rows.append(RankedCandidate(
                c.name, "error",
                f"{label}: point {j} is {dist[j]:.4g} from the surface (more than "
                f"{max_distance:.4g} allowed)", index=i))
            continue
        con = part.resolve(closest, snap=True)
        toward = np.zeros((len(closest), 3))
        np.add.at(toward, con.finger, con.normals)
        hidden = np.flatnonzero(~part.exposed(closest, toward))
        if hidden.size:
            where = ("against or inside another body of the part" if several else
                     "in a crevice of the part narrower than a fingertip's step off the "
                     "surface")
            rows.append(RankedCandidate(
                c.name, "error", f"{label}: point {int(hidden[0])} lies on a hidden part of the "
                f"surface ({where}), where no finger can touch", index=i))
            continue
        P, N, S = con.points, con.normals, con.smooth_normals
        m = c.mu if c.mu is not None else mu
        if m == 0 and len(P) < 7 or m > 0 and len(P) < 3:
            rows.append(RankedCandidate(c.name, "error",
                                        f"{label}: {len(P)} contacts are too few", index=i))
            continue
        both = surface_scores(P[None], N[None], S[None], surface, center, L, m, edges)
        graded = []  # per reading of the normals: (closure?, d*, closure class)
        for n in readings(N, S, surface):
            if m == 0:
                r = form_closure(scaled_wrenches(P, n, center, L))
                graded.append((r.closure == "form", r.d_star, r.closure))
            else:
                fr = frictional_form_closure(P, n, m, center=center, edges=edges)
                graded.append((fr.closure == "frictional form", fr.d_star, fr.closure))
        _, d, closure = min(graded, key=lambda g: (g[0], g[1]))  # the weaker reading
        cond = worst_reading(lambda n: float(conditioning(grasp_wrenches(P, n, center, L, m,
                                                                         edges))), N, S, surface)
        eps = worst_reading(lambda n: float(epsilon_quality(P, n, center, L, m, edges)), N, S,
                            surface)
        ids = np.unique(con.finger, return_inverse=True)[1]
        spw = max(float(finger_hold_batch(P[None], n[None], center, L, m, ids[None], edges)
                        .squeeze_per_weight[0]) for n in readings(N, S, surface))
        least = None if weight is None or not np.isfinite(spw) else spw * weight
        margin = None if least is None or grip is None else grip / least
        chk = check_fingers(part, P[None], N[None], fingers, ids[None])
        fing = None
        if chk.mask[0]:
            where = chk.placement(0)
            fing = where.to_dict()
            fing["tip_sink"] = float(tip_sinks(part, where.tip_centers, where.tip_radius).max())
        holds = closure in ("form", "frictional form")
        robust = contact_regions(part, P, N, mu=m, edges=edges, d_star=d, smooth=S,
                                 surface=surface) if holds and (
            regions or rank_by == "tolerance" or min_tolerance > 0) else None
        status, reason = ("ok", None) if chk.mask[0] else ("fingers", chk.reasons[0])
        if status == "ok" and robust is not None and robust.tolerance < min_tolerance:
            status, reason = "tolerance", (f"placement tolerance {robust.tolerance:.4g} is "
                                           f"below --min-tolerance {min_tolerance:g}")
        rows.append(RankedCandidate(c.name, status, reason, d, closure, cond, eps, P, N,
                                    tuple(con.features), fing, robust, i, S,
                                    float(both.d_mesh[0]), float(both.d_smooth[0]), spw, least,
                                    margin))
    return order_rows(rows, rank_by)


def order_rows(rows: list[RankedCandidate], rank_by: str = "d_star") -> list[RankedCandidate]:
    """Usable first, then those below --min-tolerance, those the fingers cannot make, then
    the unusable ones (in file order); each group in the order of ``synth plan``
    (:func:`synth.plan.ranking.rank_grasps`)."""
    from synth.plan.ranking import rank_grasps

    return [r for status in ("ok", "tolerance", "fingers") for r in
            rank_grasps([r for r in rows if r.status == status], rank_by)] + sorted(
        (r for r in rows if r.status == "error"), key=lambda r: -1 if r.index is None else r.index)


def _cell(value: float, spec: str, width: int) -> str:
    """A number of the table, or ``-`` when it was not computed (NaN)."""
    return f"{'-':>{width}}" if np.isnan(value) else f"{value:>{width}{spec}}"


def run(args: argparse.Namespace) -> int:
    """Run ``synth rank``: exit status 2 when a candidate was malformed (the others are
    ranked and written) or when none could be used."""
    from synth.fingers import default_fingers
    from synth.grasps import read_candidate_table
    from synth.cli.plan import load_part_from_args, report_part

    if args.gripper is not None:
        from synth.cli.rank_gripper import run_rank_gripper

        return run_rank_gripper(args)
    from synth.cli.rank_gripper import refuse_rank_gripper_options

    refuse_rank_gripper_options(args)
    args.mu = 0.0 if args.mu is None else args.mu
    args.rank_by = args.rank_by or "d_star"
    real("--mu", args.mu, 0, MAX_MU)
    integer("--edges", args.edges, MIN_EDGES, MAX_EDGES)
    real("--max-distance", args.max_distance, 0, MAX_LENGTH, unit=" (mesh units)")
    real("--min-tolerance", args.min_tolerance, 0, MAX_LENGTH, unit=" (mesh units)")
    integer("--top", args.top, 0)
    real("--grip", args.grip, 0, MAX_LENGTH, open_lo=True, unit=" N")
    check_part_options(args)
    check_finger_options(args)
    out = None if args.out is None else output_path("--out", args.out, ".json")
    table = read_candidate_table(args.candidates, require_normals=False)
    if not table.groups:  # every candidate malformed: say so before loading the mesh
        more = f" (and {len(table.errors) - 1} more malformed)" if len(table.errors) > 1 else ""
        raise InputError(f"no candidate could be used: {table.errors[0][1]}{more}")
    part = load_part_from_args(args)
    report_part(part, args.quiet or args.json)
    fingers = default_fingers(part, **finger_overrides(args))
    max_d = args.max_distance if args.max_distance is not None else 0.01 * part.length
    from synth.plan import PlanParams
    from synth.plan.search import part_weight

    weight = part_weight(part, PlanParams(mass=args.mass, density=args.density))
    index = sorted(i for g in table.groups for i in g.index.tolist())
    rows = rank_candidates(part, table.candidates(), args.mu, fingers, max_d,
                           regions=args.regions, rank_by=args.rank_by,
                           min_tolerance=args.min_tolerance, edges=args.edges, index=index,
                           surface=args.surface, weight=weight, grip=args.grip)
    rows = order_rows(rows + [RankedCandidate(table.names[i], "error", message, index=i)
                              for i, message in table.errors], args.rank_by)
    unusable = [r for r in rows if r.status == "error"]
    if len(unusable) == len(rows):
        more = f" (and {len(rows) - 1} more unusable)" if len(rows) > 1 else ""
        raise InputError(f"{args.candidates}: no candidate could be used: "
                         f"{unusable[0].reason}{more}")
    from synth.paths import stored_mesh_path

    doc = {"format": "synth.ranked", "version": 1, "mesh": {
           "path": stored_mesh_path(part.source, out),
           "sha256": part.sha256, "units": part.units, "length": part.length},
           "mu": args.mu, "edges": args.edges, "surface": args.surface,
           "fingers": fingers.to_dict(),
           "candidates": [r.to_dict() for r in rows]}
    text = json.dumps(doc, indent=1) + "\n"
    if out is not None:
        write_atomic(out, text)
    top = DEFAULT_TOP if args.top is None else args.top
    shown = rows if top == 0 else rows[:top]
    if args.json:
        print(text, end="")
    else:
        w = max([4] + [len(r.name) for r in shown])
        show = args.regions or args.rank_by == "tolerance" or args.min_tolerance > 0
        margin = any(r.margin is not None for r in shown)
        print(f"{'#':>3}  {'name':<{w}}  {'d*':>8}  {'closure':<15}  {'cond':>7}  "
              f"{'epsilon':>8}  {'N/weight':>8}  " + (f"{'margin':>7}  " if margin else "")
              + (f"{'tolerance':>10}  " if show else "") + "status")
        for i, r in enumerate(shown, 1):
            status = r.status if r.reason is None else f"{r.status}: {r.reason}"
            reg = r.contact_regions
            tol = "-" if reg is None else f"{reg.tolerance:.3g}" + ("" if reg.certified else "~")
            print(f"{i:>3}  {r.name:<{w}}  {_cell(r.d_star, '.5f', 8)}  "
                  f"{r.closure or '-':<15}  {_cell(r.conditioning, '.4f', 7)}  "
                  f"{_cell(r.epsilon, '.5f', 8)}  {_cell(r.squeeze_per_weight, '.3f', 8)}  "
                  + (f"{_cell(np.nan if r.margin is None else r.margin, '.2f', 7)}  "
                     if margin else "") + (f"{tol:>10}  " if show else "") + status)
    for _, message in table.errors:
        print(f"synth: error: {message}", file=sys.stderr)
    if not args.quiet:
        n_ok = sum(r.status == "ok" for r in rows)
        n_low = sum(r.status == "tolerance" for r in rows)
        low = f" ({n_low} more below --min-tolerance)" if n_low else ""
        more = (f"; showing the best {len(shown)} (--top 0 for all)"
                if len(shown) < len(rows) and not args.json else "")
        print(f"{len(rows)} candidates: {n_ok} collision free{low}, "
              f"{len(unusable)} unusable{more}", file=sys.stderr)
    return 2 if table.errors else 0
