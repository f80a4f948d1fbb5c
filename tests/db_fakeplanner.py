"""A small, real, deterministic planner for the database tests, used through ``SYNTH_DB_PLANNER``.

``SYNTH_DB_PLANNER=tests.db_fakeplanner:plan_mesh_file`` (with the repository on ``PYTHONPATH``)
makes ``synth db build`` use it. It loads the mesh with trimesh, refuses files that are not a closed
surface, samples ``evals`` sets of ``contacts`` surface points with ``default_rng(seed)``, scores
each with d* from the null space of the frictionless wrench matrix (exact when the null space
has dimension one, i.e. 7 contacts of full rank; the last right-singular vector otherwise), and
returns the ``top`` best in the planner's JSON format (version 1). ``mu`` is recorded but not used
(``epsilon`` is 0). It exists so the database can be tested before, and independently of, the
synth planner; it is not that planner.

``SYNTH_FAKEPLANNER_DELAY`` (seconds) adds a sleep per mesh so tests can interrupt a run;
``SYNTH_FAKEPLANNER_PIDS`` (a folder) makes every process that plans a mesh leave an empty file
named by its pid there, so tests know the worker processes.
"""

from __future__ import annotations

import hashlib
import os
import time
from typing import Any

import numpy as np
import trimesh

from synth.errors import MeshError

__all__ = ["plan_mesh_file"]

_RANK_TOL = 1e-9


def _load(path: str) -> trimesh.Trimesh:
    try:
        mesh = trimesh.load(path, force="mesh", process=True)
    except Exception as e:  # noqa: BLE001 - trimesh raises many kinds
        raise MeshError(f"{path}: cannot read mesh: {type(e).__name__}: {e}") from e
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise MeshError(f"{path}: no triangles in the file")
    if not mesh.is_watertight:
        raise MeshError(f"{path}: not a solid (the surface is not closed)")
    return mesh


