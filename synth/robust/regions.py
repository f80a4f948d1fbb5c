"""Independent contact regions and the placement tolerance of a grasp.

For each contact, a region of the exposed surface around it such that every choice of one
point per region is frictionless form closure (Nguyen's independent contact regions), and
the *placement tolerance*: the largest radius ``rho`` such that moving every contact anywhere
within ``rho`` of its planned point, along the feature it lies on, keeps form closure.

A contact *slides* on its feature: on a planar piece (:mod:`synth.part.pieces`) it moves in
the plane with its normal fixed; on a convex edge it moves along the edge with its normal
fixed; at a vertex it cannot move. On planar pieces and straight edges each contact's wrench
is affine in its position, and for 7 contacts (the minimum in space) the certificate of
:mod:`synth.robust.certificate` decides closure over the regions; a grasp of more contacts is
certified through 7-contact subsets that are closure by themselves. Everything else
(friction, contacts on curved patches, a grasp with no closure 7-subset) is *sampled*:
random placements within the radius, re-projected onto the surface with their normals,
scored, and the radius bisected; such results say ``certified = False``. A grasp is scored
under its surface model (:mod:`synth.scores.surface`): where the smooth reading of a contact's
normal differs from the mesh's (a sharp edge beside a tessellated patch) and both count, the
regions are sampled with both readings.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from itertools import combinations
from math import comb
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from synth.errors import InputError
from synth.limits import MAX_MU
from synth.part.model import Part
from synth.part.pieces import convex_piece
from synth.part.points import xyz_rows
from synth.part.tolerances import COPLANAR_ANGLE
from synth.robust.certificate import CERT_RTOL, certify, expand, minor_scale
from synth.scores.arguments import center_arg, edges_arg, length_arg
from synth.scores.batch import form_closure_batch
from synth.scores.cones import tangent_basis
from synth.scores.quality import scaled_wrenches
from synth.scores.surface import DEFAULT_SURFACE, check_surface, differs, surface_scores
from synth.scores.wrench import check_contacts

__all__ = ["ContactRegions", "contact_regions", "certify_regions"]

#: Vertices of a region grown around a contact on a planar piece (before clipping).
REGION_VERTICES = 16
#: Vertices of the polygon circumscribing a tolerance disc in the certificate.
DISC_VERTICES = 32
#: Relative precision of the tolerance and of the regions' size (bisection stops when the
#: smallest size known to fail is within this factor of the largest certified one).
SIZE_PRECISION = 1.08
#: Branch-and-bound work limit per cofactor while growing (an undecided size counts as lost).
MAX_BOXES = 300
#: Most 7-contact subsets tried as certificates of closure of a grasp of more contacts (the
#: d* bound uses as many as cover every contact), and how many candidates they are chosen
#: from (all subsets when there are no more than this).
SUBSETS = 3
SUBSET_TRIES = 64
#: Placements per radius when the tolerance is sampled (scored in chunks of ``_CHUNK``).
SAMPLES = 512
_CHUNK = 128


@dataclass(frozen=True)
class ContactRegions:
    """Contact regions and placement tolerance of one grasp.

    Attributes
    ----------
    polygons : tuple of (v_i, 3) float
        Each contact's region as the corners of a convex polygon on its feature, in order
        (two ends of a segment for a contact on an edge; the point itself for a contact that
        cannot move).
    kinds : tuple of str
        How each contact moves: ``"plane"``, ``"edge"``, ``"fixed"`` or ``"curved"``.
    tolerance : float
        Placement tolerance in the part's units.
    limited_by : str
        ``"closure"`` (a larger radius loses form closure), ``"feature"`` (a contact's disc
        would leave its planar piece or edge) or ``"none"`` when the grasp has no closure.
    d_star : float
        The grasp's own d*.
    d_star_min : float
        Smallest d* over every choice of one point per region: a certified lower bound when
        ``certified``, else the smallest sampled.
    certified : bool
        True when the regions and tolerance are proven (frictionless contacts on planar
        pieces, edges or vertices); False when sampled.
    """

    polygons: tuple[NDArray[np.float64], ...]
    kinds: tuple[str, ...]
    tolerance: float
    limited_by: str
    d_star: float
    d_star_min: float
    certified: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON form: ``polygons``, ``kinds``, ``tolerance``, ``limited_by``, ``d_star_min``,
        ``certified``."""
        return {
            "polygons": [np.asarray(p).tolist() for p in self.polygons],
            "kinds": list(self.kinds),
            "tolerance": float(self.tolerance),
            "limited_by": self.limited_by,
            "d_star_min": float(self.d_star_min),
            "certified": bool(self.certified),
        }


