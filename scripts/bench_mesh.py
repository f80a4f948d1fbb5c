"""Benchmark: load + feature extraction of a ~100k-face mesh, and resolving 100k points.

The mesh (a finely tessellated torus, in decimetres) is generated here and written to a
temporary binary STL, so the timing includes file reading, welding and repairs.
Run ``python scripts/bench_mesh.py``; fixed seeds, figures comparable between runs.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import manifold3d as mf
import numpy as np
import trimesh

from synth.contacts import sample_contacts
from synth.part import load_part

__all__ = ["main"]


def _torus(major: int = 400, minor: int = 125) -> trimesh.Trimesh:
    circle = mf.CrossSection.circle(0.2, minor).translate((0.6, 0.0))
    m = mf.Manifold.revolve(circle, major).to_mesh()
    return trimesh.Trimesh(np.asarray(m.vert_properties, float)[:, :3],
                           np.asarray(m.tri_verts, np.int64))


def _timed(label: str, fn, repeat: int = 3):  # type: ignore[no-untyped-def]
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    print(f"{label:52s} {best:8.3f} s (best of {repeat})")
    return out


def main() -> int:
    """Print the timings."""
    mesh = _torus()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "torus.stl"
        mesh.export(path)
        print(f"mesh: torus, {len(mesh.faces)} faces, {path.stat().st_size / 1e6:.1f} MB STL")
        part = _timed("load_part (read, weld, repair, features, regions)",
                      lambda: load_part(path, units="decimeters"))
    print(f"  -> {part}")
    rng = np.random.default_rng(0)
    c = sample_contacts(part, 100_000, seed=0)
    pts, faces = np.array(c.points), np.array(c.faces)
    _timed("sample_contacts uniform, n = 100k", lambda: sample_contacts(part, 100_000, seed=0))
    _timed("resolve 100k surface points, faces known", lambda: part.resolve(pts, faces))
    _timed("resolve 100k surface points, faces searched", lambda: part.resolve(pts))
    noisy = pts + rng.normal(scale=1e-3 * part.length, size=pts.shape)
    _timed("resolve 100k off-surface points, snap=True", lambda: part.resolve(noisy, snap=True))
    _timed("sample_contacts even, n = 1000", lambda: sample_contacts(part, 1000, seed=0,
                                                                      method="even"))
    origins = rng.normal(size=(10_000, 3)) * 3.0
    # the first call also builds the triangle r-tree (cached on the mesh)
    _timed("contacts_from_rays, 1k rays at the centre, 1st call",
           lambda: part.raycast(origins[:1000], -origins[:1000]), repeat=1)
    _timed("contacts_from_rays, 1k rays at the centre",
           lambda: part.raycast(origins[:1000], -origins[:1000]))
    _timed("contacts_from_rays, 10k rays at the centre",
           lambda: part.raycast(origins, -origins))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
