"""Malformed meshes for every native call.

``malformed()`` is the fuzz set of ``tests/test_native.py``: open, non-manifold, duplicate
and degenerate faces, inconsistent winding, thousands of open pieces, and arrays no native
library may be given (indices out of range, NaN, no faces). ``fuzz()`` hands each to every
native call synth makes and prints one JSON line per call; the test runs it in a process of
its own, so a crash shows as that process's signal instead of ending the test run.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import trimesh

__all__ = ["malformed", "open_sphere", "fuzz"]


def open_sphere(offset: float = 0.0) -> trimesh.Trimesh:
    """An icosphere with a pentagonal hole, which trimesh's hole filling cannot close (so
    the loader hands it to manifold3d)."""
    s = trimesh.creation.icosphere(subdivisions=1)
    ring = np.flatnonzero((s.faces == 0).any(axis=1))[:3]
    far = int(np.argmin(s.triangles_center @ s.vertices[0]))
    keep = np.setdiff1d(np.arange(len(s.faces)), np.r_[ring, far])
    return trimesh.Trimesh(s.vertices + offset, s.faces[keep], process=False)


def _pieces(n: int, spacing: float, one: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """``n`` copies of an open mesh on a grid."""
    side = int(np.ceil(n ** (1 / 3)))
    grid = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3)[:n]
    v = np.concatenate([one.vertices + spacing * g for g in grid])
    f = np.concatenate([one.faces + i * len(one.vertices) for i in range(n)])
    return v, f


def malformed() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Name -> (vertices (n, 3), faces (m, 3)) of every malformed mesh of the fuzz set."""
    box = trimesh.creation.box()
    v, f = np.asarray(box.vertices, float), np.asarray(box.faces, np.int64)
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    tet_f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    flipped = f.copy()
    flipped[::2] = flipped[::2, ::-1]
    nan = v.copy()
    nan[3, 1] = np.nan
    sphere = open_sphere()
    open_tet = trimesh.Trimesh(tet, tet_f[:3], process=False)
    return {
        "open": (v, f[:-2]),
        "open, holes trimesh cannot fill": (sphere.vertices, sphere.faces),
        "non-manifold edge (a fin)": (np.vstack([v, [[2.0, 2.0, 2.0]]]),
                                      np.vstack([f, [[f[0, 0], f[0, 1], 8]]])),
        "bow tie (two bodies sharing one vertex)": (
            np.vstack([tet, -tet[1:]]),
            np.vstack([tet_f, np.where(tet_f, tet_f + 3, 0)[:, ::-1]])),
        "duplicate faces": (v, np.vstack([f, f, f[:3, ::-1]])),
        "degenerate faces": (np.vstack([v, [[0.25, 0.0, -0.5]]]),
                             np.vstack([f, [[0, 0, 1], [2, 2, 2], [0, 1, 8]]])),
        "inconsistent winding": (v, flipped),
        "3000 open pieces": _pieces(3000, 2.5, open_tet),
        "3000 open pieces, corners 1e-7 apart": _pieces(3000, 1.0 + 1e-7, open_tet),
        "100 open spheres": _pieces(100, 2.5, sphere),
        "index out of range": (v, np.vstack([f, [[0, 1, 10_000_000]]])),
        "negative index": (v, np.vstack([f, [[0, 1, -4]]])),
        "NaN coordinate": (nan, f),
        "no faces": (v, np.zeros((0, 3), np.int64)),
        "no vertices": (np.zeros((0, 3)), np.zeros((0, 3), np.int64)),
    }


def _outcome(call: Any) -> str:
    """``"none"``, ``"ok"``, the string the call returned, or what it raised."""
    try:
        got = call()
    except Exception as e:  # noqa: BLE001 - the outcome is what the test checks
        return f"raised {type(e).__name__}: {e}"
    return got if isinstance(got, str) else "none" if got is None else "ok"


def fuzz() -> None:
    """Hand every malformed mesh to every native call of synth; one JSON line per call."""
    import fcl

    from synth import native
    from synth.errors import MeshError
    from synth.fingers import check_fingers, default_fingers
    from synth.part import load_part

    sphere = fcl.CollisionObject(fcl.Sphere(0.3), fcl.Transform())

    def fcl_queries(v: np.ndarray, f: np.ndarray) -> bool:
        body = fcl.CollisionObject(native.bvh_model(v, f), fcl.Transform())
        fcl.collide(body, sphere, fcl.CollisionRequest(num_max_contacts=100,
                                                       enable_contact=True),
                    fcl.CollisionResult())
        fcl.distance(body, sphere, fcl.DistanceRequest(), fcl.DistanceResult())
        return True

    def loaded(v: np.ndarray, f: np.ndarray) -> str:
        try:
            part = load_part(trimesh.Trimesh(v, f, process=False, validate=False),
                             units="mm", body="all")
        except MeshError as e:
            return f"refused: {e}"
        points = part.mesh.triangles_center[:7]
        normals = -part.mesh.face_normals[:7]
        check_fingers(part, points[None], normals[None], default_fingers(part))
        return "loaded" + "".join(f"; {w}" for w in part.warnings if "crashed" in w)

    for name, (v, f) in malformed().items():
        small = len(f) < 8_000  # loading thousands of pieces takes seconds: the calls see them
        calls = {
            # each call runs in this iteration; v and f are bound as defaults all the same
            "merge_close": lambda v=v, f=f: native.merge_close(v, f),
            "overlap_volumes": lambda v=v, f=f: native.overlap_volumes([(v, f), (v + 0.1, f)],
                                                                       [(0, 1)]),
            "unite": lambda v=v, f=f: native.unite([(v, f), (v + 0.1, f)]),
            "fcl": lambda v=v, f=f: fcl_queries(v, f),
            **({"load_part and check_fingers": lambda v=v, f=f: loaded(v, f)} if small else {}),
        }
        for call, run in calls.items():
            print(json.dumps({"mesh": name, "call": call, "outcome": _outcome(run)}), flush=True)
