"""Benchmark: candidate grasps (7 fingers each) checked per second on a ~10k-face mesh.

Compares the batched checker (numpy pre-checks, one cached BVH, one FCL sweep per finger)
with a naive baseline that builds FCL objects and runs one collide call per primitive per
finger per grasp (tip sphere, body capsule, approach sweep) without pre-checks.
Fixed seed; prints grasps/s for both and whether they agree on the part checks.

    /work/venv/bin/python scripts/bench_fingers.py
"""

from __future__ import annotations

import time

import fcl
import numpy as np
import trimesh

from synth.fingers import Fingers, check_fingers
from synth.fingers.geometry import rotations_to


def _naive(mesh: trimesh.Trimesh, points: np.ndarray, normals: np.ndarray, f: Fingers) -> np.ndarray:
    bvh = fcl.BVHModel()
    bvh.beginModel(len(mesh.vertices), len(mesh.faces))
    bvh.addSubModel(mesh.vertices, mesh.faces)
    bvh.endModel()
    part = fcl.CollisionObject(bvh, fcl.Transform())
    r, tol, L, rb = f.tip_radius, f.penetration_tol, f.body_length, f.body_radius
    D = float(np.linalg.norm(mesh.extents)) + 2 * r + L
    ok = np.ones(len(points), dtype=bool)
    for b in range(len(points)):
        c = points[b] - r * normals[b]
        for j in range(points.shape[1]):
            a = -normals[b, j]
            R = rotations_to(a[None])[0]
            for geom, t in (
                (fcl.Sphere(r - tol), c[j]),
                (fcl.Capsule(rb - tol, L), c[j] + 0.5 * L * a),
                (fcl.Capsule(r - tol, D), c[j] + 0.5 * D * a),
            ):
                obj = fcl.CollisionObject(geom, fcl.Transform(R, t))
                if fcl.collide(part, obj, fcl.CollisionRequest(), fcl.CollisionResult()):
                    ok[b] = False
        for i in range(points.shape[1]):
            for j in range(i + 1, points.shape[1]):
                if np.linalg.norm(c[i] - c[j]) < 2 * r - tol:
                    ok[b] = False
    return ok


def main() -> None:
    """Run the benchmark and print grasps per second."""
    rng = np.random.default_rng(0)
    # A CSG part: a sphere with a slot cut out, about 10k faces.
    sphere = trimesh.creation.uv_sphere(radius=50.0, count=[52, 52])
    slot = trimesh.creation.box((120.0, 12.0, 40.0), transform=trimesh.transformations.translation_matrix((0, 0, 40)))
    mesh = sphere.difference(slot, engine="manifold")
    print(f"mesh: {len(mesh.faces)} faces, watertight={mesh.is_watertight}")
    B, k = 4000, 7
    pts, fid = trimesh.sample.sample_surface(mesh, B * k, seed=1)
    points = pts.reshape(B, k, 3)
    normals = -mesh.face_normals[fid].reshape(B, k, 3)
    fingers = Fingers(tip_radius=2.0, body_length=20.0, body_radius=1.5)
    check_fingers(mesh, points[:10], normals[:10], fingers)  # build and cache the BVH
    t = time.perf_counter()
    res = check_fingers(mesh, points, normals, fingers)
    t_fast = time.perf_counter() - t
    n_naive = 400
    t = time.perf_counter()
    naive_ok = _naive(mesh, points[:n_naive], normals[:n_naive], fingers)
    t_naive = time.perf_counter() - t
    print(f"batched checker : {B / t_fast:10.0f} grasps/s  ({B} grasps, {res.n_accepted} accepted)")
    print(f"naive baseline  : {n_naive / t_naive:10.0f} grasps/s  ({n_naive} grasps, {naive_ok.sum()} accepted)")
    names = {}
    for s in res.reasons:
        key = s.split(" ", 2)[-1].split(" by ")[0].split(" (")[0] if s else "accepted"
        names[key] = names.get(key, 0) + 1
    print("outcomes:", dict(sorted(names.items(), key=lambda kv: -kv[1])))
    # The naive baseline ignores body-body overlaps; compare where our reasons are not overlaps.
    ours = res.mask[:n_naive]
    disagree = np.flatnonzero(ours != naive_ok)
    print(f"agreement with baseline on {n_naive} grasps: {n_naive - len(disagree)}/{n_naive}")
    for b in disagree[:5]:
        print("  differs:", b, res.reasons[b] or "accepted", "| naive:", naive_ok[b])


if __name__ == "__main__":
    main()
