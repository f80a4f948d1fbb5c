"""The part as MuJoCo can collide it: the mesh file's own bodies as convex pieces.

MuJoCo collides a mesh geom as its convex hull, so a non-convex body collides where it is
not. Each connected body of the file is used as it is when it is closed and convex (the
pieces of a V-HACD or CoACD collision mesh); any other body is decomposed into convex pieces
with CoACD (Wei et al., SIGGRAPH 2022, the ``coacd`` package). Decompositions are slow (0.8 s
for a 44-face L bracket, 16 s for a 384-face mug), so they are cached on disk under the hash
of the body, the CoACD settings and its version: in ``$SYNTH_CACHE_DIR`` if set, else
``$XDG_CACHE_HOME/synth`` (``~/.cache/synth``), in the folder ``coacd``.

A decomposition is reported with its error: the volume its pieces add to the bodies they
replace (their union's volume minus the bodies', over the bodies'), since a hull piece can
only cover more than the body does.

Only the object the grasp touches is kept: bodies are grouped into objects as the loader
groups them (:func:`synth.part.compound.group_bodies`), and the group nearest to the contact
points wins.
"""

from __future__ import annotations

import hashlib
import io
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from synth.errors import InputError, MeshError

__all__ = ["ConvexPieces", "convex_pieces", "cache_dir", "COACD_THRESHOLD"]

#: CoACD's concavity threshold (its default): lower values give more, tighter pieces.
COACD_THRESHOLD: float = 0.05


