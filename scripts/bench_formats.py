"""Benchmark: ``synth rank --gripper`` of 2,000 gripper poses (one ACRONYM file's worth) on a
part of about 10,000 faces, on one core, the mesh already loaded.

The part is a capsule 80 mm long and 50 mm across (10,224 faces, metres); the poses are
written as an ACRONYM HDF5 file with fixed seeds: approaches from random directions at the
part's axis, the TCP within 10 mm of it, random turns about the approach -- a
generator's spread: half close across the capsule's axis within 3 degrees and 3 mm (most of
them land and are scored), the others anywhere near the part. Printed: the time to read the
file, to load the mesh, and to rank (close, check, score) the poses, with the statuses.

Run: ``python scripts/bench_formats.py`` (single-threaded BLAS is set here).
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import trimesh  # noqa: E402


def _poses(n: int, seed: int) -> np.ndarray:
    from synth.fingers.gripper import load_gripper

    tcp = load_gripper("franka").tcp
    rng = np.random.default_rng(seed)
    z = rng.normal(size=(n, 3))
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    e = rng.normal(size=(n, 3))
    x = np.cross(z, e)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, 0], T[:, :3, 1], T[:, :3, 2] = x, y, z
    # half the poses close across the capsule's axis (a generator's good ones, within 3 degrees
    # and 3 mm), the others anywhere near it
    good = np.arange(n) < n // 2
    axis = rng.uniform(-np.pi, np.pi, n)
    x[good] = np.column_stack([np.cos(axis), np.sin(axis), np.zeros(n)])[good]
    z[good] = np.cross(x[good], [0.0, 0.0, 1.0]) * np.where(rng.random(n) < 0.5, 1, -1)[good,
                                                                                          None]
    tilt = np.radians(3.0) * rng.normal(size=(n, 3))
    z[good] += tilt[good]
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    x[good] -= np.einsum("ij,ij->i", x[good], z[good])[:, None] * z[good]
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    T[:, :3, 0], T[:, :3, 1], T[:, :3, 2] = x, y, z
    centre = np.column_stack([np.zeros(n), np.zeros(n), rng.uniform(-0.03, 0.03, n)])
    centre += rng.uniform(-0.01, 0.01, (n, 3)) * np.where(good, 0.3, 1.0)[:, None]
    T[:, :3, 3] = centre - np.einsum("nij,j->ni", T[:, :3, :3], tcp)
    return T


def main() -> None:
    import h5py

    from synth.formats import read_gripper_poses
    from synth.part import load_part
    from synth.plan.gripper import GripperParams
    from synth.plan.gripper_rank import rank_gripper_poses

    with tempfile.TemporaryDirectory() as tmp:
        mesh = Path(tmp) / "capsule.stl"
        trimesh.creation.capsule(height=0.03, radius=0.025, count=[72, 72]).export(mesh)
        poses = Path(tmp) / "capsule.h5"
        with h5py.File(poses, "w") as f:
            f["grasps/transforms"] = _poses(2000, seed=0)
            f["object/file"] = "capsule.stl"
            f["object/scale"] = 1.0
        t0 = time.perf_counter()
        part = load_part(mesh, units="m")
        t_mesh = time.perf_counter() - t0
        t0 = time.perf_counter()
        read = read_gripper_poses(poses)
        at = read.to_part(1.0, "m")
        t_read = time.perf_counter() - t0
        t0 = time.perf_counter()
        r = rank_gripper_poses(part, at.poses, at.metres_per_unit, GripperParams(mass=0.1),
                               dict(read.errors), epsilon_top=20)  # as synth rank's --top 20
        t_rank = time.perf_counter() - t0
    print(f"part: {len(part.mesh.faces)} faces; poses: {len(read.poses)} (ACRONYM HDF5)")
    print(f"load the mesh   {t_mesh:6.2f} s")
    print(f"read the poses  {t_read:6.3f} s")
    print(f"rank the poses  {t_rank:6.2f} s  (target 2 s)  "
          + ", ".join(f"{v} {k}" for k, v in r.counts.items()))


if __name__ == "__main__":
    main()
