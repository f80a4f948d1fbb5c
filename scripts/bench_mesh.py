"""Benchmark: loading and planning every mesh of the real-mesh corpus; then load + features
of a ~100k-face mesh and resolving 100k points.

Corpus: for each file of ``meshes/corpus``, the time to read it with plain ``trimesh.load``
(the baseline: reading and welding only), ``load_part`` (bodies, repairs, unions, exposure,
features, regions), and ``synth plan`` at its defaults, with the bodies and the best d*.

Torus: the mesh (a finely tessellated torus, in decimetres) is generated here and written to
a temporary binary STL, so the timing includes file reading, welding and repairs.

Run ``python scripts/bench_mesh.py [--corpus-only | --torus-only]``; fixed seeds.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import manifold3d as mf
import numpy as np
import trimesh

from synth.contacts import sample_contacts
from synth.part import load_part
from synth.plan import PlanParams, plan_part

__all__ = ["main"]

CORPUS = Path(__file__).resolve().parent.parent / "meshes" / "corpus"


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


def _best(fn, repeat: int = 3) -> tuple[float, object]:  # type: ignore[no-untyped-def]
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def corpus() -> None:
    """Load and plan times over the real-mesh corpus."""
    entries = json.loads((CORPUS / "corpus.json").read_text())
    print(f"{'mesh':44s} {'faces':>6s} {'bodies':>6s} {'trimesh s':>9s} {'load s':>7s} "
          f"{'plan s':>7s} {'best d*':>8s}")
    loads, plans = [], []
    for e in entries:
        path = CORPUS / e["file"]
        kw = {"split_objects": True, "group_material": False} if path.suffix == ".obj" else {}
        t_tm, _ = _best(lambda path=path, kw=kw: trimesh.load(path, **kw))
        try:
            t_load, part = _best(lambda path=path, e=e: load_part(path, units=e["units"]))
        except Exception as ex:  # the flat cloth is refused as bad input
            print(f"{e['file'][:44]:44s} {'':>6s} {'':>6s} {t_tm:9.3f}   refused: "
                  f"{str(ex).split(': ', 1)[-1][:40]}")
            continue
        t0 = time.perf_counter()
        plan = plan_part(part, PlanParams())
        t_plan = time.perf_counter() - t0
        loads.append(t_load)
        plans.append(t_plan)
        best = f"{plan.grasps[0].d_star:8.4f}" if plan.grasps else "    none"
        print(f"{e['file'][:44]:44s} {len(part.mesh.faces):6d} {len(part.bodies):6d} "
              f"{t_tm:9.3f} {t_load:7.3f} {t_plan:7.2f} {best}")
    print(f"{len(plans)} meshes planned: load median {np.median(loads):.3f} s, max "
          f"{max(loads):.3f} s; plan median {np.median(plans):.2f} s, max {max(plans):.2f} s")


def torus() -> None:
    """Load a 100k-face torus, resolve and sample on it, cast rays."""
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


def main() -> int:
    """Print the timings."""
    if "--torus-only" not in sys.argv:
        corpus()
    if "--corpus-only" not in sys.argv:
        torus()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