@dataclass(frozen=True)
class _Contact:
    """How one contact can move: frame axes (2, 3) (zero rows for locked axes), its feature
    as a convex polygon in frame coordinates (the contact at the origin), and the distance
    to the feature's boundary."""

    kind: str
    axes: NDArray[np.float64]
    feature: NDArray[np.float64]
    reach: float


def _ngon(r: float, m: int, outer: bool) -> NDArray[np.float64]:
    """Regular ``m``-gon about the origin: inscribed in (or, ``outer``, around) radius r."""
    a = (np.arange(m) + 0.5) * 2 * np.pi / m
    s = r / np.cos(np.pi / m) if outer else r
    return np.stack([np.cos(a), np.sin(a)], axis=1) * s


def _clip(poly: NDArray[np.float64], feature: NDArray[np.float64]) -> NDArray[np.float64]:
    """Intersection of two convex polygons, both counter-clockwise (Sutherland-Hodgman)."""
    out = poly
    n = len(feature)
    for a in range(n):
        p, q = feature[a], feature[(a + 1) % n]
        edge = q - p
        s = edge[0] * (out[:, 1] - p[1]) - edge[1] * (out[:, 0] - p[0])  # >= 0 inside
        res = []
        for i in range(len(out)):
            j = (i + 1) % len(out)
            if s[i] >= 0:
                res.append(out[i])
            if (s[i] > 0 > s[j]) or (s[i] < 0 < s[j]):
                res.append(out[i] + (out[j] - out[i]) * (s[i] / (s[i] - s[j])))
        if not res:
            return np.zeros((1, 2))
        out = np.array(res)
    return out


def _shape(c: _Contact, r: float, m: int, outer: bool) -> NDArray[np.float64]:
    """The contact's region of size ``r`` in frame coordinates."""
    if c.kind == "plane":
        return _clip(_ngon(r, m, outer), c.feature)
    if c.kind == "edge":
        lo, hi = float(c.feature[0, 0]), float(c.feature[1, 0])
        return np.array([[max(lo, -r), 0.0], [min(hi, r), 0.0]])
    return np.zeros((1, 2))


def _clamp(reach: float, part: Part) -> float:
    """A distance to a feature's boundary, 0 when within the part's feature tolerance."""
    return reach if reach > part.feature_tolerance else 0.0


def _contacts(part: Part, P: NDArray[np.float64], N: NDArray[np.float64]) -> list[_Contact]:
    """How each contact of a grasp can move on the part's surface."""
    res = part.resolve(P, snap=True)
    out = []
    # a normal within the coplanarity angle of the feature's counts as its own: it stays
    # fixed while the contact slides, so the wrench is still affine in the position
    cos_tol, sin_tol = np.cos(COPLANAR_ANGLE), np.sin(COPLANAR_ANGLE)
    for j in range(len(P)):
        rows = np.flatnonzero(res.finger == j)
        row = rows[np.argmax(res.normals[rows] @ N[j])]
        kind, face = str(res.features[row]), int(res.faces[row])
        reg = part.regions[int(part.face_region[face])] if part.face_region[face] >= 0 else None
        if kind == "face" and reg is not None and reg.planar and np.dot(reg.normal, N[j]) > cos_tol:
            piece = convex_piece(part, face, 0.0)
            if piece is not None:
                xy = np.array([(P[j] - piece.origin) @ piece.u, (P[j] - piece.origin) @ piece.v])
                corners = piece.corners - xy
                reach = float(np.min(piece.b - piece.A @ xy))
                out.append(_Contact("plane", np.stack([piece.u, piece.v]), corners,
                                    _clamp(reach, part)))
                continue
        if kind == "edge":
            a, b = part.mesh.vertices[part.mesh.edges_unique[int(res.feature_index[row])]]
            e = (b - a) / np.linalg.norm(b - a)
            if abs(np.dot(e, N[j])) < sin_tol:
                t = np.sort([(a - P[j]) @ e, (b - P[j]) @ e])
                out.append(_Contact("edge", np.stack([e, np.zeros(3)]),
                                    np.array([[t[0], 0.0], [t[1], 0.0]]),
                                    _clamp(float(min(-t[0], t[1])), part)))
                continue
        smooth = kind == "face" and reg is not None and not reg.planar
        out.append(_Contact("curved" if smooth else "fixed", np.zeros((2, 3)),
                            np.zeros((1, 2)), 0.0))
    return out


