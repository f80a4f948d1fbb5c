"""Contact sets from elsewhere, ranked on a part (``synth rank MESH CANDIDATES``): each
candidate's points snapped to the surface, its normals resolved by the part model, its fingers
checked and its grasp scored as ``synth plan`` scores its own.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

__all__ = ["STATUSES", "SCORED", "RankedCandidate", "rank_candidates", "order_rows"]

#: Every status a contact set can get: the words of ``synth rank --gripper``'s poses
#: (:data:`synth.plan.gripper_rank.POSE_STATUSES`), and ``tolerance`` (usable, but its placement
#: tolerance is below ``--min-tolerance``).
STATUSES: tuple[str, ...] = ("ok", "tolerance", "collision", "misses the part", "no contact",
                             "malformed")
#: The statuses of candidates that were scored; they are ranked in this order of groups, the
#: others follow in file order.
SCORED: tuple[str, ...] = ("ok", "tolerance", "collision")


@dataclass(frozen=True)
class RankedCandidate:
    """One candidate after snapping, normal resolution, finger checks and scoring.

    A candidate whose status is not one of :data:`SCORED` (``misses the part``: a point off
    the surface; ``no contact``: a point on hidden surface; ``malformed``: unreadable, not
    3-D, too few contacts) was never scored: its ``d_star`` and ``conditioning`` are NaN and
    its ``closure`` None (null in JSON, ``-`` in the table), never a score of 0.
    """

    name: str
    status: str  # one of STATUSES
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


def _shared_tips(ids: np.ndarray, P: np.ndarray, N: np.ndarray, radius: float, tol: float
                 ) -> np.ndarray:
    """Fingers of the contacts (k,): those of ``ids`` (the resolver's: one per given point),
    joined where the tips would be one (their centres one radius off the surface, against
    the normals, within ``tol``), as in a groove or an inside corner of a plan made with
    ``--fingers``: one fingertip touching two or three faces."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    tips = P - radius * N
    pairs = cKDTree(tips).query_pairs(max(tol, 0.0), output_type="ndarray")
    if not len(pairs):
        return ids
    n = int(ids.max()) + 1
    a = np.concatenate([ids[pairs[:, 0]], np.arange(n)])
    b = np.concatenate([ids[pairs[:, 1]], np.arange(n)])
    joined = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)),
                                  directed=False)[1]
    return np.unique(joined[ids], return_inverse=True)[1]


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
    from synth.fingers import check_fingers, tip_sinks
    from synth.part.resolve import closest_points
    from synth.plan.picture import unit_symbol
    from synth.robust import contact_regions
    from synth.scores import form_closure, frictional_form_closure
    from synth.scores.hold import finger_hold_batch
    from synth.scores.quality import conditioning, epsilon_quality, grasp_wrenches, scaled_wrenches
    from synth.scores.surface import readings, surface_scores, worst_reading

    rows: list[RankedCandidate] = []
    center, L = part.center_mass, part.length
    several = len(part.bodies) > 1
    unit = unit_symbol(part.units) if part.units else "mesh units"

    def conditioning_of(P: np.ndarray, mu: float, n: np.ndarray) -> float:
        return float(conditioning(grasp_wrenches(P, n, center, L, mu, edges)))

    def epsilon_of(P: np.ndarray, mu: float, n: np.ndarray) -> float:
        return float(epsilon_quality(P, n, center, L, mu, edges))

    for i, c in zip(index if index is not None else range(len(cands)), cands, strict=True):
        label = f"candidate {i} ({c.name})"
        if c.points.shape[1] != 3:
            rows.append(RankedCandidate(c.name, "malformed", f"{label}: points must be 3-D",
                                        index=i))
            continue
        closest, _, dist = closest_points(part, c.points)
        far = np.nonzero(dist > max_distance)[0]
        if far.size:
            j = int(far[0])
            rows.append(RankedCandidate(
                c.name, "misses the part",
                f"{label}: point {j} is {dist[j]:.4g} {unit} from the surface (more than "
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
                c.name, "no contact",
                f"{label}: point {int(hidden[0])} lies on a hidden part of the "
                f"surface ({where}), where no finger can touch", index=i))
            continue
        P, N, S = con.points, con.normals, con.smooth_normals
        m = c.mu if c.mu is not None else mu
        if m == 0 and len(P) < 7 or m > 0 and len(P) < 3:
            rows.append(RankedCandidate(c.name, "malformed",
                                        f"{label}: {len(P)} contacts are too few: closure "
                                        "takes at least 7 without friction, 3 with it (--mu)",
                                        index=i))
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
        cond = worst_reading(partial(conditioning_of, P, m), N, S, surface)
        eps = worst_reading(partial(epsilon_of, P, m), N, S, surface)
        ids = _shared_tips(np.unique(con.finger, return_inverse=True)[1], P, N,
                           fingers.tip_radius, part.surface_tolerance)
        spw = max(float(finger_hold_batch(P[None], n[None], center, L, m, ids[None], edges)
                        .squeeze_per_weight[0]) for n in readings(N, S, surface))
        least = None if weight is None or not np.isfinite(spw) else spw * weight
        margin = None if least is None or grip is None else grip / least
        chk = check_fingers(part, P[None], N[None], fingers, ids[None])
        fing = None
        if chk.mask[0]:
            placement = chk.placement(0)
            fing = placement.to_dict()
            fing["tip_sink"] = float(tip_sinks(part, placement.tip_centers, placement.tip_radius)
                                     .max())
        holds = closure in ("form", "frictional form")
        robust = contact_regions(part, P, N, mu=m, edges=edges, d_star=d, smooth=S,
                                 surface=surface) if holds and (
            regions or rank_by == "tolerance" or min_tolerance > 0) else None
        status, reason = ("ok", None) if chk.mask[0] else ("collision", chk.reasons[0])
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

    return [r for status in SCORED for r in
            rank_grasps([r for r in rows if r.status == status], rank_by)] + sorted(
        (r for r in rows if r.status not in SCORED),
        key=lambda r: -1 if r.index is None else r.index)
