"""Benchmark: candidate grasps (7 fingers each) checked per second on a ~10k-face CSG part.

Compares, in the same run, the batched checker (numpy pre-checks on the whole batch, one cached
BVH, one FCL sweep per finger, a grasp dropped at its first failing finger) with a naive
baseline (a BVH built once, then per grasp and per finger new FCL objects and one collide call
each for the tip sphere, the body capsule and the approach sweep, no pre-checks, no early exit;
tip-tip distances after). Two workloads: uniformly random contacts (many grasps fail early),
and contacts on the part's lower, convex cap spread apart so nearly every finger passes and
every finger reaches FCL (the worst case for the batched checker). Fixed seeds.

    /work/venv/bin/python scripts/bench_fingers.py
"""

from __future__ import annotations

import time

import fcl
import numpy as np
import trimesh

from synth.fingers import Fingers, check_fingers
from synth.fingers.geometry import quaternions_to


def _naive(mesh: trimesh.Trimesh, points: np.ndarray, normals: np.ndarray,
           f: Fingers) -> np.ndarray:
    """Per grasp, per finger, per primitive: one FCL object and one collide call."""
    bvh = fcl.BVHModel()
    bvh.beginModel(len(mesh.vertices), len(mesh.faces))
    bvh.addSubModel(mesh.vertices, mesh.faces)
    bvh.endModel()
    part = fcl.CollisionObject(bvh, fcl.Transform())
    r, tol = float(f.tip_radius), float(f.penetration_tol)
    L, rb = float(f.body_length), float(f.body_radius)
    D = float(np.linalg.norm(mesh.extents)) + 2 * r + L
    ok = np.ones(len(points), dtype=bool)
    for b in range(len(points)):
        c = points[b] - r * normals[b]
        for j in range(points.shape[1]):
            a = -normals[b, j]
            q = quaternions_to(a[None])[0]
            for geom, t in (
                (fcl.Sphere(r - tol), c[j]),
                (fcl.Capsule(rb - tol, L), c[j] + 0.5 * L * a),
                (fcl.Capsule(r - tol, D), c[j] + 0.5 * D * a),
            ):
                obj = fcl.CollisionObject(geom, fcl.Transform(q, t))
                if fcl.collide(part, obj, fcl.CollisionRequest(), fcl.CollisionResult()):
                    ok[b] = False
        for i in range(points.shape[1]):
            for j in range(i + 1, points.shape[1]):
                if np.linalg.norm(c[i] - c[j]) < 2 * r - tol:
                    ok[b] = False
    return ok


def _spread_grasps(points: np.ndarray, normals: np.ndarray, B: int, k: int, min_gap: float,
                   seed: int) -> tuple[np.ndarray, np.ndarray]:
    """B grasps of k contacts drawn from a pool, contacts at least ``min_gap`` apart."""
    rng = np.random.default_rng(seed)
    out = np.empty((B, k), dtype=int)
    for b in range(B):
        chosen: list[int] = []
        while len(chosen) < k:
            i = int(rng.integers(len(points)))
            if all(np.linalg.norm(points[i] - points[j]) >= min_gap for j in chosen):
                chosen.append(i)
        out[b] = chosen
    return points[out], normals[out]


def _rate(mesh, points, normals, fingers, n_naive):
    # CPU time of this process (single-threaded code), so that other jobs on the machine
    # do not distort the comparison; wall-clock rates are printed too.
    t, w = time.process_time(), time.perf_counter()
    res = check_fingers(mesh, points, normals, fingers)
    fast = len(points) / (time.process_time() - t)
    wall = len(points) / (time.perf_counter() - w)
    t = time.process_time()
    naive_ok = _naive(mesh, points[:n_naive], normals[:n_naive], fingers)
    naive = n_naive / (time.process_time() - t)
    agree = int((res.mask[:n_naive] == naive_ok).sum())
    return res, fast, wall, naive, agree


def main() -> None:
    """Run both workloads and print grasps per second."""
    sphere = trimesh.creation.uv_sphere(radius=50.0, count=[52, 52])
    move = trimesh.transformations.translation_matrix
    slot = trimesh.creation.box((120.0, 12.0, 40.0), transform=move((0, 0, 40)))
    mesh = sphere.difference(slot, engine="manifold")
    print(f"part: sphere r=50 with a 12-wide slot, {len(mesh.faces)} faces, "
          f"watertight={mesh.is_watertight}")
    fingers = Fingers(tip_radius=2.0, body_length=20.0, body_radius=1.5)
    print(f"fingers: {fingers.to_dict()}")
    k, n_naive = 7, 300
    B = 4000
    pts, fid = trimesh.sample.sample_surface(mesh, B * k, seed=1)
    nrm = -mesh.face_normals[fid]
    check_fingers(mesh, pts[:k][None], nrm[:k][None], fingers)  # build and cache the BVH
    low = pts[:, 2] < -10.0
    spread = _spread_grasps(pts[low], nrm[low], B, k, 4.5, seed=2)
    workloads = {
        "random contacts": (pts.reshape(B, k, 3), nrm.reshape(B, k, 3)),
        "all-clear contacts": spread,
    }
    print(f"grasps/s per CPU core (wall-clock in brackets); {B} grasps batched, {n_naive} naive")
    print(f"{'workload':20s} {'batched':>16s} {'naive':>8s} {'speed-up':>9s}"
          f" {'accepted':>9s} {'agree w/ naive':>15s}")
    for name, (p, n) in workloads.items():
        res, fast, wall, naive, agree = _rate(mesh, p, n, fingers, n_naive)
        print(f"{name:20s} {fast:7.0f} ({wall:6.0f}) {naive:8.0f} {fast / naive:9.1f}"
              f" {res.n_accepted / len(p):9.1%} {agree:>8d}/{n_naive}")
    counts: dict[str, int] = {}
    for s in check_fingers(mesh, *workloads["random contacts"], fingers).reasons:
        key = "accepted" if not s else s.split(" ", 2)[2].split(" (")[0].split(" by ")[0]
        key = "fingers overlap" if "overlap" in s else key
        counts[key] = counts.get(key, 0) + 1
    print("random contacts, first reason per grasp:", counts)


if __name__ == "__main__":
    main()