def _wrenches(P: NDArray[np.float64], N: NDArray[np.float64], center: NDArray[np.float64],
              length: float, axes: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Wrench matrix (6, k) with moments about ``center`` over ``length``, and each contact's
    wrench change per unit move along its axes (k, 2, 6)."""
    D = np.zeros((len(P), 2, 6))
    D[:, :, 3:] = np.cross(axes, N[:, None, :]) / length
    return scaled_wrenches(P, N, center, length), D


def _grow(test, lo: float, hi: float, top: float) -> float:
    """Largest size in [lo, top] that ``test`` accepts, to SIZE_PRECISION: ``lo`` is known
    to pass; ``hi`` is a first guess of a failing size (it is enlarged until one fails)."""
    if lo >= top or test(top):
        return top
    hi = min(max(hi, lo * 1.5, 1e-300), top)
    while hi < top and test(hi):
        lo, hi = hi, min(hi * 1.5, top)
    while hi > lo * SIZE_PRECISION:
        mid = np.sqrt(lo * hi) if lo > 0 else hi / 8
        if mid <= 1e-12 * top:
            return lo
        if test(mid):
            lo = mid
        else:
            hi = mid
    return lo


def contact_regions(part: Part, points: ArrayLike, normals: ArrayLike, *, mu: float = 0.0,
                    edges: int = 8, d_star: float | None = None, seed: int = 0,
                    smooth: ArrayLike | None = None, surface: str = DEFAULT_SURFACE
                    ) -> ContactRegions:
    """Independent contact regions and the placement tolerance of one grasp.

    Parameters
    ----------
    part : synth.Part
    points, normals : (k, 3) float
        The grasp's contacts (on the part's surface) and inward unit normals.
    mu : float
        Coulomb friction coefficient; with friction the result is sampled.
    edges : int
        Friction cone edges (with ``mu > 0``).
    d_star : float, optional
        The grasp's d*, if already known.
    seed : int
        Seed of the sampling, and of the choice of 7-contact subsets of a grasp of more than
        9 contacts.
    smooth : (k, 3) float, optional
        The smooth reading of the normals (default: ``normals``).
    surface : {"both", "mesh", "smooth"}
        The surface model the grasp is scored with (:mod:`synth.scores.surface`).

    Returns
    -------
    ContactRegions

    Examples
    --------
    >>> r = contact_regions(part, grasp.points, grasp.normals)  # doctest: +SKIP
    >>> r.tolerance, r.certified  # doctest: +SKIP
    (2.1, True)
    """
    if not isinstance(part, Part):
        raise InputError(f"part: expected a synth.Part, got {type(part).__name__}")
    P, N = check_contacts(points, normals, name="contact_regions")
    if P.shape[1] != 3:
        raise InputError(f"points and normals: expected two (k, 3) arrays, got {P.shape}")
    S = N if smooth is None else check_contacts(P, smooth, name="contact_regions: smooth")[1]
    if not (isinstance(mu, numbers.Real) and not isinstance(mu, bool)
            and 0 <= mu <= MAX_MU):
        raise InputError(f"mu: expected a number from 0 to {MAX_MU:g}, got {mu!r}")
    edges = edges_arg(edges)
    if d_star is not None and not (isinstance(d_star, numbers.Real) and not isinstance(
            d_star, bool) and 0 <= d_star <= 1):
        raise InputError(f"d_star: expected a number in [0, 1] or None, got {d_star!r}")
    _seed(seed)
    surface = check_surface(surface)
    if surface == "smooth":
        N = S  # the certificate needs one reading: the one that counts
    cs = _contacts(part, P, N)
    center, L = np.asarray(part.center_mass, float), float(part.length)
    one = surface != "both" or not differs(N[None], S[None])[0]
    if mu == 0 and len(P) >= 7 and all(c.kind != "curved" for c in cs) and one:
        d0 = float(form_closure_batch(scaled_wrenches(P, N, center, L)[None], compiled=False)
                   .d_star[0]) if d_star is None else float(d_star)
        out = _certified(P, N, cs, center, L, d0, seed)
        if out is not None:
            return out
    return _sampled(part, P, N, S, surface, cs, center, L, mu, edges, d_star, seed)


def _points(P: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Regions that are the contacts themselves."""
    return tuple(p[None].copy() for p in P)


