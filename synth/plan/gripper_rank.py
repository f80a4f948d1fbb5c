"""Ranking gripper poses from elsewhere: the gripper planner's steps 3 to 5 on given poses.

For every pose (already in the part's frame and unit, :mod:`synth.formats`):

1. **one jaw grasp per pair**: a pose and its half-turn about the approach axis are the same
   jaw grasp, so both are replaced by one representative
   (:func:`synth.formats.poses.canonical_half_turn`) and identical representatives are
   processed once; the results are turned back to the pose as given (its +x pad's contact
   first, its pose moved along its own x);
2. **jaws** (:func:`synth.fingers.jaws.close_jaws`): close from the open width until both pads
   touch;
3. **collisions** (:class:`synth.fingers.gripper_collide.GripperChecker`): approach and closed
   fingers against every body of the part and the table;
4. **scores**: closure, the least squeeze against gravity (the fine bound), mu_min and epsilon,
   as the planner scores the grasps it returns (:func:`synth.plan.gripper.grasp_results`),
   through numba's simplex kernel when it is installed and the batch repays loading it
   (:func:`synth.scores.simplex.compiled_for`; the same optima as numpy's to about 1e-12).

Each candidate gets one status: ``ok`` (scored; closure or not), ``collision``,
``no contact`` (the part lies between the jaws but they make no trustworthy two-pad contact:
wider than the opening, or a pad touching with its rim where it cannot rest: in two places,
buried in a slope, or on an edge or vertex at no single normal), ``misses the part`` (a pad's
prism meets no part of the mesh) or ``malformed``. The ``ok`` ones are ordered as the planner
orders its grasps (``rank_by``), grasps without closure last.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.fingers.gripper import Gripper, half_turn, load_gripper
from synth.fingers.gripper_collide import CLEAR, GRIPPER_STATUS, GripperChecker
from synth.fingers.jaws import JAW_STATUS, LANDED, MISSES, close_jaws
from synth.formats.poses import canonical_half_turn
from synth.plan.gripper import (
    PREGRASP_M,
    TORSION_M,
    GripperGrasp,
    GripperParams,
    grasp_results,
    part_mass,
    rank_order,
)
from synth.plan.gripper_refine import Scored
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.gravity import gravity_hold_batch

__all__ = ["POSE_STATUSES", "RankedPose", "PoseRanking", "rank_gripper_poses"]

#: Every status a candidate pose can get.
POSE_STATUSES: tuple[str, ...] = ("ok", "collision", "no contact", "misses the part",
                                  "malformed")


@dataclass(frozen=True)
class RankedPose:
    """One candidate pose after closing, checking and scoring.

    Attributes
    ----------
    index : int
        Position in the candidate file.
    name : str
    status : str
        One of ``POSE_STATUSES``.
    reason : str or None
        Why a candidate that is not ``ok`` is not.
    grasp : GripperGrasp or None
        For ``ok``: the pose moved along its x axis so both pads touch, the contacts (its
        +x pad's first) and the measures; ``closure`` says whether it closes.
    same_as : int or None
        The first candidate that is the same jaw grasp (equal, or its half-turn).
    label : float or None
        The file's own label or confidence for this pose.
    given_width : float or None
        The width the file gives for this pose (part units), beside the grasp's own ``width``
        where the jaws closed.
    """

    index: int
    name: str
    status: str
    reason: str | None
    grasp: GripperGrasp | None = field(default=None, repr=False)
    same_as: int | None = None
    label: float | None = None
    given_width: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (a ranked grasp's fields as in ``synth plan --gripper``)."""
        out: dict[str, Any] = {"index": self.index, "name": self.name, "status": self.status,
                               "reason": self.reason, "same_as": self.same_as,
                               "label": self.label, "given_width": self.given_width}
        if self.grasp is not None:
            out.update(self.grasp.to_json())
        return out


@dataclass(frozen=True)
class PoseRanking:
    """Result of :func:`rank_gripper_poses`.

    Attributes
    ----------
    rows : tuple of RankedPose
        Ranked candidates best first, then the others in file order.
    gripper : Gripper
        In the part's unit.
    counts : dict of str to int
        Candidates per status.
    mass : float or None
    torsion : float
        The pads' torsional coefficient, part units.
    seconds : float
    """

    rows: tuple[RankedPose, ...]
    gripper: Gripper
    counts: dict[str, int]
    mass: float | None
    torsion: float
    seconds: float


def _turn_back(g: GripperGrasp) -> GripperGrasp:
    """The same grasp seen from the half-turned pose: pads swapped."""
    from dataclasses import replace

    return replace(g, pose=g.pose @ half_turn(), points=g.points[::-1], normals=g.normals[::-1],
                   patch=g.patch[::-1])


def rank_gripper_poses(part: Any, poses: NDArray[np.float64], metres_per_unit: float,
                       params: GripperParams, malformed: dict[int, str] | None = None,
                       names: tuple[str, ...] | None = None,
                       labels: NDArray[np.float64] | None = None,
                       epsilon_top: int | None = None,
                       widths: NDArray[np.float64] | None = None) -> PoseRanking:
    """Close, check and score gripper poses on a part (see the module).

    Parameters
    ----------
    part : Part
    poses : (n, 4, 4) float
        Gripper base frame to the part's frame, translations in the part's unit.
    metres_per_unit : float
        Metres per part unit (the gripper is scaled by its inverse).
    params : GripperParams
        ``gripper``, ``mu``, ``torsion``, ``mass``/``density``, ``gravity``, ``table``,
        ``edges`` and ``rank_by`` are used.
    malformed : dict of int to str, optional
        Candidates already known to be malformed, with the reason.
    names : tuple of str, optional
    labels : (n,) float, optional
        The file's labels, carried to the rows.
    epsilon_top : int, optional
        Compute epsilon (a convex hull per grasp, about 10 ms) for the best this many ranked
        grasps only, as the planner does for the grasps it returns; None: for all. Ranking
        by ``mu_min`` or ``epsilon`` computes it for all.
    widths : (n,) float, optional
        The file's grasp widths in part units, carried to the rows (the jaws always close
        from the gripper's full opening).

    Returns
    -------
    PoseRanking
    """
    t0 = time.perf_counter()
    bad = dict(malformed or {})
    n = len(poses)
    names = names or tuple(str(i) for i in range(n))
    scale = 1.0 / metres_per_unit
    gripper = load_gripper(params.gripper).scaled(scale)
    gamma = TORSION_M * scale if params.torsion is None else float(params.torsion)
    mass = part_mass(part, params, scale)
    good = np.array([i for i in range(n) if i not in bad], np.int64)
    canon, turned = canonical_half_turn(np.asarray(poses, float)[good])
    uniq, first, inverse = np.unique(canon.reshape(len(canon), 16), axis=0, return_index=True,
                                     return_inverse=True)
    inverse = inverse.reshape(-1)
    U = uniq.reshape(-1, 4, 4)
    mesh = part.mesh
    jaws = close_jaws(np.asarray(mesh.vertices), np.asarray(mesh.faces),
                      np.asarray(mesh.face_normals), U, gripper, part.surface_tolerance)
    checker = GripperChecker(part, gripper, PREGRASP_M * scale,
                             max(1e-3 * part.length, 10.0 * part.precision), params.table)
    landed = np.flatnonzero(jaws.status == LANDED)
    hit = np.full(len(U), CLEAR, np.int64)
    hit[landed] = checker.check(jaws.poses[landed], jaws.width[landed])
    clear = landed[hit[landed] == CLEAR]
    every = epsilon_top is None or params.rank_by in ("mu_min", "epsilon")
    results, order = _score(part, jaws.take(clear), gripper, params, gamma, mass,
                            None if every else epsilon_top)
    grasp_of = dict(zip(clear.tolist(), results, strict=True))
    position = {int(clear[k]): r for r, k in enumerate(order)}
    rows: list[RankedPose] = []
    ranked: list[tuple[int, RankedPose]] = []
    def given(i: int) -> float | None:
        return None if widths is None else float(widths[i])

    for k, i in enumerate(good.tolist()):
        u = int(inverse[k])
        lab = None if labels is None else float(labels[i])
        same = int(good[first[u]]) if int(good[first[u]]) != i else None
        if jaws.status[u] != LANDED:
            status = "misses the part" if jaws.status[u] == MISSES else "no contact"
            rows.append(RankedPose(i, names[i], status, JAW_STATUS[int(jaws.status[u])],
                                   None, same, lab, given(i)))
        elif hit[u] != CLEAR:
            rows.append(RankedPose(i, names[i], "collision", GRIPPER_STATUS[int(hit[u])], None,
                                   same, lab, given(i)))
        else:
            g = grasp_of[u]
            ranked.append((position[u], RankedPose(i, names[i], "ok", None,
                                                   _turn_back(g) if turned[k] else g, same,
                                                   lab, given(i))))
    for i, why in bad.items():
        rows.append(RankedPose(i, names[i], "malformed", why, None, None,
                               None if labels is None else float(labels[i]), given(i)))
    ranked.sort(key=lambda r: (r[0], r[1].index))
    out = tuple([r for _, r in ranked] + sorted(rows, key=lambda r: r.index))
    counts = {s: sum(r.status == s for r in out) for s in POSE_STATUSES}
    return PoseRanking(out, gripper, counts, mass, gamma, time.perf_counter() - t0)


def _score(part: Any, jaws: Any, gripper: Gripper, params: GripperParams, gamma: float,
           mass: float | None, epsilon_top: int | None
           ) -> tuple[list[GripperGrasp], NDArray[np.int64]]:
    """Every landed, collision-free pose scored as the planner scores the grasps it returns,
    and their order (epsilon for the best ``epsilon_top`` of the order only, None: all)."""
    P, N = jaws.points, jaws.normals
    if not len(P):
        return [], np.zeros(0, np.int64)
    fc = frictional_form_closure_batch(P, N, params.mu, center=part.center_mass,
                                       edges=params.edges, compiled=None, torsion=gamma)
    spw = np.full(len(P), np.inf)
    sampled = np.full(len(P), np.inf)
    worst = np.full((len(P), 3), np.nan)
    closing = np.flatnonzero(fc.closure)
    if len(closing):
        hold = gravity_hold_batch(P[closing], N[closing], params.mu, gamma, part.center_mass,
                                  part.length, params.gravity, params.edges, compiled=None)
        spw[closing] = hold.squeeze_per_weight
        sampled[closing] = hold.sampled
        worst[closing] = hold.worst_direction
    scored = Scored(jaws.poses, jaws.width, P, N, jaws.patch, fc.d_star, spw, sampled, worst)
    closure = ["frictional form" if c else "none" for c in fc.closure]
    if epsilon_top is None:
        grasps = grasp_results(scored, part, gripper, params, gamma, mass, closure,
                               compiled=None)
        order = rank_order(params.rank_by, spw, fc.d_star,
                           np.array([g.mu_min for g in grasps]),
                           np.array([g.epsilon for g in grasps]))
        return grasps, order
    order = rank_order(params.rank_by, spw, fc.d_star, spw, spw)  # margin or d_star
    head = np.zeros(len(P), bool)
    head[order[:epsilon_top]] = True
    return grasp_results(scored, part, gripper, params, gamma, mass, closure, head,
                         compiled=None), order
