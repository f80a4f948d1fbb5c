"""Shared cases of the simulation tests: a unit cube, grasp files written by hand, and the
largest push a grasp's force limits can balance, found by an LP that shares no code with
MuJoCo or synth.sim."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import trimesh
from scipy.optimize import linprog

#: A 7-contact frictionless grasp of the unit cube [-0.5, 0.5]^3 (d* = 0.5): points, inward
#: normals. Row 1 is the only contact pushing along +x.
A = 0.3
CUBE7 = (np.array([[-A, -A, 0.5], [-0.5, A, -A], [-A, 0.5, -A], [A, -0.5, A], [-A, A, -0.5],
                   [0.5, -A, A], [A, A, 0.5]]),
         np.array([[0, 0, -1], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0],
                   [0, 0, -1]], float))

#: A 6-contact frictionless grasp of the unit cube that holds it against everything but a
#: translation along x (every normal lies in the y-z plane; the wrench matrix has rank 5 and a
#: positive null vector): its only free motion is sliding along +-x.
CUBE6 = (np.array([[-A, 0.5, A], [A, 0.5, A], [0, -0.5, 0], [-A, A, 0.5], [A, A, 0.5],
                   [0, 0, -0.5]]),
         np.array([[0, -1, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, -1], [0, 0, 1]],
                  float))

#: A 3-contact frictional grasp of the unit cube: a pinch across x and a finger on +y.
CUBE3 = (np.array([[0.5, -0.1, 0.05], [-0.5, -0.1, -0.05], [0.05, 0.5, 0.1]]),
         np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0]], float))

TIP = 0.04  # fingertip radius, cube units


def rotation(seed: int = 3) -> np.ndarray:
    """A fixed proper rotation matrix."""
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def write_cube(folder: Path, R: np.ndarray | None = None, t: np.ndarray | None = None) -> Path:
    """The unit cube, turned by ``R`` and moved by ``t``, as a binary STL."""
    m = trimesh.creation.box((1.0, 1.0, 1.0))
    if R is not None:
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = np.zeros(3) if t is None else t
        m.apply_transform(T)
    path = folder / "cube.stl"
    m.export(path)
    return path


_CORNERS = np.array([[x, y, z] for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)])


def write_grasps(folder: Path, mesh: Path, points, normals, *, mu: float = 0.0,
                 R: np.ndarray | None = None, t: np.ndarray | None = None,
                 name: str = "cube.grasps.json") -> Path:
    """A synth.grasps file with one grasp of the unit cube, turned and moved like the mesh."""
    R = np.eye(3) if R is None else R
    t = np.zeros(3) if t is None else np.asarray(t, float)
    P = np.asarray(points, float) @ R.T + t
    N = np.asarray(normals, float) @ R.T
    doc = {
        "format": "synth.grasps", "version": 1,
        "mesh": {"path": str(mesh), "sha256": None,
                 "length": float(np.linalg.norm(np.ptp(_CORNERS @ R.T, axis=0))),
                 "center_mass": t.tolist(), "volume": 1.0},
        "params": {"mu": mu},
        "grasps": [{"rank": 1, "points": P.tolist(), "normals": N.tolist(),
                    "d_star": 0.5, "conditioning": 0.2, "epsilon": 0.05,
                    "fingers": {"tip_centers": (P - TIP * N).tolist(), "approach": (-N).tolist(),
                                "tip_radius": TIP}}],
    }
    path = folder / name
    path.write_text(json.dumps(doc))
    return path


def push_bounds(points, normals, center, length: float, weight: float) -> np.ndarray:
    """The largest push along +x, -x, +y, -y, +z, -z and torque about each that frictionless
    fingers of force limit 1 balance together with the weight (-z), by LP.

    Maximise ``t`` subject to ``sum_i f_i w_i + t e + w_g = 0``, ``0 <= f_i <= 1``, with
    ``w_i = [n_i; (p_i - c) / length x n_i]``: forces in grip forces, torques in grip force
    times ``length``, as the simulation labels them.
    """
    P = (np.asarray(points, float) - center) / length
    N = np.asarray(normals, float)
    W = np.vstack([N.T, np.cross(P, N).T])
    k = len(P)
    g = np.array([0.0, 0.0, -weight, 0.0, 0.0, 0.0])
    out = np.zeros(12)
    for j in range(12):
        e = np.zeros(6)
        e[(3 if j >= 6 else 0) + (j % 6) // 2] = 1.0 if j % 2 == 0 else -1.0
        res = linprog(np.r_[np.zeros(k), -1.0], A_eq=np.hstack([W, e[:, None]]), b_eq=-g,
                      bounds=[(0, 1)] * k + [(0, None)], method="highs")
        assert res.status == 0, res.message
        out[j] = res.x[-1]
    return out


def write_split_obj(folder: Path, split: str, name: str | None = None) -> Path:
    """The unit cube centred at the origin as an OBJ file whose vertices are split as many
    exporters write them: ``"normal"``, every face with its own four corners and a ``vn``
    normal (flat shading); ``"uv"``, two texture islands (the top with the sides, and the
    bottom) that share no vertex, each corner with a ``vt`` coordinate."""
    m = trimesh.creation.box((1.0, 1.0, 1.0))
    tri = np.asarray(m.triangles)  # (12, 3, 3)
    normals = np.asarray(m.face_normals)
    lines = ["# written by tests.sim_support.write_split_obj", "o cube"]
    if split == "normal":
        for f in range(12):
            for c in tri[f]:
                lines.append("v {:.6f} {:.6f} {:.6f}".format(*c))
            lines.append("vn {:.6f} {:.6f} {:.6f}".format(*normals[f]))
        for f in range(12):
            a = 3 * f + 1
            lines.append(f"f {a}//{f + 1} {a + 1}//{f + 1} {a + 2}//{f + 1}")
    elif split == "uv":
        bottom = normals[:, 2] < -0.5
        offset = 0
        for island in (~bottom, bottom):
            faces = np.asarray(m.faces)[island]
            used, inverse = np.unique(faces, return_inverse=True)
            for i, v in enumerate(used):
                lines.append("v {:.6f} {:.6f} {:.6f}".format(*m.vertices[v]))
                lines.append(f"vt {i / len(used):.6f} {float(island.sum() > 2):.1f}")
            for f in inverse.reshape(-1, 3) + offset + 1:
                lines.append(f"f {f[0]}/{f[0]} {f[1]}/{f[1]} {f[2]}/{f[2]}")
            offset += len(used)
    else:
        raise ValueError(split)
    path = folder / (name or f"cube_{split}.obj")
    path.write_text("\n".join(lines) + "\n")
    return path