def _to3(P: NDArray[np.float64], cs: list[_Contact], shapes: list[NDArray[np.float64]]
         ) -> tuple[NDArray[np.float64], ...]:
    return tuple(P[i] + s @ c.axes for i, (c, s) in enumerate(zip(cs, shapes, strict=True)))


def _subsets(W: NDArray[np.float64], rng: np.random.Generator) -> list[NDArray[np.int64]]:
    """The 7-contact subsets whose wrenches are form closure by themselves, best nominal d*
    first: all of them for up to 9 contacts, else among
    ``SUBSET_TRIES`` drawn at random. A closure subset keeps the whole grasp closure
    wherever the other contacts are."""
    k = W.shape[1]
    if comb(k, 7) <= SUBSET_TRIES:
        cand = np.array(list(combinations(range(k), 7)), dtype=np.int64)
    else:
        cand = np.unique(np.sort(np.array([rng.choice(k, 7, replace=False)
                                           for _ in range(SUBSET_TRIES)]), axis=1), axis=0)
    sub = np.swapaxes(W[:, cand], 0, 1)  # (n, 6, 7)
    c = np.stack([(-1) ** j * np.linalg.det(np.delete(sub, j, axis=2)) for j in range(7)], 1)
    c *= np.where(c.sum(axis=1, keepdims=True) < 0, -1.0, 1.0)
    scale = np.abs(c).max(axis=1)
    ok = c.min(axis=1) > CERT_RTOL * minor_scale(sub)
    d = np.where(ok, c.min(axis=1) / np.where(scale > 0, scale, 1.0), -1.0)
    order = np.argsort(-d, kind="stable")
    return [cand[i] for i in order if d[i] > 0]


def _cover(subsets: list[NDArray[np.int64]], k: int) -> list[NDArray[np.int64]]:
    """The first subset, then the best subset holding a contact not yet covered, until every
    contact is (or none is left)."""
    chosen: list[NDArray[np.int64]] = []
    covered = np.zeros(k, bool)
    for S in subsets:
        if not chosen or not covered[S].all():
            chosen.append(S)
            covered[S] = True
        if covered.all():
            break
    return chosen


class _Proofs:
    """Expansions and certificates of a grasp's 7-contact subsets, each computed once."""

    def __init__(self, W: NDArray[np.float64], D: NDArray[np.float64]) -> None:
        self.W, self.D = W, D
        self._expansions: dict[tuple[int, ...], Any] = {}
        self._certificates: dict[tuple[Any, ...], Any] = {}

    def expansion(self, S: NDArray[np.int64]) -> Any:
        key = tuple(S.tolist())
        if key not in self._expansions:
            self._expansions[key] = expand(self.W[:, S], self.D[S])
        return self._expansions[key]

    def holds(self, S: NDArray[np.int64], shapes: list[NDArray[np.float64]], name: tuple
              ) -> Any:
        """The certificate of subset ``S`` over ``shapes``, named ``name`` (kind, size)."""
        key = (tuple(S.tolist()),) + name
        if key not in self._certificates:
            self._certificates[key] = certify(self.expansion(S), [shapes[i] for i in S],
                                              max_boxes=MAX_BOXES)
        return self._certificates[key]


