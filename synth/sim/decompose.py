"""The part as MuJoCo can collide it: the planned part's own bodies as convex pieces.

MuJoCo collides a mesh geom as its convex hull, so a non-convex body collides where it is
not. The pieces come from the :class:`~synth.part.Part` the grasps were planned on, loaded,
welded and repaired by the same loader with the same options, never from the raw file (an OBJ
whose vertices are split along normal or texture seams is a set of open sheets until welded).
Each body of the part is used as it is when it is closed and convex (the pieces of a V-HACD or
CoACD collision mesh); a body the loader united from overlapping closed convex bodies of the
file is exactly their union, and those bodies are its pieces; any other body is decomposed into
convex pieces with CoACD (Wei et al.,
SIGGRAPH 2022, the ``coacd`` package). Decompositions are slow (about 1 s for a 44-face L
bracket, 16 s for a 384-face mug), so they are cached on disk under the hash of the body, the
CoACD settings and its version: in ``$SYNTH_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/synth``
(``~/.cache/synth``), in the folder ``coacd``.

A decomposition is reported with its error: the volume its pieces add to the closed bodies
they replace (their union's volume minus the bodies', over the bodies'), since a hull piece can
only cover more than the body does. A fingertip meets a piece where the piece is, so a coarse
decomposition moves contacts and turns their normals (measured on a robot link: CoACD's
default threshold added 8% of the volume and 9 of its 10 best grasps were pushed out by their
own squeeze; at 0.01, 0.5% and 9 of 10 held). So a body is decomposed at the thresholds
``COACD_THRESHOLDS`` in turn until its error is at most ``DECOMPOSITION_RTOL`` (an open body,
which has no volume to compare, gets CoACD's default only: decomposing an open body is slow,
measured up to minutes for a 2,000-face sheet). A piece with no volume (fewer than four vertices, or all of
them in one plane: a flat piece of an open sheet) cannot be a MuJoCo mesh and is left out and
counted; a part left with no piece at all raises :class:`~synth.errors.SimulationError`.
"""

from __future__ import annotations

import hashlib
import io
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from synth.errors import InputError, SimulationError

__all__ = ["ConvexPieces", "convex_pieces", "cache_dir", "COACD_THRESHOLDS",
           "DECOMPOSITION_RTOL", "FLAT_RTOL"]

#: CoACD's concavity thresholds tried in turn (its default first): lower values give more,
#: tighter pieces.
COACD_THRESHOLDS: tuple[float, ...] = (0.05, 0.02, 0.01)
#: The most volume a body's decomposition may add, over the body's volume, before a finer
#: threshold is tried.
DECOMPOSITION_RTOL: float = 0.01
#: A piece is flat when its hull's volume is below this fraction of its bounding box's.
FLAT_RTOL: float = 1e-6