@dataclass(frozen=True)
class ConvexPieces:
    """Convex pieces of one part, in the mesh file's coordinates and units.

    Attributes
    ----------
    pieces : tuple of (m_i, 3) float
        Vertices of each piece (MuJoCo uses their convex hull).
    bodies : int
        Bodies of the file that make up the part.
    decomposed : int
        Bodies that were not closed and convex and were decomposed with CoACD.
    error : float
        Volume the decomposition adds to the bodies it replaced, over their volume; 0 when no
        body was decomposed, NaN when a decomposed body is open (it has no volume).
    cached : bool
        Every decomposition came from the cache.
    inertia : (3, 3) float
        Inertia tensor of the part's closed bodies about ``center``, per unit density
        (mesh units to the fifth); of the hull of all pieces when no body is closed.
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
    inertia: NDArray[np.float64] = field(repr=False)
    volume: float
    center: NDArray[np.float64] = field(repr=False)


def cache_dir() -> Path:
    """The folder of cached decompositions: ``$SYNTH_CACHE_DIR/coacd``, else
    ``$XDG_CACHE_HOME/synth/coacd`` (``~/.cache/synth/coacd``)."""
    root = os.environ.get("SYNTH_CACHE_DIR")
    if not root:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        root = str(Path(base) / "synth")
    return Path(root) / "coacd"


def _bodies(path: Path) -> list[trimesh.Trimesh]:
    """Every connected body of every mesh in the file."""
    ext = path.suffix.lower().lstrip(".")
    # OBJ: one body per object, never welded to another (as synth's loader reads it)
    extra = {"split_objects": True, "group_material": False} if ext == "obj" else {}
    try:
        loaded = trimesh.load(str(path), **extra)
    except Exception as e:  # trimesh raises many kinds on a bad file
        raise MeshError(f"{path}: cannot be read as a mesh ({type(e).__name__}: {e})") from e
    meshes = (loaded.dump(concatenate=False) if isinstance(loaded, trimesh.Scene)
              else [loaded])
    out = []
    for m in meshes:
        if not isinstance(m, trimesh.Trimesh) or len(m.faces) == 0:
            continue
        out.extend(c for c in m.split(only_watertight=False) if len(c.faces) >= 1)
    if not out:
        raise MeshError(f"{path}: no triangles")
    return out


def _choose(bodies: list[trimesh.Trimesh], points: NDArray[np.float64]) -> list[int]:
    """The bodies of the object nearest to the contact points."""
    from synth.part.compound import group_bodies
    from synth.part.tolerances import GROUP_GAP_RTOL

    if len(bodies) == 1:
        return [0]
    groups, _ = group_bodies(bodies, [bool(b.is_watertight) for b in bodies], GROUP_GAP_RTOL)
    if len(groups) == 1:
        return groups[0]
    lo = np.array([b.bounds[0] for b in bodies])
    hi = np.array([b.bounds[1] for b in bodies])
    # distance from each point to each body's box; a group's distance is its nearest body's
    gap = np.linalg.norm(np.maximum(0, np.maximum(lo[None] - points[:, None],
                                                   points[:, None] - hi[None])), axis=2)
    score = [float(gap[:, g].min(axis=1).sum()) for g in groups]
    return groups[int(np.argmin(score))]


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
    parts = coacd.run_coacd(coacd.Mesh(np.asarray(mesh.vertices, float),
                                       np.asarray(mesh.faces, np.int64)),
                            threshold=threshold, seed=seed)
    pieces = [np.asarray(v, float) for v, _ in parts]
    if file is not None:
        from synth.files import write_atomic

        buf = io.BytesIO()
        np.savez(buf, n=len(pieces), **{f"v{i}": v for i, v in enumerate(pieces)})
        try:
            file.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(file, buf.getvalue())
        except Exception:  # an unwritable cache only costs time
            pass
    return pieces, False


def _union_volume(pieces: list[NDArray[np.float64]]) -> float:
    hulls = [trimesh.convex.convex_hull(v) for v in pieces if len(v) >= 4]
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


def convex_pieces(path: str | os.PathLike[str], points: ArrayLike, *, seed: int = 0,
                  threshold: float = COACD_THRESHOLD, cache: Path | None | bool = True
                  ) -> ConvexPieces:
    """The convex pieces of the object of a mesh file that a grasp touches.

    Parameters
    ----------
    path : path
        The mesh file (any format trimesh reads).
    points : (k, 3) float
        Contact points of a grasp of the part, to pick the object in a file of several.
    seed : int
        CoACD's random seed.
    threshold : float
        CoACD's concavity threshold, in (0, 1].
    cache : pathlib.Path, True or None
        Folder of cached decompositions; True for :func:`cache_dir`, None for no cache.

    Returns
    -------
    ConvexPieces

    Raises
    ------
    MeshError
        The file cannot be read or holds no triangles.

    Examples
    --------
    >>> p = convex_pieces("meshes/cube.stl", [[0.5, 0, 0]])  # doctest: +SKIP
    >>> len(p.pieces), p.decomposed
    (1, 0)
    """
    if not 0 < threshold <= 1:
        raise InputError(f"threshold: expected a number in (0, 1], got {threshold!r}")
    with np.errstate(divide="ignore", invalid="ignore"):  # trimesh on open bodies' volume
        return _convex_pieces(Path(path), points, seed, threshold,
                              cache_dir() if cache is True else (cache or None))


def _convex_pieces(p: Path, points: ArrayLike, seed: int, threshold: float,
                   folder: Path | None) -> ConvexPieces:
    if not p.is_file():
        raise MeshError(f"{p}: no such file")
    bodies = _bodies(p)
    pts = np.asarray(points, float).reshape(-1, 3)
    chosen = [bodies[i] for i in _choose(bodies, pts)]
    pieces: list[NDArray[np.float64]] = []
    decomposed: list[tuple[trimesh.Trimesh, list[NDArray[np.float64]]]] = []
    all_cached = True
    for b in chosen:
        if b.is_watertight and b.is_convex:
            pieces.append(np.asarray(b.vertices, float))
            continue
        parts, cached = _decompose(b, threshold, seed, folder)
        all_cached &= cached
        pieces.extend(parts)
        decomposed.append((b, parts))
    error = 0.0
    if decomposed:
        if all(b.is_watertight and b.volume > 0 for b, _ in decomposed):
            body_volume = sum(float(b.volume) for b, _ in decomposed)
            union = _union_volume([v for _, parts in decomposed for v in parts])
            error = max(0.0, union - body_volume) / body_volume
        else:
            error = float("nan")
    inertia, volume, center = _mass_properties(chosen, pieces)
    return ConvexPieces(tuple(pieces), len(chosen), len(decomposed), float(error),
                        all_cached and bool(decomposed), inertia, volume, center)
