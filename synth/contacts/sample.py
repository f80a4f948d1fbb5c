"""Reproducible sampling of contacts on a part's surface, edges and corners."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from synth.contacts.contacts import Contacts
from synth.errors import InputError

#: Most contacts one call samples (10 million: about 1 GB of points, normals and labels).
MAX_SAMPLES = 10_000_000

if TYPE_CHECKING:
    from synth.part.model import Part

__all__ = ["SAMPLE_METHODS", "sample_contacts"]

#: Sampling methods of :func:`sample_contacts`.
SAMPLE_METHODS: tuple[str, ...] = ("uniform", "even", "regions", "edges", "corners")

_EVEN_OVERSAMPLE = 8
_MAX_ROUNDS = 20


def _faces_points(part: Part, rng: np.random.Generator, n: int, faces: np.ndarray,
                  by_region: bool = False) -> tuple[np.ndarray, np.ndarray]:
    area = np.asarray(part.mesh.area_faces, float)[faces] * (part.face_exposure[faces] > 0)
    if area.sum() <= 0:
        raise InputError("sample_contacts: the chosen faces have no exposed area")
    if by_region:  # every region with exposed area weighs 1, split by area among its faces
        reg = part.face_region[faces]
        total = np.bincount(reg, weights=area)[reg]
        area = np.divide(area, total, out=np.zeros_like(area), where=total > 0)
    f = faces[rng.choice(len(faces), size=n, p=area / area.sum())]
    u = rng.random((n, 2))
    flip = u.sum(axis=1) > 1.0
    u[flip] = 1.0 - u[flip]
    tri = part._corners(f)
    pts = tri[:, 0] + u[:, :1] * (tri[:, 1] - tri[:, 0]) + u[:, 1:] * (tri[:, 2] - tri[:, 0])
    return pts, f


def _exposed_points(part: Part, pts: np.ndarray, faces: np.ndarray) -> tuple[Contacts, np.ndarray]:
    """Resolve points on known faces; which of them a fingertip can touch (every contact
    of the point on the exposed surface)."""
    c = part.resolve(pts, faces)
    toward = np.zeros((len(pts), 3))
    np.add.at(toward, c.finger, c.normals)  # a shared fingertip: the sum of its normals
    return c, part.exposed(pts, toward)


def _draw(part: Part, rng: np.random.Generator, n: int, faces: np.ndarray,
          by_region: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """``n`` area-uniform points of the exposed surface of ``faces`` (rejection sampling;
    fewer only when almost nothing of those faces is exposed); with ``by_region``, each face
    region is equally likely and the points are area-uniform within it."""
    pts, fs = np.zeros((0, 3)), np.zeros(0, np.int64)
    for _ in range(_MAX_ROUNDS):
        need = n - len(pts)
        if need <= 0:
            break
        p, f = _faces_points(part, rng, max(need, 16) * (1 if part._solids is None else 2), faces,
                             by_region)
        _, good = _exposed_points(part, p, f)
        pts, fs = np.concatenate([pts, p[good]]), np.concatenate([fs, f[good]])
    return pts[:n], fs[:n]


def _farthest(points: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of ``n`` points chosen by farthest-point sampling (greedy max-min)."""
    chosen = np.empty(n, np.int64)
    chosen[0] = rng.integers(len(points))
    d = np.linalg.norm(points - points[chosen[0]], axis=1)
    for i in range(1, n):
        chosen[i] = int(np.argmax(d))
        d = np.minimum(d, np.linalg.norm(points - points[chosen[i]], axis=1))
    return chosen