def plan_mesh_file(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Plan grasps on a mesh file by seeded random sampling (see the module docstring).

    Parameters
    ----------
    path : str
        Mesh file.
    params : dict
        ``contacts``, ``mu``, ``top``, ``seed``, ``finger_radius``, ``evals``.

    Returns
    -------
    dict
        The planner's JSON document, format ``synth.grasps`` version 1.
    """
    t0 = time.perf_counter()
    pids = os.environ.get("SYNTH_FAKEPLANNER_PIDS")
    if pids:
        open(os.path.join(pids, str(os.getpid())), "a").close()
    delay = float(os.environ.get("SYNTH_FAKEPLANNER_DELAY", "0") or 0)
    if delay:
        time.sleep(delay)
    k, evals, top = int(params["contacts"]), int(params["evals"]), int(params["top"])
    mesh = _load(path)
    rng = np.random.default_rng(int(params["seed"]))
    length = float(np.max(mesh.extents))
    center = mesh.bounds.mean(axis=0)
    areas = mesh.area_faces / mesh.area
    faces = rng.choice(len(areas), size=(evals, k), p=areas)
    uv = rng.random((evals, k, 2))
    flip = uv.sum(axis=2) > 1.0
    uv[flip] = 1.0 - uv[flip]
    tri = mesh.triangles[faces]  # (evals, k, 3, 3)
    points = (
        tri[:, :, 0] * (1.0 - uv[..., :1] - uv[..., 1:])
        + tri[:, :, 1] * uv[..., :1]
        + tri[:, :, 2] * uv[..., 1:]
    )
    normals = -mesh.face_normals[faces]  # inward: the direction a contact pushes
    torques = np.cross(points - center, normals) / length
    wrench = np.concatenate([normals, torques], axis=2).transpose(0, 2, 1)  # (evals, 6, k)
    _, s, vt = np.linalg.svd(wrench)
    rank = (s > _RANK_TOL * s[:, :1]).sum(axis=1)
    null = vt[:, -1, :]
    scale = np.abs(null).max(axis=1)
    d_star = np.maximum(null.min(axis=1), (-null).min(axis=1)) / scale
    d_star = np.where((rank == 6) & (k > 6), d_star, 0.0)
    conditioning = s[:, -1] / s[:, 0]
    order = np.lexsort((-conditioning, -d_star))
    chosen = [int(i) for i in order[:top] if d_star[i] > 0.0]
    radius = float(params["finger_radius"] or 0.05 * length)
    grasps = []
    for i in chosen:
        tips = points[i] - normals[i] * radius
        grasps.append(
            {
                "points": points[i].tolist(),
                "normals": normals[i].tolist(),
                "features": ["face"] * k,
                "regions": faces[i].tolist(),
                "d_star": float(d_star[i]),
                "closure": "form closure",
                "conditioning": float(conditioning[i]),
                "epsilon": 0.0,
                "squeeze_per_weight": float(1.0 / conditioning[i]),  # a stand-in, stored as is
                "fingers": {
                    "tip_centers": tips.tolist(),
                    "tip_radius": radius,
                    "approach": normals[i].tolist(),
                    "body_length": length,
                    "body_radius": radius,
                },
            }
        )
    doc: dict[str, Any] = {
        "format": "synth.grasps",
        "version": 1,
        "synth_version": "0.1.0",
        "mesh": {
            "path": path,
            "sha256": "",
            "units": "unknown",
            "length": length,
        },
        "params": dict(params),
        "grasps": grasps,
        "timing": {"total_s": time.perf_counter() - t0},
    }
    if not grasps:
        doc["message"] = f"no form-closure grasp among {evals} random {k}-contact sets"
    return doc


def plan_for_sim(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Like :func:`plan_mesh_file`, with what ``synth.sim`` needs and synth's planner gives:
    the mesh's digest, size (bounding-box diagonal), centre of mass, volume and how it was
    loaded, and fingers approaching from outside."""
    doc = plan_mesh_file(path, params)
    mesh = _load(path)
    with open(path, "rb") as fh:
        digest = hashlib.sha256(fh.read()).hexdigest()
    doc["mesh"].update(sha256=digest, center_mass=mesh.center_mass.tolist(),
                       volume=float(mesh.volume), units=None,
                       length=float(np.linalg.norm(mesh.extents)),
                       load={"units": None, "body": "largest", "sharp_angle": 30.0})
    for g in doc["grasps"]:
        g["fingers"]["approach"] = (-np.asarray(g["normals"])).tolist()
    return doc


def plan_cut_by_time(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Like :func:`plan_mesh_file`, but reports that the wall-clock cap cut the search."""
    doc = plan_mesh_file(path, params)
    doc["timing"] = dict(doc.get("timing", {}), stopped_by_time=True)
    return doc


def plan_without_mesh(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Like :func:`plan_mesh_file`, but the document has no ``mesh`` object."""
    doc = plan_mesh_file(path, params)
    del doc["mesh"]
    return doc


def plan_with_report(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Like :func:`plan_mesh_file`, with a loading report holding numpy values and a NaN."""
    doc = plan_mesh_file(path, params)
    doc["mesh"].update(
        center_mass=np.zeros(3),
        volume=np.float64("nan"),
        repairs=("welded 3 vertices",),
        warnings=[],
        dropped=["dropped object 1"],
        extra={"count": np.int64(2)},
    )
    return doc


def plan_catching_everything(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Like :func:`plan_mesh_file`, but any ``Exception`` becomes "cannot be read as STL", as a
    mesh loader that wraps whatever its reader raises does."""
    try:
        return plan_mesh_file(path, params)
    except Exception as e:  # noqa: BLE001 - the point of this planner
        raise MeshError(f"{path}: cannot be read as STL ({type(e).__name__}: {e})") from e


def plan_losing_one_alarm(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Like :func:`plan_mesh_file`, but the first interruption is lost, as when the alarm
    fires inside a garbage-collector callback or a ``__del__`` (Python only reports an
    exception raised there as unraisable)."""
    try:
        time.sleep(float(os.environ.get("SYNTH_FAKEPLANNER_DELAY", "0")))
    except BaseException:  # noqa: BLE001 - the point of this planner: the first alarm is lost
        pass
    return plan_mesh_file(path, params)


def plan_crashing_on_ico(path: str, params: dict[str, Any]) -> dict[str, Any]:
    """Like :func:`plan_mesh_file`, but the process dies of SIGSEGV on files named ``ico*``, as
    when a native library crashes on one mesh."""
    if os.path.basename(path).startswith("ico"):
        from tests.segfault import segfault

        segfault()
    return plan_mesh_file(path, params)
