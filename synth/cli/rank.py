"""``synth rank MESH CANDIDATES``: score contact sets from elsewhere on a mesh."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from synth.cli.checks import check_finger_options, check_part_options, output_path, real
from synth.errors import InputError
from synth.files import write_atomic
from synth.limits import MAX_LENGTH, MAX_MU

__all__ = ["add_parser", "run", "rank_candidates", "RankedCandidate"]


@dataclass(frozen=True)
class RankedCandidate:
    """One candidate after snapping, normal resolution, finger checks and scoring."""

    name: str
    status: str  # "ok", "tolerance" (below --min-tolerance), "fingers" (collides), "error"
    reason: str | None
    d_star: float = 0.0
    closure: str = "force"
    conditioning: float = 0.0
    points: np.ndarray | None = field(default=None, repr=False)
    normals: np.ndarray | None = field(default=None, repr=False)
    features: tuple[str, ...] = ()
    fingers: dict[str, Any] | None = field(default=None, repr=False)
    contact_regions: Any = field(default=None, repr=False)
    smooth_normals: np.ndarray | None = field(default=None, repr=False)
    d_star_mesh: float | None = None
    d_star_smooth: float | None = None

    @property
    def tolerance(self) -> float:
        """Placement tolerance (NaN when regions were not computed)."""
        r = self.contact_regions
        return float("nan") if r is None else float(r.tolerance)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary."""
        return {
            "name": self.name,
            "status": self.status,
            "reason": self.reason,
            "d_star": self.d_star,
            "closure": self.closure,
            "conditioning": self.conditioning,
            "points": None if self.points is None else self.points.tolist(),
            "normals": None if self.normals is None else self.normals.tolist(),
            "smooth_normals": None if self.smooth_normals is None
            else self.smooth_normals.tolist(),
            "d_star_mesh": self.d_star_mesh,
            "d_star_smooth": self.d_star_smooth,
            "features": list(self.features),
            "fingers": self.fingers,
            "tolerance": None if self.contact_regions is None else self.tolerance,
            "contact_regions": None if self.contact_regions is None
            else self.contact_regions.to_dict(),
        }


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``synth rank``."""
    from synth.cli.plan import add_finger_options, add_part_options

    p = sub.add_parser(
        "rank",
        help="rank candidate grasps from another tool on a mesh",
        description="Snap each candidate's points to the mesh surface, resolve their normals "
        "with the part model (given normals are ignored), check the fingers with FCL, score "
        "by d* and print the candidates ranked. CANDIDATES is JSON (a list of {points[, name]}"
        " or an object with a 'candidates' or 'grasps' list) or NPZ.",
        epilog="exit status: 0 ranked; 1 the --out file could not be written; 2 bad input, "
        "or no candidate could be used (the line gives the first one's reason; nothing is "
        "written); 3 internal error (a bug in synth).",
    )
    p.add_argument("mesh", help="mesh file")
    p.add_argument("candidates", help="candidate file (.json or .npz)")
    p.add_argument("--mu", type=float, default=0.0,
                   help=f"friction coefficient, in [0, {MAX_MU:g}] (default 0)")
    p.add_argument("--max-distance", type=float, default=None, metavar="D",
                   help="largest distance from a point to the surface that is snapped, in mesh "
                   f"units, in [0, {MAX_LENGTH:g}] (default: 1%% of the part's bounding-box "
                   "diagonal)")
    p.add_argument("--regions", action="store_true",
                   help="compute each closure candidate's contact regions and placement "
                   "tolerance (as synth plan --regions)")
    p.add_argument("--rank-by", choices=("d_star", "tolerance"), default="d_star",
                   help="order of the candidates (default d_star; tolerance computes the "
                   "regions)")
    p.add_argument("--min-tolerance", type=float, default=0.0, metavar="R",
                   help="mark collision-free candidates whose placement tolerance is below R "
                   "(mesh units) as status 'tolerance', ranked after the usable ones "
                   "(default 0)")
    add_part_options(p)
    add_finger_options(p)
    p.add_argument("--out", default=None, metavar="JSON",
                   help="write the ranked candidates to this file, ending in .json")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--quiet", action="store_true", help="no summary line")
    p.set_defaults(run=run)


def rank_candidates(part, cands, mu: float, fingers, max_distance: float, *,
                    regions: bool = False, rank_by: str = "d_star", min_tolerance: float = 0.0,
                    surface: str = "both") -> list[RankedCandidate]:
    """Snap, resolve, check and score candidates on a part; best first (errors last).

    With ``regions`` (implied by ``rank_by="tolerance"`` and a positive ``min_tolerance``)
    every closure candidate gets its contact regions and placement tolerance
    (:func:`synth.contact_regions`); a collision-free one whose tolerance is below
    ``min_tolerance`` gets status ``"tolerance"`` and ranks after the usable ones. A point is
    snapped to the closest point of the part's surface when it lies within
    ``max_distance`` of it; a point whose snapped place is not on the exposed surface (it
    lies against or inside another body of the part) makes its candidate unusable. Each
    candidate is scored under the surface model ``surface`` (:mod:`synth.scores.surface`):
    d*, closure and conditioning are those of its weaker reading of the normals.
    """
    from synth.fingers import check_fingers, tip_sinks
    from synth.part.resolve import closest_points
    from synth.robust import contact_regions
    from synth.scores import form_closure, frictional_form_closure
    from synth.scores.quality import conditioning, scaled_wrenches
    from synth.scores.surface import readings, surface_scores

    rows: list[RankedCandidate] = []
    center, L = part.center_mass, part.length
    for i, c in enumerate(cands):
        label = f"candidate {i} ({c.name})"
        if c.points.shape[1] != 3:
            rows.append(RankedCandidate(c.name, "error", f"{label}: points must be 3-D"))
            continue
        closest, _, dist = closest_points(part, c.points)
        far = np.nonzero(dist > max_distance)[0]
        if far.size:
            j = int(far[0])
            rows.append(RankedCandidate(
                c.name, "error",
                f"{label}: point {j} is {dist[j]:.4g} from the surface (more than "
                f"{max_distance:.4g} allowed)"))
            continue
        con = part.resolve(closest, snap=True)
        toward = np.zeros((len(closest), 3))
        np.add.at(toward, con.finger, con.normals)
        hidden = np.flatnonzero(~part.exposed(closest, toward))
        if hidden.size:
            rows.append(RankedCandidate(
                c.name, "error", f"{label}: point {int(hidden[0])} lies on a hidden part of the "
                "surface (against or inside another body of the part), where no finger can "
                "touch"))
            continue
        P, N, S = con.points, con.normals, con.smooth_normals
        m = c.mu if c.mu is not None else mu
        if m == 0 and len(P) < 7 or m > 0 and len(P) < 3:
            rows.append(RankedCandidate(c.name, "error",
                                        f"{label}: {len(P)} contacts are too few"))
            continue
        both = surface_scores(P[None], N[None], S[None], surface, center, L, m)
        graded = []  # per reading: (closure?, d*, closure class, conditioning)
        for n in readings(N, S, surface):
            if m == 0:
                W = scaled_wrenches(P, n, center, L)
                r = form_closure(W)
                graded.append((r.closure == "form", r.d_star, r.closure, float(conditioning(W))))
            else:
                fr = frictional_form_closure(P, n, m, center=center)
                graded.append((fr.closure == "frictional form", fr.d_star, fr.closure, 0.0))
        _, d, closure, _ = min(graded, key=lambda g: (g[0], g[1]))  # the weaker reading
        cond = min(g[3] for g in graded)
        ids = np.unique(con.finger, return_inverse=True)[1]
        chk = check_fingers(part, P[None], N[None], fingers, ids[None])
        fing = None
        if chk.mask[0]:
            where = chk.placement(0)
            fing = where.to_dict()
            fing["tip_sink"] = float(tip_sinks(part, where.tip_centers, where.tip_radius).max())
        holds = closure in ("form", "frictional form")
        robust = contact_regions(part, P, N, mu=m, d_star=d, smooth=S, surface=surface) if (
            holds and (regions or rank_by == "tolerance" or min_tolerance > 0)) else None
        status, reason = ("ok", None) if chk.mask[0] else ("fingers", chk.reasons[0])
        if status == "ok" and robust is not None and robust.tolerance < min_tolerance:
            status, reason = "tolerance", (f"placement tolerance {robust.tolerance:.4g} is "
                                           f"below --min-tolerance {min_tolerance:g}")
        rows.append(RankedCandidate(c.name, status, reason, d, closure, cond, P, N,
                                    tuple(con.features), fing, robust, S,
                                    float(both.d_mesh[0]), float(both.d_smooth[0])))
    from synth.plan.search import rank_grasps

    # usable first, then those below --min-tolerance, those the fingers cannot make, then
    # errors; each best first (d* equal within the LPs' accuracy ordered by conditioning, as
    # synth plan does)
    return [r for status in ("ok", "tolerance", "fingers", "error")
            for r in rank_grasps([r for r in rows if r.status == status],  # type: ignore[arg-type]
                                 rank_by)]


def run(args: argparse.Namespace) -> int:
    """Run ``synth rank``."""
    from synth.cli.plan import load_part_from_args, report_part
    from synth.fingers import default_fingers
    from synth.grasps import read_candidates

    real("--mu", args.mu, 0, MAX_MU)
    real("--max-distance", args.max_distance, 0, MAX_LENGTH, unit=" (mesh units)")
    real("--min-tolerance", args.min_tolerance, 0, MAX_LENGTH, unit=" (mesh units)")
    check_part_options(args)
    check_finger_options(args)
    out = None if args.out is None else output_path("--out", args.out, ".json")
    cands = read_candidates(args.candidates, require_normals=False)
    part = load_part_from_args(args)
    report_part(part, args.quiet or args.json)
    over = {k: v for k, v in (("tip_radius", args.finger_radius),
                              ("body_length", args.body_length),
                              ("body_radius", args.body_radius)) if v is not None}
    if args.approach_cone:
        over["approach_cone"] = float(np.radians(args.approach_cone))
    fingers = default_fingers(part, **over)
    max_d = args.max_distance if args.max_distance is not None else 0.01 * part.length
    rows = rank_candidates(part, cands, args.mu, fingers, max_d, regions=args.regions,
                           rank_by=args.rank_by, min_tolerance=args.min_tolerance,
                           surface=args.surface)
    unusable = [r for r in rows if r.status == "error"]
    if len(unusable) == len(rows):
        more = f" (and {len(rows) - 1} more unusable)" if len(rows) > 1 else ""
        raise InputError(f"{args.candidates}: no candidate could be used: "
                         f"{unusable[0].reason}{more}")
    doc = {"format": "synth.ranked", "version": 1, "mesh": {"path": part.source,
           "sha256": part.sha256, "units": part.units, "length": part.length},
           "mu": args.mu, "surface": args.surface, "fingers": fingers.to_dict(),
           "candidates": [r.to_dict() for r in rows]}
    text = json.dumps(doc, indent=1) + "\n"
    if out is not None:
        write_atomic(out, text)
    if args.json:
        print(text, end="")
    else:
        w = max([4] + [len(r.name) for r in rows])
        show = args.regions or args.rank_by == "tolerance" or args.min_tolerance > 0
        print(f"{'#':>3}  {'name':<{w}}  {'d*':>8}  {'closure':<15}  {'cond':>7}  "
              + (f"{'tolerance':>10}  " if show else "") + "status")
        for i, r in enumerate(rows, 1):
            status = r.status if r.reason is None else f"{r.status}: {r.reason}"
            reg = r.contact_regions
            tol = "-" if reg is None else f"{reg.tolerance:.3g}" + ("" if reg.certified else "~")
            print(f"{i:>3}  {r.name:<{w}}  {r.d_star:>8.5f}  {r.closure:<15}  "
                  f"{r.conditioning:>7.4f}  " + (f"{tol:>10}  " if show else "") + status)
    if not args.quiet:
        n_ok = sum(r.status == "ok" for r in rows)
        n_low = sum(r.status == "tolerance" for r in rows)
        low = f" ({n_low} more below --min-tolerance)" if n_low else ""
        print(f"{len(rows)} candidates: {n_ok} collision free{low}, "
              f"{len(unusable)} unusable", file=sys.stderr)
    return 0