def sample_contacts(
    part: Part,
    n: int,
    seed: int | np.random.Generator | None = None,
    method: str = "uniform",
    regions: Sequence[int] | np.ndarray | None = None,
) -> Contacts:
    """Sample fingertip placements on a part and resolve them into contacts.

    Parameters
    ----------
    part : Part
    n : int
        Number of fingertip placements. Each gives one contact, except on concave edges
        and in concave corners (2 or 3 contacts sharing a ``finger`` id), so
        ``contacts.n_fingers == n`` and ``len(contacts) >= n``. Only the exposed surface is
        sampled (:meth:`synth.part.Part.exposed`); where almost nothing of the chosen faces
        or edges is exposed, fewer placements may come back.
    seed : int or numpy.random.Generator, optional
        Seed of ``np.random.default_rng``; the same seed gives the same contacts.
    method : {"uniform", "even", "regions", "edges", "corners"}
        ``"uniform"``: area-uniform on the surface. ``"even"``: an even spread
        (farthest-point subset of 8 n area-uniform samples). ``"regions"``: every face region
        (planar facet or curved patch) with exposed area equally likely, area-uniform within
        it, so that small facets, whose distinct normals matter to closure as much as large
        ones, are not drowned by area. ``"edges"``: uniform along
        the sharp (convex and concave) edges, by length. ``"corners"``: corner and saddle
        vertices, without replacement while there are enough, with replacement beyond.
    regions : sequence of int, optional
        Restrict ``"uniform"``, ``"even"`` and ``"regions"`` to these face regions.

    Returns
    -------
    Contacts

    Examples
    --------
    >>> c = sample_contacts(part, 100, seed=0, method="even")  # doctest: +SKIP
    """
    if not hasattr(part, "mesh") or not hasattr(part, "resolve"):
        raise InputError(f"part: expected a synth.Part (see synth.load_part), got "
                         f"{type(part).__name__}")
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or not 0 <= n <= MAX_SAMPLES:
        raise InputError(f"n: expected a count from 0 to {MAX_SAMPLES:,}, got {n!r}")
    n = int(n)
    if method not in SAMPLE_METHODS:
        raise InputError(f"method: expected one of {SAMPLE_METHODS}, got {method!r}")
    try:
        rng = np.random.default_rng(seed)
    except (TypeError, ValueError) as err:
        raise InputError(f"seed: expected a non-negative integer, a numpy Generator or None, "
                         f"got {seed!r}") from err
    if method in ("uniform", "even", "regions"):
        if regions is None:
            faces = np.arange(len(part.mesh.faces))
        else:
            r = np.atleast_1d(np.asarray(regions, np.int64))
            if len(r) == 0 or r.min() < 0 or r.max() >= len(part.regions):
                raise InputError(
                    f"regions: expected ids in [0, {len(part.regions)}), got {r.tolist()}"
                )
            faces = np.flatnonzero(np.isin(part.face_region, r))
        if method in ("uniform", "regions"):
            pts, f = _draw(part, rng, n, faces, method == "regions")
        else:
            pts, f = _draw(part, rng, max(n, 1) * _EVEN_OVERSAMPLE, faces)
            keep = _farthest(pts, min(n, len(pts)), rng) if n else np.zeros(0, np.int64)
            pts, f = pts[keep], f[keep]
        return part.resolve(pts, f)
    if regions is not None:
        raise InputError(f"regions: only used by 'uniform', 'even' and 'regions', not "
                         f"{method!r}")
    feats = part.features
    if method == "edges":
        e = feats.sharp_edges
        if len(e) == 0:
            raise InputError("sample_contacts: the part has no sharp edges (method='edges')")
        length = feats.edge_length[e]
        v = np.asarray(part.mesh.vertices, float)
        pts, fs = np.zeros((0, 3)), np.zeros(0, np.int64)
        for _ in range(_MAX_ROUNDS):
            if len(pts) >= n:
                break
            pick = e[rng.choice(len(e), size=max(n, 16), p=length / length.sum())]
            t = rng.random(len(pick))[:, None]
            a, b = v[feats.edges[pick, 0]], v[feats.edges[pick, 1]]
            p, f = a + t * (b - a), feats.edge_faces[pick, 0]
            _, good = _exposed_points(part, p, f)
            pts, fs = np.concatenate([pts, p[good]]), np.concatenate([fs, f[good]])
        return part.resolve(pts[:n], fs[:n])
    corners = np.flatnonzero(feats.vertex_kind >= 2)
    corners = corners[feats.vertex_kind[corners] <= 4]
    if len(corners) == 0:
        raise InputError("sample_contacts: the part has no corners (method='corners')")
    vf = np.asarray(part.mesh.vertex_faces)[corners, 0]
    _, good = _exposed_points(part, np.asarray(part.mesh.vertices, float)[corners], vf)
    corners, vf = corners[good], vf[good]
    if len(corners) == 0:
        raise InputError("sample_contacts: no corner of the part is exposed (method='corners')")
    pick = rng.choice(len(corners), size=n, replace=n > len(corners))
    return part.resolve(np.asarray(part.mesh.vertices, float)[corners[pick]], vf[pick])