@dataclass(frozen=True)
class ConvexPieces:
    """Convex pieces of one part, in the part's coordinates and units.

    Attributes
    ----------
    pieces : tuple of (m_i, 3) float
        Vertices of each piece (MuJoCo uses their convex hull).
    bodies : int
        Bodies of the part.
    decomposed : int
        Bodies that were not closed and convex and were decomposed with CoACD.
    error : float
        Volume the decomposition adds to the bodies it replaced, over their volume; 0 when no
        body was decomposed, NaN when a decomposed body is open (it has no volume).
    cached : bool
        Every decomposition came from the cache.
    flat : int
        Pieces left out for having no volume.
    inertia : (3, 3) float
        Inertia tensor of the part's closed bodies about ``center``, per unit density
        (units to the fifth); of the hull of all pieces when no body is closed.
    volume : float
        Volume that ``inertia`` belongs to.
    center : (3,) float
        Centre of mass of that volume.
    """

    pieces: tuple[NDArray[np.float64], ...] = field(repr=False)
    bodies: int
    decomposed: int
    error: float
    cached: bool
    flat: int
    inertia: NDArray[np.float64] = field(repr=False)
    volume: float
    center: NDArray[np.float64] = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no vertices)."""
        return {"pieces": len(self.pieces), "bodies": self.bodies,
                "decomposed": self.decomposed,
                "decomposition_error": None if self.error != self.error else self.error,
                "flat_pieces_dropped": self.flat}


def cache_dir() -> Path:
    """The folder of cached decompositions: ``$SYNTH_CACHE_DIR/coacd``, else
    ``$XDG_CACHE_HOME/synth/coacd`` (``~/.cache/synth/coacd``)."""
    root = os.environ.get("SYNTH_CACHE_DIR")
    if not root:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        root = str(Path(base) / "synth")
    return Path(root) / "coacd"


def _key(mesh: trimesh.Trimesh, threshold: float, seed: int) -> str:
    import coacd

    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype="<i8").tobytes())
    version = getattr(coacd, "__version__", "")
    h.update(f"coacd {version} threshold {threshold!r} seed {seed}".encode())
    return h.hexdigest()


def _decompose(mesh: trimesh.Trimesh, threshold: float, seed: int, cache: Path | None
               ) -> tuple[list[NDArray[np.float64]], bool]:
    """CoACD pieces of one body (vertices of each), and whether they came from the cache."""
    file = None if cache is None else cache / f"{_key(mesh, threshold, seed)}.npz"
    if file is not None and file.exists():
        try:
            with np.load(file) as z:
                return [z[f"v{i}"] for i in range(int(z["n"]))], True
        except (OSError, ValueError, KeyError):
            pass  # a damaged entry is computed again and overwritten
    import coacd

    coacd.set_log_level("error")
    try:
        parts = coacd.run_coacd(coacd.Mesh(np.asarray(mesh.vertices, float),
                                           np.asarray(mesh.faces, np.int64)),
                                threshold=threshold, seed=seed)
    except Exception as e:  # noqa: BLE001 - CoACD raises several kinds
        raise SimulationError(f"CoACD could not decompose a body of {len(mesh.faces)} faces "
                              f"({type(e).__name__}: {e})") from e
    pieces = [np.asarray(v, float) for v, _ in parts]
    if file is not None:
        from synth.files import write_atomic

        buf = io.BytesIO()
        np.savez(buf, n=len(pieces), **{f"v{i}": v for i, v in enumerate(pieces)})
        try:
            file.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(file, buf.getvalue())
        except Exception:  # noqa: BLE001 - an unwritable cache only costs time
            pass
    return pieces, False


def _excess(mesh: trimesh.Trimesh, pieces: list[NDArray[np.float64]]) -> float:
    """Volume the pieces add to a closed body, over its volume (NaN for an open body)."""
    if not (mesh.is_watertight and mesh.volume > 0):
        return float("nan")
    union = _union_volume([v for v in pieces if _solid(v)])
    return max(0.0, union - float(mesh.volume)) / float(mesh.volume)


def _fine_enough(mesh: trimesh.Trimesh, thresholds: tuple[float, ...], seed: int,
                 cache: Path | None) -> tuple[list[NDArray[np.float64]], bool]:
    """A body's pieces at the first threshold whose error is at most ``DECOMPOSITION_RTOL``
    (the first for an open body, whose error cannot be measured: CoACD makes it closed first,
    slowly), and whether every decomposition tried was cached."""
    cached_all = True
    closed = bool(mesh.is_watertight and mesh.volume > 0)
    for i, t in enumerate(thresholds if closed else thresholds[:1]):
        got, cached = _decompose(mesh, t, seed, cache)
        cached_all &= cached
        if not closed or i == len(thresholds) - 1 or _excess(mesh, got) <= DECOMPOSITION_RTOL:
            return got, cached_all
    raise AssertionError("unreachable")  # the loop returns at its last threshold


def _own_pieces(part: Any, body: Any) -> list[NDArray[np.float64]] | None:
    """The closed convex bodies of the file that a united body is the union of (None when
    it is not such a union)."""
    if part.face_source is None or not part.convex_inputs:
        return None
    sources = np.unique(part.face_source[body.faces])
    if len(sources) < 2 or not all(int(k) in part.convex_inputs for k in sources):
        return None
    return [part.convex_inputs[int(k)] for k in sources]


def _solid(v: NDArray[np.float64]) -> bool:
    """Whether a piece's hull has a volume MuJoCo can load."""
    if len(v) < 4:
        return False
    extent = np.ptp(v, axis=0)
    if not np.all(extent > 0):
        return False
    try:
        from scipy.spatial import ConvexHull

        return bool(ConvexHull(v).volume > FLAT_RTOL * float(np.prod(extent)))
    except Exception:  # noqa: BLE001 - qhull refuses degenerate input
        return False