def _certified(P: NDArray[np.float64], N: NDArray[np.float64], cs: list[_Contact],
               center: NDArray[np.float64], L: float, d0: float, seed: int
               ) -> ContactRegions | None:
    """Regions and tolerance proven by the cofactor certificate (frictionless contacts on
    planar pieces, edges and vertices). With more than 7 contacts, closure over the regions
    is proven by a 7-contact subset (:func:`_subsets`) and d* by a cover of such subsets (the
    sum of their null vectors). None when no 7-contact subset is closure by itself."""
    axes = np.stack([c.axes for c in cs])
    W, D = _wrenches(P, N, center, L, axes)
    kinds = tuple(c.kind for c in cs)
    subsets = _subsets(W, np.random.default_rng(seed))
    if not subsets:
        return None if len(P) > 7 else ContactRegions(_points(P), kinds, 0.0, "none",
                                                     max(d0, 0.0), 0.0, True)
    free = [c for c in cs if c.kind != "fixed"]
    if not free:
        return ContactRegions(_points(P), kinds, 0.0, "feature", d0, d0, True)
    proofs = _Proofs(W, D)
    reach = min(c.reach for c in cs)  # a contact at a vertex has nowhere to slide
    # first-order guess: the disc radius at which the best subset's linear part reaches zero
    e = proofs.expansion(subsets[0])
    gn = np.linalg.norm(e.g, axis=2).sum(axis=1)
    guess = float(np.min(e.c0 / np.where(gn > 0, gn, np.inf))) if gn.max() > 0 else L

    def discs(r: float) -> bool:
        shapes = [_shape(c, r, DISC_VERTICES, True) for c in cs]
        return any(proofs.holds(S, shapes, ("disc", r)).closure for S in subsets[:SUBSETS])

    def regions(r: float) -> bool:
        shapes = [_shape(c, r, REGION_VERTICES, False) for c in cs]
        return any(proofs.holds(S, shapes, ("region", r)).closure for S in subsets[:SUBSETS])

    tolerance = _grow(discs, 0.0, guess, reach)
    limited = "feature" if tolerance >= reach else "closure"
    top = max(float(np.linalg.norm(c.feature, axis=1).max()) for c in free)
    size = _grow(regions, tolerance, max(guess, tolerance * 1.5), top)
    shapes = [_shape(c, size, REGION_VERTICES, False) for c in cs]
    certs = [(S, proofs.holds(S, shapes, ("region", size))) for S in _cover(subsets, len(P))]
    return ContactRegions(_to3(P, cs, shapes), kinds, float(tolerance), limited, d0,
                          _cover_bound(certs, len(P)), True)


def _cover_bound(certs: list[tuple[NDArray[np.int64], Any]], k: int) -> float:
    """Certified lower bound of d* over the regions from the subsets proven on them: their
    null vectors (each scaled to largest entry 1, entries at least its d* bound on its
    contacts) add up to a null vector of the whole grasp, so d* >= min bound / the most
    subsets any contact is in; 0 unless the proven subsets cover every contact."""
    bounds, count = [], np.zeros(k, np.int64)
    for S, cert in certs:
        if cert.closure:
            bounds.append(cert.d_star_min)
            count[S] += 1
    if not bounds or count.min() == 0:
        return 0.0
    return min(bounds) / int(count.max())


