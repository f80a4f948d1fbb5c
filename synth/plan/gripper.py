"""Parallel-jaw grasps of a part: gripper poses, ranked by whether they hold its weight.

The gripper route of the planner (``synth plan --gripper``), in the data path's order:

1. **contacts**: surface points drawn on the exposed surface from the seed, half by area and
   half region by region (every face region as likely, so small faces get their share); each
   shoots a ray along its inward normal to where the opposite pad would land (the
   method Dex-Net samples antipodal grasps with), and the pair is kept when the line between
   them lies inside both friction cones;
2. **poses**: each pair gives the closing axis ``x`` (the bisector of the two outward normals),
   and ``APPROACHES`` approach directions ``z`` about it (every 90 degrees), tried in turn
   until one is clear; the tool centre point is put at the pair's midpoint;
3. **jaws** (:func:`synth.fingers.jaws.close_jaws`): the jaws close from the open width until
   both pads touch; the contacts are where the pads land (patches on faces, the pad's
   normal);
4. **collisions** (:class:`synth.fingers.gripper_collide.GripperChecker`, FCL): palm and
   fingers along the approach from the pre-grasp distance, and the closed fingers, against
   every body of the part and the table;
5. **scores** (soft contacts, :mod:`synth.scores`): frictional d* and closure, and the least
   squeeze against gravity in every orientation (or ``gravity``): coarse icosphere bounds (12,
   then 42 directions) screen the distinct contact pairs, dropping those certainly outside the
   best ``SCREEN * SHORTLIST * top``, and the fine one (162) ranks the best ``SHORTLIST``
   times ``top``; ``mu_min`` and the Ferrari-Canny epsilon of the grasps
   returned;
6. **refinement** (:mod:`synth.plan.gripper_refine`): the ``REFINE_TOP`` best grasps by
   margin try small moves of their pose and keep the one needing the least squeeze;
7. **ranking**: by the gravity margin (the least squeeze per weight, ascending) by default, and
   the best poses kept pairwise distinct: their contact pairs at least ``DISTINCT_RTOL`` of the
   part's size apart (Hausdorff distance of the unordered pairs, so a pose and its half-turn
   about the approach axis are the same grasp).

Lengths are in the part's unit (the gripper is converted from metres), so the part's unit
must be known.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from synth.errors import InputError
from synth.fingers.gripper import Gripper, load_gripper
from synth.fingers.gripper_collide import CLEAR, GripperChecker
from synth.fingers.jaws import EDGE_TOUCH, LANDED, TOO_WIDE, JawContacts, close_jaws, pad_touch
from synth.plan.gripper_params import APPROACHES, GRIPPER_RANK_BY, GripperParams
from synth.plan.gripper_refine import Scored, refine
from synth.plan.params import from_dict
from synth.plan.result import describe_part, new_run_id
from synth.scores.cones import cone_name
from synth.scores.friction_batch import frictional_form_closure_batch
from synth.scores.gravity import GRAVITY, gravity_hold_batch
from synth.scores.mu_min import mu_min_batch
from synth.scores.quality import epsilon_quality

__all__ = ["APPROACHES", "DISTINCT_RTOL", "GRIPPER_RANK_BY", "GripperParams", "GripperGrasp",
           "GripperPlan", "plan_gripper", "plan_gripper_file", "PREGRASP_M", "TORSION_M",
           "grasp_results", "loaded_with", "rank_order", "part_mass", "unit_scale"]

#: Contact pairs of two returned grasps are at least this fraction of the part's size apart.
DISTINCT_RTOL: float = 0.05
#: Pre-grasp distance along the approach, metres (as MoveIt's pick pipelines default to).
PREGRASP_M: float = 0.1
#: Default torsional coefficient of a pad, metres (MuJoCo's default torsional friction).
TORSION_M: float = 0.005
#: Poses whose contacts are this close (fraction of the part's size) are scored once.
DEDUPE_RTOL: float = 0.005
#: Grasps scored with the fine gravity bound: this many times ``top``, the best by the coarse.
SHORTLIST: int = 2
#: The coarse screens keep every grasp that may be among this many times the shortlist.
SCREEN: int = 4
#: The best grasps refined by small moves of the pose (:mod:`synth.plan.gripper_refine`).
REFINE_TOP: int = 10
#: Surface points are drawn until this share of ``samples`` pairs fits the open jaws ...
FIT_SHARE: float = 0.5
#: ... or this many draws of ``samples`` points were made.
MAX_DRAWS: int = 8


@dataclass(frozen=True)
class GripperGrasp:
    """One gripper grasp, in the part's frame and unit.

    Attributes
    ----------
    pose : (4, 4) float
        The gripper's base frame (ACRONYM/GraspGen: approach +z, closing x) in the part frame.
    tcp : (3,) float
        Tool centre point.
    width : float
        Pad distance at the grasp.
    points, normals : (2, 3) float
        Contacts (the +x pad's first) and their inward normals.
    patch : (2,) float
        Size of each contact patch (0: a point).
    d_star : float
        Trinkle's frictional d* with soft contacts.
    closure : str
    mu_min : float
    epsilon : float
        NaN where it was not computed (``synth rank --gripper`` beyond its ``--top`` rows).
    squeeze_per_weight : float
        Least squeeze / weight that holds the part (every orientation: a certified bound).
    squeeze_sampled : float
        The worst sampled direction's value (<= ``squeeze_per_weight``).
    worst_gravity : (3,) float
    least_squeeze : float or None
        Newtons, when the mass is known.
    margin : float or None
        Rated grip force / least squeeze (>= 1: the rated force holds the part).
    """

    pose: NDArray[np.float64] = field(repr=False)
    tcp: NDArray[np.float64] = field(repr=False)
    width: float
    points: NDArray[np.float64] = field(repr=False)
    normals: NDArray[np.float64] = field(repr=False)
    patch: NDArray[np.float64] = field(repr=False)
    d_star: float
    closure: str
    mu_min: float
    epsilon: float
    squeeze_per_weight: float
    squeeze_sampled: float
    worst_gravity: NDArray[np.float64] = field(repr=False)
    least_squeeze: float | None
    margin: float | None

    @property
    def touch(self) -> tuple[str, str]:
        """How each pad touches: ``"pad"`` (its face on the part: the normal is the pad's
        closing direction) or ``"rim"`` (only its rim on a slope: the normal is the part's)."""
        return pad_touch(self.pose, self.normals)

    def to_json(self) -> dict[str, Any]:
        """The grasp as a JSON object."""
        def num(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else float(x)

        return {"pose": self.pose.tolist(), "tcp": self.tcp.tolist(), "width": self.width,
                "contacts": [{"point": p.tolist(), "normal": n.tolist(), "patch": float(s),
                              "touch": t}
                             for p, n, s, t in zip(self.points, self.normals, self.patch,
                                                   self.touch, strict=True)],
                "measures": {"margin": num(self.margin), "least_squeeze": num(self.least_squeeze),
                             "squeeze_per_weight": num(self.squeeze_per_weight),
                             "squeeze_per_weight_sampled": num(self.squeeze_sampled),
                             "worst_gravity": self.worst_gravity.tolist(),
                             "d_star": self.d_star, "closure": self.closure,
                             "mu_min": num(self.mu_min), "epsilon": num(self.epsilon)}}


@dataclass(frozen=True)
class GripperPlan:
    """Result of :func:`plan_gripper`.

    Attributes
    ----------
    gripper : Gripper
        In the part's unit.
    grasps : tuple of GripperGrasp
        Best first.
    message : str
    params : GripperParams
    units : str
    mass : float or None
        kg.
    cone : str
    counts : dict
        Pairs sampled, poses tried, landed, too wide, edge touches, collision-free, closure.
    narrowest : float or None
        Narrowest width found among poses whose pads touched (for parts too large).
    seconds : float
    length : float
        The part's characteristic length (bounding-box diagonal), in ``units``.
    mesh : dict
        Where the part came from and what loading did to it
        (:func:`synth.plan.result.describe_part`: ``path``, ``sha256``, ``units``,
        ``length``, ``repairs``, ...), as a point-finger plan records it.
    run_id : str
        Name of the run (:func:`synth.plan.result.new_run_id`), written into its JSON, PNG
        and GLB files.
    """

    gripper: Gripper
    grasps: tuple[GripperGrasp, ...]
    message: str
    params: GripperParams
    units: str
    mass: float | None
    cone: str
    counts: dict[str, int]
    narrowest: float | None
    seconds: float
    length: float = 0.0
    mesh: dict[str, Any] = field(default_factory=dict)
    run_id: str = field(default_factory=new_run_id)

    def to_json(self) -> dict[str, Any]:
        """The ``synth.gripper_grasps`` document."""
        from dataclasses import asdict

        from synth import __version__

        p = self.params
        return {"format": "synth.gripper_grasps", "version": 1, "synth_version": __version__,
                "run_id": self.run_id, "units": self.units,
                "mesh": {**self.mesh, "units": self.units, "length": self.length},
                "params": asdict(p), "timing": {"total_s": self.seconds},
                "gripper": self.gripper.to_json(),
                "model": {"mu": p.mu, "torsion": self.gripper.unit_scale * TORSION_M
                          if p.torsion is None else p.torsion, "cone": self.cone,
                    "contact": "soft (MuJoCo condim 4, inscribed linearisation)",
                    "mass": self.mass, "gravity": None if p.gravity is None else list(p.gravity),
                    "gravity_directions": "every orientation (certified bound over an "
                    "icosphere's 162 directions)" if p.gravity is None else "given",
                    "rank_by": p.rank_by},
                "counts": self.counts, "seconds": self.seconds, "message": self.message,
                "grasps": [g.to_json() for g in self.grasps]}


def unit_scale(part: Any) -> float:
    """Lengths of the part's unit per metre (its unit must be known)."""
    import trimesh

    if part.units is None:
        raise InputError("gripper: the part's length unit is unknown (the file does not say) "
                         "and gripper sizes are physical: give --units (mm, cm, m, in, ...; "
                         "Python: load_part(path, units=...))")
    return float(trimesh.units.unit_conversion("meters", part.units))


def part_mass(part: Any, params: GripperParams, scale: float) -> float | None:
    """The part's mass in kg from ``params`` (``mass``, or ``density`` times the closed
    bodies' volume, ``scale`` part units per metre), None when neither is given."""
    if params.mass is not None:
        return float(params.mass)
    if params.density is None:
        return None
    if part.volume <= 0:
        raise InputError("--density: the part has no closed body, so no volume; give --mass")
    return float(params.density) * float(part.volume) / scale**3


def _sample_pairs(part: Any, n: int, mu: float, rng: np.random.Generator,
                  focus: NDArray[np.bool_] | None = None, with_faces: bool = False
                  ) -> tuple[NDArray[np.float64], ...]:
    """Antipodal pairs: points p, their ray's far hit q along the inward normal, axis x
    (and, ``with_faces``, the face of each p). ``focus`` (f,) restricts the draw to those
    faces (by area)."""
    import trimesh

    mesh = part.mesh
    area = np.asarray(mesh.area_faces, float) * (part.face_exposure > 0)
    region = np.asarray(part.face_region)
    per_region = np.bincount(np.maximum(region, 0), weights=area)
    balanced = np.where(region >= 0, area / np.maximum(per_region[np.maximum(region, 0)],
                                                       1e-300), 0.0)
    weights = ((n - n // 2, area), (n // 2, balanced)) if focus is None else (
        (n, area * focus),)
    draws = [trimesh.sample.sample_surface(mesh, k, face_weight=w,
                                           seed=int(rng.integers(2**31)))
             for k, w in weights if k and w.sum() > 0]
    if not draws:
        return (np.zeros((0, 3)),) * 3 + ((np.zeros(0, np.int64),) if with_faces else ())
    pts = np.concatenate([d[0] for d in draws])
    faces = np.concatenate([d[1] for d in draws])
    out = np.asarray(mesh.face_normals, float)[faces]
    keep = part.exposed(pts, -out)
    pts, out, faces = pts[keep], out[keep], faces[keep]
    reach = 2.0 * part.length
    origins = pts - out * reach  # from beyond the part, back towards p along -out
    hit = mesh.ray.intersects_first(origins, out)
    ok = hit >= 0
    pts, out, hit, origins = pts[ok], out[ok], hit[ok], origins[ok]
    n_q = np.asarray(mesh.face_normals, float)[hit]
    v0 = np.asarray(mesh.vertices, float)[np.asarray(mesh.faces)[hit, 0]]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.einsum("ij,ij->i", v0 - origins, n_q) / np.einsum("ij,ij->i", out, n_q)
    q = origins + s[:, None] * out
    axis = out - n_q
    norm = np.linalg.norm(axis, axis=1)
    line = pts - q
    ln = np.linalg.norm(line, axis=1)
    good = np.isfinite(s) & (norm > 1e-9) & (ln > part.feature_tolerance)
    pts, q, out, n_q, axis, line, ln, faces = (a[good] for a in (pts, q, out, n_q, axis, line,
                                                                  ln, faces[ok]))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    u = line / ln[:, None]
    cos_cone = 1.0 / math.sqrt(1.0 + mu * mu)
    inside = (np.einsum("ij,ij->i", u, out) > cos_cone) & (-np.einsum("ij,ij->i", u, n_q)
                                                            > cos_cone)
    return (pts[inside], q[inside], axis[inside]) + ((faces[inside],) if with_faces else ())


def _poses(p: NDArray[np.float64], q: NDArray[np.float64], axis: NDArray[np.float64],
           tcp: NDArray[np.float64], approaches: int) -> NDArray[np.float64]:
    """Poses (n * approaches, 4, 4): x along ``axis``, z about it, the TCP at the midpoint."""
    e = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(axis, e)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(axis, e1)
    ang = 2.0 * np.pi * np.arange(approaches) / approaches
    z = np.cos(ang)[None, :, None] * e1[:, None] + np.sin(ang)[None, :, None] * e2[:, None]
    x = np.broadcast_to(axis[:, None], z.shape)
    y = np.cross(z, x)
    T = np.zeros((len(p), approaches, 4, 4))
    T[..., :3, 0], T[..., :3, 1], T[..., :3, 2] = x, y, z
    mid = 0.5 * (p + q)
    T[..., :3, 3] = mid[:, None] - np.einsum("naij,j->nai", T[..., :3, :3], tcp)
    T[..., 3, 3] = 1.0
    return T.reshape(-1, 4, 4)


def _unique_contacts(points: NDArray[np.float64], cell: float) -> NDArray[np.int64]:
    """Indices of the first of each group of contact pairs falling in the same two cells of
    size ``cell`` (pairs unordered), in their original order."""
    if not len(points):
        return np.zeros(0, np.int64)
    q = np.floor(points / cell).astype(np.int64)  # (n, 2, 3)
    a, b = q[:, 0], q[:, 1]
    diff = a - b
    first = np.argmax(diff != 0, axis=1)  # first differing coordinate (0 when equal)
    a_less = diff[np.arange(len(diff)), first] < 0
    lo = np.where(a_less[:, None], a, b)
    hi = np.where(a_less[:, None], b, a)
    _, idx = np.unique(np.concatenate([lo, hi], axis=1), axis=0, return_index=True)
    return np.sort(idx)


def _hausdorff_pairs(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hausdorff distance between the unordered pair ``a`` (2, 3) and each pair of ``b``."""
    d = np.linalg.norm(a[None, :, None, :] - b[:, None, :, :], axis=3)  # (n, 2, 2)
    return np.maximum(d.min(axis=2).max(axis=1), d.min(axis=1).max(axis=1))


def _distinct(P: NDArray[np.float64], order: NDArray[np.int64], size: float, top: int
              ) -> NDArray[np.int64]:
    """The first ``top`` of ``order`` whose contact pairs are pairwise ``size`` apart."""
    chosen: list[int] = []
    for i in order:
        if len(chosen) == top:
            break
        if not chosen or _hausdorff_pairs(P[i], P[chosen]).min() >= size:
            chosen.append(int(i))
    return np.array(chosen, np.int64)


def rank_order(rank_by: str, spw: NDArray[np.float64], d: NDArray[np.float64],
               mumin: NDArray[np.float64], eps: NDArray[np.float64]) -> NDArray[np.int64]:
    """Indices of grasps in ``rank_by`` order (ties by the squeeze, then by d*)."""
    if rank_by == "margin":
        return np.lexsort((-d, spw))
    if rank_by == "d_star":
        return np.lexsort((spw, -d))
    if rank_by == "mu_min":
        return np.lexsort((spw, mumin))
    return np.lexsort((spw, -eps))


def plan_gripper(part: Any, params: GripperParams) -> GripperPlan:
    """Plan parallel-jaw grasps of a part (see the module for the steps).

    Parameters
    ----------
    part : Part
        With a known unit.
    params : GripperParams

    Returns
    -------
    GripperPlan
    """
    t0 = time.perf_counter()
    from synth.part import Part

    if not isinstance(part, Part):
        raise InputError(f"part: expected a synth.Part (see synth.load_part), got "
                         f"{type(part).__name__}")
    if not isinstance(params, GripperParams):
        raise InputError(f"params: expected a synth.GripperParams, got {type(params).__name__}")
    if params.rank_by not in GRIPPER_RANK_BY:
        raise InputError(f"--rank-by: {params.rank_by!r} is not a gripper measure; expected one "
                         f"of {', '.join(GRIPPER_RANK_BY)}")
    if not params.mu > 0:
        raise InputError(f"--mu: jaw grasps need friction, expected mu > 0, got {params.mu!r}")
    scale = unit_scale(part)
    gripper = load_gripper(params.gripper).scaled(scale)
    mass = part_mass(part, params, scale)
    gamma = TORSION_M * scale if params.torsion is None else float(params.torsion)
    counts: dict[str, int] = {}
    checker = GripperChecker(part, gripper, PREGRASP_M * scale,
                             max(1e-3 * part.length, 10.0 * part.precision), params.table)
    jaws, clear, narrowest = _land(part, gripper, checker, params, counts)
    pool = _score(part, jaws, clear, params, gamma, counts)
    grasps: list[GripperGrasp] = []
    heavy = None  # the least squeeze of all, in N, when the floor leaves no grasp
    if len(pool.spw):
        size = DISTINCT_RTOL * part.length
        ranked = np.arange(len(pool.spw))
        # the physical floor, as the largest squeeze per weight within the rated grip
        limit = None if mass is None or not params.min_margin else (
            gripper.grip_force / (params.min_margin * mass * GRAVITY))
        if params.rank_by == "margin" or limit is not None:  # refine the least squeezes
            least = ranked if params.rank_by == "margin" else np.argsort(pool.spw,
                                                                         kind="stable")
            head = pool.take(_distinct(pool.points, least, size, REFINE_TOP))
            moved = refine(head, part, gripper, checker, params.mu, gamma, params.gravity,
                           params.edges)
            if params.rank_by == "margin":
                pool = _joined(moved, pool)
                ranked = np.argsort(pool.spw, kind="stable")
            else:  # ranked by another measure: the refined poses rank after every original
                # (whose order is that measure's), so one is returned only when fewer than
                # --top originals are within the floor, and a part too heavy for every pose
                # is told the least squeeze of all
                pool = _joined(pool, moved)
                ranked = np.arange(len(pool.spw))
        if limit is not None and mass is not None:
            within = pool.spw[ranked] <= limit
            counts["within_grip"] = int(within.sum())
            if not within.any():
                heavy = float(pool.spw.min()) * mass * GRAVITY
            ranked = ranked[within]
        if len(ranked):
            best = pool.take(_distinct(pool.points, ranked, size, params.top))
            grasps = grasp_results(best, part, gripper, params, gamma, mass)
    message = _message(gripper, grasps, counts, narrowest, mass, str(part.units))  # (known)
    if heavy is not None:
        where = ("in every orientation" if params.gravity is None else
                 "against gravity along --gravity")
        message = (f"no grasp: the part ({mass:.4g} kg) is too heavy for the "
                   f"{gripper.title}'s rated {gripper.grip_force:g} N: of "
                   f"{counts['closure']} closing grasps, the best needs a squeeze of "
                   f"{heavy:.3g} N to hold it {where}"
                   f" (margin {gripper.grip_force / heavy:.2f}, below --min-margin "
                   f"{params.min_margin:g}); --min-margin 0 returns them anyway")
    cone = cone_name(params.edges, gamma > 0)
    return GripperPlan(gripper, tuple(grasps), message, params, str(part.units), mass, cone,
                       counts, narrowest, time.perf_counter() - t0, float(part.length),
                       describe_part(part))


def _land(part: Any, gripper: Gripper, checker: GripperChecker, params: GripperParams,
          counts: dict[str, int]) -> tuple[JawContacts, NDArray[np.int64], float | None]:
    """Steps 1 to 4: each pair's first approach (of ``APPROACHES``) whose jaws land and whose
    gripper is clear, the ones landing on distinct contacts, and the narrowest width found.

    The approaches are tried in rounds: all pairs at the first angle, then the pairs still
    without a clear pose at the next, and so on (the measures depend on the contacts only;
    the refinement turns the best poses about their closing axis again)."""
    rng = np.random.default_rng(params.seed)
    p, q, axis, wide = _fitting_pairs(part, gripper, params, rng, counts)
    poses = _poses(p, q, axis, gripper.tcp, APPROACHES).reshape(len(p), APPROACHES, 4, 4)
    mesh = part.mesh
    touch = part.surface_tolerance  # follows the part's size and coordinate precision
    V, F, FN = (np.asarray(a) for a in (mesh.vertices, mesh.faces, mesh.face_normals))
    pending = np.arange(len(p))
    found: list[JawContacts] = []
    tried = landed_n = too_wide = edge = 0
    narrowest = wide
    for a in range(APPROACHES):
        if not len(pending):
            break
        jaws = close_jaws(V, F, FN, poses[pending, a], gripper, touch)
        tried += len(pending)
        landed = np.flatnonzero(jaws.status == LANDED)
        landed_n += len(landed)
        too_wide += int((jaws.status == TOO_WIDE).sum())
        edge += int((jaws.status == EDGE_TOUCH).sum())
        if np.isfinite(jaws.width).any():
            narrowest = min(narrowest, float(np.nanmin(jaws.width)))
        clear = landed[checker.check(jaws.poses[landed], jaws.width[landed]) == CLEAR]
        found.append(jaws.take(clear))
        keep = np.ones(len(pending), bool)
        keep[clear] = False
        pending = pending[keep]
    jaws = JawContacts.concatenate(found) if found else close_jaws(V, F, FN, poses[:0, 0],
                                                                     gripper, touch)
    counts.update(poses=tried, landed=landed_n, too_wide=too_wide, edge_touch=edge,
                  collision_free=len(jaws.status))
    # poses landing on the same contacts (to DEDUPE_RTOL of the part's size) are scored once
    clear = _unique_contacts(jaws.points, DEDUPE_RTOL * part.length)
    counts["distinct_contacts"] = len(clear)
    return jaws, clear, float(narrowest) if np.isfinite(narrowest) else None


def _fitting_pairs(part: Any, gripper: Gripper, params: GripperParams,
                   rng: np.random.Generator, counts: dict[str, int]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                              float]:
    """Step 1: antipodal pairs that may fit between the open jaws, and the narrowest extent
    along the closing axis of those that cannot (inf if none).

    A pair whose points lie further apart along its closing axis than the gripper opens
    cannot be grasped there, so it is dropped before any jaw closes; surface points are drawn
    ``params.samples`` at a time until at least ``FIT_SHARE`` of that many pairs fit or
    ``MAX_DRAWS`` draws were made (a part much larger than the hand, graspable only at thin
    features, gets more draws; one that fits gets the first draw only)."""
    found, wide, drawn = [], np.inf, 0
    n = 0
    region = np.asarray(part.face_region)
    focus = None
    for _ in range(MAX_DRAWS):
        p, q, axis, faces = _sample_pairs(part, params.samples, params.mu, rng, focus,
                                          with_faces=True)
        drawn += params.samples
        extent = np.abs(np.einsum("ij,ij->i", p - q, axis))
        fits = extent <= gripper.max_opening
        if (~fits).any():
            wide = min(wide, float(extent[~fits].min()))
        found.append((p[fits], q[fits], axis[fits]))
        n += int(fits.sum())
        if n >= FIT_SHARE * params.samples:
            break
        # the next draws on the face regions where pairs fit: thin features of a large part
        seen = np.unique(region[faces[fits]])
        if len(seen) and (focus is None or not np.isin(region[focus], seen).all()):
            focus = np.isin(region, seen) if focus is None else focus | np.isin(region, seen)
    p, q, axis = (np.concatenate([f[i] for f in found]) for i in range(3))
    counts.update(drawn=drawn, pairs=len(p))
    return p, q, axis, wide


def _score(part: Any, jaws: Any, clear: NDArray[np.int64], params: GripperParams,
           gamma: float, counts: dict[str, int]) -> Scored:
    """Step 5: the closure grasps among ``clear``, scored and in ``rank_by`` order."""
    P, N = jaws.points[clear], jaws.normals[clear]
    if not len(clear):
        counts["closure"] = 0
        return _pool(jaws, clear, P, N, np.zeros(0), None)
    fc = frictional_form_closure_batch(P, N, params.mu, center=part.center_mass,
                                       edges=params.edges, compiled=False, torsion=gamma)
    counts["closure"] = int(fc.closure.sum())
    alive, spw = _screen(P, N, np.flatnonzero(fc.closure), part, params, gamma,
                         SCREEN * SHORTLIST * params.top)
    ranked = alive[np.argsort(spw, kind="stable")]
    short = _distinct(P, ranked, DISTINCT_RTOL * part.length, SHORTLIST * params.top)
    if not len(short):
        return _pool(jaws, clear[:0], P[:0], N[:0], np.zeros(0), None)
    hold = gravity_hold_batch(P[short], N[short], params.mu, gamma, part.center_mass,
                              part.length, params.gravity, params.edges, compiled=False)
    spw, d = hold.squeeze_per_weight, fc.d_star[short]
    P, N, clear = P[short], N[short], clear[short]
    if params.rank_by in ("mu_min", "epsilon"):
        mm = mu_min_batch(P, N, gamma, params.edges, compiled=False).mu_min
        ee = np.array([epsilon_quality(P[i], N[i], part.center_mass, part.length, params.mu,
                                       params.edges, gamma) for i in range(len(P))])
        order = rank_order(params.rank_by, spw, d, mm, ee)
    else:
        order = rank_order(params.rank_by, spw, d, spw, spw)
    order = order[np.isfinite(spw[order])]
    return _pool(jaws, clear[order], P[order], N[order], d[order], hold, order)


def _screen(P: NDArray[np.float64], N: NDArray[np.float64], alive: NDArray[np.int64],
            part: Any, params: GripperParams, gamma: float, keep: int
            ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The grasps ``alive`` that may be among the ``keep`` needing the least squeeze, and their
    bounds: icosphere levels 0 (12 directions) then 1 (42), each dropping the grasps whose
    sampled worst case (a lower bound) exceeds the ``keep``-th least certified bound."""
    spw = np.zeros(0)
    for level in (0, 1) if params.gravity is None else (0,):
        h = gravity_hold_batch(P[alive], N[alive], params.mu, gamma, part.center_mass,
                               part.length, params.gravity, params.edges, compiled=False,
                               level=level)
        up, low = h.squeeze_per_weight, h.sampled
        finite = np.sort(up[np.isfinite(up)])
        limit = finite[keep - 1] if len(finite) >= keep else np.inf
        stay = np.isfinite(low) & (low <= limit)
        alive, spw = alive[stay], up[stay]
    return alive, spw


def _pool(jaws: Any, idx: NDArray[np.int64], P: NDArray[np.float64], N: NDArray[np.float64],
          d: NDArray[np.float64], hold: Any, rows: NDArray[np.int64] | None = None) -> Scored:
    """Scored grasps from the jaws' poses ``idx`` and the scores (``hold`` rows ``rows``)."""
    if hold is None:
        return Scored(jaws.poses[idx], jaws.width[idx], P, N, jaws.patch[idx], d, np.zeros(0),
                      np.zeros(0), np.zeros((0, 3)))
    return Scored(jaws.poses[idx], jaws.width[idx], P, N, jaws.patch[idx], d,
                  hold.squeeze_per_weight[rows], hold.sampled[rows], hold.worst_direction[rows])


def plan_gripper_file(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Load a mesh file and plan gripper grasps; the ``synth.gripper_grasps`` document.

    The planner ``synth db build --gripper`` calls for every mesh: ``params`` holds
    :class:`GripperParams` fields and the mesh options :data:`synth.plan.LOAD_KEYS`
    (``units``, the unit of meshes whose file does not say; ``body``; ``sharp_angle`` in
    degrees).
    """
    from synth.part import load_part
    from synth.plan import LOAD_KEYS, load_options

    if not isinstance(params, dict):
        raise InputError(f"plan_gripper_file: params must be a dict of parameter names, got "
                         f"{type(params).__name__}")
    prm = dict(params)
    load = {k: prm.pop(k) for k in LOAD_KEYS if k in prm}
    if isinstance(prm.get("gravity"), list):
        prm["gravity"] = tuple(prm["gravity"])
    gp = from_dict(GripperParams, prm, "plan_gripper_file", LOAD_KEYS)
    part = load_part(path, **load_options(load))
    doc = plan_gripper(part, gp).to_json()
    doc["mesh"].update(loaded_with(load))
    return doc


def loaded_with(load: dict[str, Any]) -> dict[str, Any]:
    """How a part was loaded, for a gripper document's ``mesh`` object (``body`` and
    ``sharp_angle`` in degrees), so that a consumer loads the same part: ``load`` holds the
    mesh options :data:`synth.plan.LOAD_KEYS` given (absent: the defaults)."""
    return {"body": load.get("body", "largest"),
            "sharp_angle": float(load.get("sharp_angle", 30.0))}


def grasp_results(best: Scored, part: Any, gripper: Gripper, params: GripperParams,
                  gamma: float, mass: float | None, closure: list[str] | None = None,
                  epsilon: NDArray[np.bool_] | None = None, compiled: bool | None = False
                  ) -> list[GripperGrasp]:
    """The result objects of scored grasps, with mu_min and epsilon computed for them.

    ``closure`` names each grasp's closure class (default: every one frictional form
    closure, as the planner keeps only those); ``epsilon`` says which grasps get their
    epsilon computed (default all; the others get NaN); ``compiled`` is mu_min's simplex
    route (default numpy, the planner's, whose output must not depend on numba; None lets
    :func:`synth.scores.simplex.compiled_for` choose, as ``synth rank`` does)."""
    mm = mu_min_batch(best.points, best.normals, gamma, params.edges, compiled=compiled).mu_min
    out = []
    for j, pose in enumerate(best.poses):
        least = None if mass is None else float(best.spw[j]) * mass * GRAVITY
        out.append(GripperGrasp(
            pose=pose, tcp=pose[:3, :3] @ gripper.tcp + pose[:3, 3], width=float(best.width[j]),
            points=best.points[j], normals=best.normals[j], patch=best.patch[j],
            d_star=float(best.d_star[j]),
            closure="frictional form" if closure is None else closure[j], mu_min=float(mm[j]),
            epsilon=epsilon_quality(best.points[j], best.normals[j], part.center_mass,
                                    part.length, params.mu, params.edges, gamma)
            if epsilon is None or epsilon[j] else math.nan,
            squeeze_per_weight=float(best.spw[j]), squeeze_sampled=float(best.sampled[j]),
            worst_gravity=best.worst[j], least_squeeze=least,
            margin=None if least is None else gripper.grip_force / least))
    return out


def _joined(first: Scored, then: Scored) -> Scored:
    """The rows of ``first``, then those of ``then``."""
    return Scored(*(np.concatenate([getattr(first, f), getattr(then, f)])
                    for f in Scored.__dataclass_fields__))


def _message(gripper: Gripper, grasps: list[GripperGrasp], counts: dict[str, int],
             narrowest: float | None, mass: float | None, units: str) -> str:
    """The sentence of a plan: what was found, or why nothing was, in words (the counts stay
    in the document's ``counts``): for a part the hand cannot grasp, the narrowest width the
    jaws found across it and the hand's opening."""
    mm = 1000.0 / gripper.unit_scale  # part units -> millimetres
    if grasps:
        g = grasps[0]
        hold = (f"; best holds {mass:g} kg with {g.least_squeeze:.3g} N of "
                f"{gripper.grip_force:g} N (margin {g.margin:.2f})") if mass is not None else (
            f"; best needs a squeeze of {g.squeeze_per_weight:.3g} times the part's weight")
        return (f"{len(grasps)} {gripper.title} grasps ({counts['collision_free']} "
                f"collision-free of {counts['poses']} poses){hold}")
    opening = f"{gripper.max_opening * mm:.0f} mm opening"
    width = ("" if narrowest is None else
             f"the narrowest width found is {narrowest * mm:.0f} mm")
    if counts["landed"] == 0 and narrowest is not None and narrowest > gripper.max_opening:
        return f"no grasp: the part is too large for the {gripper.title}'s {opening} ({width})"
    if counts["pairs"] == 0:
        return ("no grasp: no two points of the part face each other within the friction "
                "cones (mu = the pads' friction) among the surface points drawn; try more "
                "--samples or a larger --mu")
    if counts["landed"] == 0:
        return (f"no grasp: the {gripper.title}'s pads never both rest on the part "
                f"({counts['poses']} poses: a pad misses the part, or touches it with its rim "
                f"where it cannot rest)" + (f"; {width}" if width else ""))
    if counts["collision_free"] == 0:
        return (f"no grasp: where the {gripper.title}'s {opening} fits across the part "
                f"({counts['landed']} of {counts['poses']} poses; {width}), its palm or "
                f"fingers hit the part or the table: the part is too large around those "
                f"places")
    if counts["closure"] == 0:
        return (f"no grasp: none of the {counts['distinct_contacts']} distinct collision-free "
                f"jaw grasps closes (the line between the pads leaves a friction cone)")
    return (f"no grasp: none of the {counts['closure']} closing jaw grasps holds the part "
            f"against gravity with a finite squeeze")