def _union_volume(pieces: list[NDArray[np.float64]]) -> float:
    hulls = [trimesh.convex.convex_hull(v) for v in pieces]
    if not hulls:
        return 0.0
    if len(hulls) == 1:
        return float(hulls[0].volume)
    return float(trimesh.boolean.union(hulls, engine="manifold").volume)


def _mass_properties(bodies: list[trimesh.Trimesh], pieces: list[NDArray[np.float64]]
                     ) -> tuple[NDArray[np.float64], float, NDArray[np.float64]]:
    closed = [b for b in bodies if b.is_watertight and b.volume > 0]
    if not closed:
        closed = [trimesh.convex.convex_hull(np.concatenate(pieces))]
    volume = float(sum(b.volume for b in closed))
    center = sum(b.volume * np.asarray(b.center_mass) for b in closed) / volume
    inertia = np.zeros((3, 3))
    for b in closed:
        d = np.asarray(b.center_mass) - center
        inertia += np.asarray(b.moment_inertia) + b.volume * (np.dot(d, d) * np.eye(3)
                                                              - np.outer(d, d))
    return inertia, volume, np.asarray(center, float)


def convex_pieces(part: Any, *, seed: int = 0,
                  thresholds: tuple[float, ...] = COACD_THRESHOLDS,
                  cache: Path | None | bool = True) -> ConvexPieces:
    """The convex pieces of a planned part, each body as it is or decomposed.

    Parameters
    ----------
    part : synth.Part
        The part the grasps were planned on (:func:`synth.load_part`).
    seed : int
        CoACD's random seed.
    thresholds : tuple of float
        CoACD's concavity thresholds, each in (0, 1], tried in turn (module notes).
    cache : pathlib.Path, True or None
        Folder of cached decompositions; True for :func:`cache_dir`, None for no cache.

    Returns
    -------
    ConvexPieces

    Raises
    ------
    SimulationError
        CoACD failed, or no piece with a volume is left.

    Examples
    --------
    >>> p = convex_pieces(load_part("meshes/cube.stl", "dm"))  # doctest: +SKIP
    >>> len(p.pieces), p.decomposed
    (1, 0)
    """
    if not thresholds or not all(0 < t <= 1 for t in thresholds):
        raise InputError(f"thresholds: expected numbers in (0, 1], got {thresholds!r}")
    folder = cache_dir() if cache is True else (cache or None)
    with np.errstate(divide="ignore", invalid="ignore"):  # trimesh on open bodies' volume
        meshes = [part.mesh.submesh([b.faces], append=True) for b in part.bodies]
        pieces: list[NDArray[np.float64]] = []
        decomposed: list[tuple[trimesh.Trimesh, list[NDArray[np.float64]]]] = []
        all_cached = True
        flat = 0
        for b, m in zip(part.bodies, meshes, strict=True):
            own = _own_pieces(part, b)
            if b.convex:
                got = [np.asarray(m.vertices, float)]
            elif own is not None:
                got = own
            else:
                got, cached = _fine_enough(m, thresholds, seed, folder)
                all_cached &= cached
                decomposed.append((m, got))
            solid = [v for v in got if _solid(v)]
            flat += len(got) - len(solid)
            pieces.extend(solid)
        if not pieces:
            raise SimulationError(f"no piece of the part has a volume ({flat} flat pieces): "
                                  "MuJoCo cannot collide it")
        error = 0.0
        if decomposed:
            if all(m.is_watertight and m.volume > 0 for m, _ in decomposed):
                body_volume = sum(float(m.volume) for m, _ in decomposed)
                excess = sum(_excess(m, got) * float(m.volume) for m, got in decomposed)
                error = excess / body_volume
            else:
                error = float("nan")
        inertia, volume, center = _mass_properties(meshes, pieces)
    return ConvexPieces(tuple(pieces), len(part.bodies), len(decomposed), float(error),
                        all_cached and bool(decomposed), flat, inertia, volume, center)