def certify_regions(points: ArrayLike, normals: ArrayLike, polygons: list[ArrayLike],
                    center: ArrayLike, length: float, seed: int = 0
                    ) -> tuple[bool | None, float]:
    """Re-check stored regions (for example a grasp file's) with the certificate.

    Parameters
    ----------
    points, normals : (k, 3) float
        At least 7 contacts.
    polygons : list of (v_i, 3) float
        Each contact's region: corners in order, in the plane through the contact normal to
        its normal (a segment, or the point itself, for contacts on edges or vertices).
    center : (3,) float
        Any moment reference; length : float, any moment scale (the answer is the same).
    seed : int
        Choice of 7-contact subsets of more than 9 contacts.

    Returns
    -------
    closure : bool or None
        True when every choice of one point per region is form closure, False when a choice
        is not, None when undecided within the work limit (with more than 7 contacts: when
        no 7-contact subset proves closure).
    d_star_min : float
        Certified lower bound of d* over the regions.
    """
    P, N = check_contacts(points, normals, name="certify_regions")
    _seed(seed)
    k = len(P)
    if P.shape[1] != 3 or k < 7:
        raise InputError(f"certify_regions: expected at least 7 contacts in space, (k, 3) "
                         f"with k >= 7; got points of shape {P.shape}")
    sized = isinstance(polygons, (list, tuple, np.ndarray))
    if not sized or len(polygons) != k:
        raise InputError(f"certify_regions: polygons: expected a list of {k} regions (one per "
                         f"contact), got {type(polygons).__name__}"
                         + (f" of {len(polygons)}" if sized else ""))
    o = center_arg(center, name="certify_regions: center")
    length = length_arg(length, "certify_regions: length")
    axes = np.zeros((k, 2, 3))
    shapes = []
    for i, poly in enumerate(polygons):
        Q = xyz_rows(poly, f"certify_regions: polygons[{i}]") - P[i]
        if not len(Q):
            raise InputError(f"certify_regions: polygons[{i}] has no corners")
        # the region's own plane (its normal may differ from the contact's by up to the
        # coplanarity angle, as on the faces of real meshes): frame from its principal axes
        size = float(np.linalg.norm(Q, axis=1).max(initial=0.0))
        if len(Q) > 1 and size > 0:
            sv, span = np.linalg.svd(Q - Q.mean(axis=0), full_matrices=True)[1:]
            planar = len(sv) > 1 and sv[1] > 1e-12 * size
            axes[i] = [span[0], span[1] if planar else np.zeros(3)]
            if abs(span[0] @ N[i]) > np.sin(COPLANAR_ANGLE) or planar and abs(
                    span[1] @ N[i]) > np.sin(COPLANAR_ANGLE):
                raise InputError(f"certify_regions: region {i} does not lie square to its "
                                 f"contact's normal")
        xy = Q @ axes[i].T
        if np.linalg.norm(Q - xy @ axes[i], axis=1).max(initial=0.0) > 1e-9 * length:
            raise InputError(f"certify_regions: region {i} is not a flat polygon")
        if not _contains(xy, 1e-9 * length):
            raise InputError(f"certify_regions: region {i} does not contain its contact point")
        shapes.append(xy)
    W, D = _wrenches(P, N, o, length, axes)
    if k == 7:
        cert = certify(expand(W, D), shapes)
        return cert.closure, cert.d_star_min
    subsets = _subsets(W, np.random.default_rng(seed))
    certs = [(S, certify(expand(W[:, S], D[S]), [shapes[i] for i in S]))
             for S in _cover(subsets, k)]
    if not any(cert.closure for _, cert in certs):
        return None, 0.0
    return True, _cover_bound(certs, k)


def _seed(seed: object) -> None:
    """A seed for numpy's generator: an integer >= 0 (not a bool)."""
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed: expected an integer >= 0, got {seed!r}")


def _contains(poly: NDArray[np.float64], tol: float) -> bool:
    """Whether a convex polygon (its corners in order; or a segment, or a point) in the plane
    contains the origin, within ``tol``."""
    if len(poly) < 3:
        a, b = poly[0], poly[-1]
        t = np.clip(-a @ (b - a) / max(float((b - a) @ (b - a)), 1e-300), 0.0, 1.0)
        return bool(np.linalg.norm(a + t * (b - a)) <= tol)
    e = np.roll(poly, -1, axis=0) - poly
    cross = e[:, 0] * (-poly[:, 1]) - e[:, 1] * (-poly[:, 0])
    lengths = np.linalg.norm(e, axis=1)
    return bool((cross >= -tol * lengths).all() or (cross <= tol * lengths).all())


