"""The native libraries' meshes: what FCL and manifold3d require, checked before they get one,
and the manifold3d steps that run in the child process of :mod:`synth.isolate`.

FCL and manifold3d trust their input. A face index past the last vertex makes both read
memory that is not theirs (a segmentation fault, or worse, a wrong answer), an empty model
makes FCL's BVH crash, and NaN coordinates make its bounding volumes meaningless. So every
array is checked here first (:func:`mesh_problem`). manifold3d's merge of open edges also
crashed on a valid mesh (a robot's visual mesh of 2,215 open pieces), so every manifold3d
call of the loader runs in the child process: :func:`merge_close`, :func:`overlap_volumes`
and :func:`unite`, called through :func:`synth.isolate.call_isolated`. They take and return
plain arrays (they are pickled), and import nothing of synth beyond this module.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from synth.errors import InternalError

__all__ = ["mesh_problem", "bvh_model", "merge_close", "overlap_volumes", "unite"]

#: Most vertices or faces a mesh handed to FCL may have (it indexes them with 32-bit ints).
_MAX_INDEX = 2**31 - 1


def mesh_problem(vertices: Any, faces: Any) -> str | None:
    """What FCL or manifold3d would not accept in a mesh, in words; None if nothing.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int

    Returns
    -------
    str or None
        The first problem found: wrong shapes, no face, a non-finite coordinate, a face
        index out of range, more vertices or faces than 32-bit indices reach.

    Examples
    --------
    >>> mesh_problem(np.zeros((3, 3)), [[0, 1, 3]])
    'face 0 refers to vertex 3, but there are 3 vertices'
    """
    v = np.asarray(vertices)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or not np.issubdtype(v.dtype, np.number):
        return f"vertices: expected an (n, 3) array of numbers, got shape {v.shape}"
    if f.ndim != 2 or f.shape[1] != 3 or not (len(f) == 0 or np.issubdtype(f.dtype, np.integer)):
        return f"faces: expected an (m, 3) array of integers, got shape {f.shape}"
    if len(f) == 0:
        return "no faces"
    if max(len(v), len(f)) > _MAX_INDEX:
        return f"{len(v)} vertices and {len(f)} faces: more than 32-bit indices reach"
    if not np.isfinite(v).all():
        return (f"{int((~np.isfinite(v).all(axis=1)).sum())} vertices have NaN or infinite "
                "coordinates")
    bad = np.flatnonzero(((f < 0) | (f >= len(v))).any(axis=1))
    if len(bad):
        row = f[bad[0]]
        index = int(row[(row < 0) | (row >= len(v))][0])
        return f"face {int(bad[0])} refers to vertex {index}, but there are {len(v)} vertices"
    return None


def bvh_model(vertices: Any, faces: Any) -> Any:
    """An FCL ``BVHModel`` of a mesh checked by :func:`mesh_problem`.

    Raises
    ------
    InternalError
        The mesh has a problem: synth hands FCL only meshes it has checked (callers that
        take meshes from users check them first and raise ``InputError``).
    """
    import fcl

    problem = mesh_problem(vertices, faces)
    if problem is not None:
        raise InternalError(f"a mesh handed to FCL: {problem}")
    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(faces))
    model.addSubModel(np.ascontiguousarray(vertices, np.float64),
                      np.ascontiguousarray(faces, np.int32))
    model.endModel()
    return model


def _manifold(vertices: np.ndarray, faces: np.ndarray, merge: bool = False) -> Any:
    """A manifold3d ``Manifold`` (None when manifold3d refuses the mesh)."""
    import manifold3d as mf

    if mesh_problem(vertices, faces) is not None:
        return None
    try:
        mesh = mf.Mesh64(vert_properties=np.ascontiguousarray(vertices, np.float64),
                         tri_verts=np.ascontiguousarray(faces, np.uint64))
        if merge:
            mesh.merge()
        solid = mf.Manifold(mesh)
    except Exception:  # noqa: BLE001 - manifold3d refuses some meshes by raising
        return None
    return solid if solid.status() == mf.Error.NoError and not solid.is_empty() else None


def _arrays(mesh: Any) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) and faces (m, 3) of a manifold3d ``Mesh64``."""
    return (np.asarray(mesh.vert_properties, np.float64)[:, :3].copy(),
            np.asarray(mesh.tri_verts, np.int64).copy())


def merge_close(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """manifold3d's merge of nearly coincident open edges, and the solid it makes.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int

    Returns
    -------
    (vertices, faces) of the closed mesh, or None when manifold3d cannot make a solid of it.
    """
    solid = _manifold(vertices, faces, merge=True)
    return None if solid is None else _arrays(solid.to_mesh64())


def overlap_volumes(bodies: list[tuple[np.ndarray, np.ndarray]], pairs: list[tuple[int, int]]
                    ) -> list[float]:
    """Volume common to each pair of closed bodies (0 where manifold3d refuses one).

    Parameters
    ----------
    bodies : list of ((n, 3) float, (m, 3) int)
        Closed bodies, best placed around the origin (manifold3d works in float64, but its
        tolerances follow the coordinates' magnitude).
    pairs : list of (int, int)
        Indices into ``bodies``.

    Returns
    -------
    list of float
        One volume per pair.
    """
    solids: dict[int, Any] = {}

    def solid(i: int) -> Any:
        if i not in solids:
            solids[i] = _manifold(*bodies[i])
        return solids[i]

    out = []
    for i, j in pairs:
        a, b = solid(i), solid(j)
        out.append(0.0 if a is None or b is None else float((a ^ b).volume()))
    return out


def unite(bodies: list[tuple[np.ndarray, np.ndarray]]
          ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None:
    """The union of closed bodies, as the pieces it falls into.

    Parameters
    ----------
    bodies : list of ((n, 3) float, (m, 3) int)

    Returns
    -------
    list of (vertices, faces, source) or None
        One entry per connected piece of the union; ``source`` (f,) int gives the body each
        face lies on. None when manifold3d refuses a body or fails.
    """
    import manifold3d as mf

    solids = [_manifold(*b) for b in bodies]
    if any(s is None for s in solids):
        return None
    inputs = [s.as_original() for s in solids]
    origin = {m.original_id(): k for k, m in enumerate(inputs)}
    union = mf.Manifold.batch_boolean(inputs, mf.OpType.Add)
    if union.status() != mf.Error.NoError:
        return None
    out = []
    for piece in union.decompose():
        mesh = piece.to_mesh64()
        runs = np.asarray(mesh.run_index, np.int64) // 3
        src = np.repeat([origin.get(int(r), 0) for r in mesh.run_original_id], np.diff(runs))
        out.append((*_arrays(mesh), src.astype(np.int64)))
    return out or None
