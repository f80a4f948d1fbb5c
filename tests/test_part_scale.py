"""Any size, any placement, any float precision: from 1 nm to 1 km, in metres and in
millimetres, centred and 1,000 part sizes off the origin, in float32 (binary STL) and float64
(OBJ written with every digit) files. synth's own samples are never refused by its own
resolver, and every planned grasp passes the independent check."""

from __future__ import annotations

import itertools
from pathlib import Path

import manifold3d as mf
import numpy as np
import pytest
import trimesh

from synth import PlanParams, load_part, plan_part, sample_contacts
from tests.independent_check import check_document


def _shape() -> trimesh.Trimesh:
    """An irregular part of size ~1: the hull of random points with a notch cut out (planar
    facets of many sizes, convex and concave edges, an inside corner)."""
    rng = np.random.default_rng(11)
    pts = rng.normal(size=(40, 3)) * [1.0, 0.7, 0.5]
    hull = mf.Manifold.hull_points(pts)
    notch = mf.Manifold.cube((1.0, 1.0, 1.0)).translate((0.2, 0.1, 0.05))
    m = (hull - notch).to_mesh()
    mesh = trimesh.Trimesh(np.asarray(m.vert_properties, float)[:, :3],
                           np.asarray(m.tri_verts, np.int64))
    return mesh.apply_scale(1.0 / np.linalg.norm(mesh.extents))


def _write_obj(mesh: trimesh.Trimesh, path: Path) -> None:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in mesh.vertices.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces.tolist()]
    path.write_text("\n".join(lines) + "\n")


CASES = list(itertools.product([1e-3, 1.0, 1e3], ["m", "mm"], [0.0, 1000.0], ["f32", "f64"]))
CASES += list(itertools.product([1e-9], ["m", "mm"], [0.0, 1000.0], ["f32", "f64"]))


@pytest.mark.parametrize("size, unit, offset, dtype", CASES,
                         ids=[f"{s:g}m-{u}-off{o:g}-{d}" for s, u, o, d in CASES])
def test_part_of_any_size_and_placement_plans_and_checks(
        tmp_path: Path, size: float, unit: str, offset: float, dtype: str) -> None:
    scale = size * (1000.0 if unit == "mm" else 1.0)  # file coordinates per part size
    mesh = _shape()
    mesh.apply_scale(scale)
    mesh.apply_translation(np.array([1.0, -0.6, 0.3]) * offset * scale)
    path = tmp_path / ("part.stl" if dtype == "f32" else "part.obj")
    if dtype == "f32":
        mesh.export(path)
    else:
        _write_obj(mesh, path)
    part = load_part(path, units=unit)
    assert part.watertight and len(part.bodies) == 1
    assert part.length == pytest.approx(scale, rel=1e-3)
    # every face keeps a real normal and the planar facets survive float32 rounding far away
    assert np.allclose(np.linalg.norm(part.mesh.face_normals, axis=1), 1.0)
    assert sum(r.planar for r in part.regions) >= 10

    contacts = sample_contacts(part, 600, seed=0)
    again = part.resolve(contacts.points)  # no faces given, no snapping: must not refuse
    assert np.allclose(again.points, contacts.points, rtol=0, atol=part.surface_tolerance)
    even = sample_contacts(part, 200, seed=1, method="even")
    part.resolve(even.points)

    plan = plan_part(part, PlanParams(top=3, seed=0))
    assert plan.grasps and plan.grasps[0].d_star > 0.3
    failures = check_document(path, plan.to_json())
    assert not failures, "\n".join(failures)