def _on_surface(part: Part, points: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Closest surface points, the mesh's inward normals there and the smooth reading's (the
    first contact where a point lands in a groove)."""
    c = part.resolve(points, snap=True)
    first = np.unique(c.finger, return_index=True)[1]
    return c.points[first], c.normals[first], c.smooth_normals[first]


def _sampled(part: Part, P: NDArray[np.float64], N: NDArray[np.float64],
             S: NDArray[np.float64], surface: str, cs: list[_Contact],
             center: NDArray[np.float64], L: float, mu: float, edges: int,
             d_star: float | None, seed: int) -> ContactRegions:
    """Tolerance by bisection on sampled placements; regions are the tolerance discs."""
    rng = np.random.default_rng(seed)
    k = len(P)
    kinds = tuple(c.kind for c in cs)
    tangent = np.stack([c.axes for c in cs])
    curved = np.array([c.kind == "curved" for c in cs])
    tangent[curved] = np.stack(tangent_basis(N[curved]), axis=1)

    def score(PP: NDArray[np.float64], NN: NDArray[np.float64], SS: NDArray[np.float64]
              ) -> NDArray[np.float64]:
        # numpy simplex: regions must not depend on whether numba is installed (as plans)
        res = surface_scores(PP, NN, SS, surface, center, L, mu, edges, compiled=False)
        return np.where(res.closure, res.d_star, -1.0)

    d0 = float(score(P[None], N[None], S[None])[0]) if d_star is None else float(d_star)
    if d0 <= 0:
        return ContactRegions(_points(P), kinds, 0.0, "none", max(d0, 0.0), 0.0, False)
    if all(c.kind == "fixed" for c in cs):
        return ContactRegions(_points(P), kinds, 0.0, "feature", d0, d0, False)
    reach = min(c.reach if c.kind != "curved" else L for c in cs)
    worst = {0.0: d0}

    def placements(r: float, n: int) -> tuple[NDArray[np.float64], ...]:
        rad = r * np.sqrt(rng.uniform(size=(n, k)))
        rad[: n // 2] = r  # half on the rim, where the extremes are
        ang = rng.uniform(0, 2 * np.pi, size=(n, k))
        xy = np.stack([rad * np.cos(ang), rad * np.sin(ang)], axis=2)
        PP = P + np.einsum("ska,kad->skd", xy, tangent)
        NN, SS = np.repeat(N[None], n, axis=0), np.repeat(S[None], n, axis=0)
        if curved.any():
            q, nrm, smo = _on_surface(part, PP[:, curved].reshape(-1, 3))
            PP[:, curved] = q.reshape(n, -1, 3)
            NN[:, curved] = nrm.reshape(n, -1, 3)
            SS[:, curved] = smo.reshape(n, -1, 3)
        return PP, NN, SS

    def holds(r: float) -> bool:
        # in chunks: a radius that fails usually fails in the first one
        worst[r] = d0
        for _ in range(SAMPLES // _CHUNK):
            d = score(*placements(r, _CHUNK))
            worst[r] = min(worst[r], float(d.min()))
            if worst[r] <= 0:
                return False
        return True

    tolerance = _grow(holds, 0.0, 0.01 * L, reach)
    shapes = [_shape(c, tolerance, REGION_VERTICES, False) if c.kind != "curved" else
              _ngon(tolerance, REGION_VERTICES, False) for c in cs]
    polys = list(_to3(P, cs, shapes))
    for i in np.flatnonzero(curved):
        polys[i] = _on_surface(part, P[i] + shapes[i] @ tangent[i])[0]
    d_min = worst.get(tolerance, d0)
    return ContactRegions(tuple(polys), kinds, float(tolerance),
                          "feature" if tolerance >= reach else "closure", d0,
                          max(min(d_min, d0), 0.0), False)
