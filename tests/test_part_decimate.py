"""Decimation on loading: the reported surface error is the distance an independent
brute-force point-triangle check measures, and a mesh above MAX_FACES loads only with it."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from synth import MeshError, load_part
from synth.part import load as load_module
from synth.part.decimate import decimate_mesh


def _brute_distance(points: np.ndarray, mesh: trimesh.Trimesh) -> np.ndarray:
    """Distance of each point to the nearest of every triangle (trimesh's kernel, all pairs)."""
    tri = np.asarray(mesh.triangles)
    out = np.empty(len(points))
    for i, p in enumerate(points):
        q = trimesh.triangles.closest_point(tri, np.repeat(p[None], len(tri), axis=0))
        out[i] = np.linalg.norm(q - p, axis=1).min()
    return out


def test_reported_error_is_the_measured_distance():
    m = trimesh.creation.icosphere(subdivisions=3)  # 1280 faces, 642 vertices: all sampled
    d = decimate_mesh(m.vertices, m.faces, 300)
    assert 4 <= len(d.mesh.faces) <= 300 and d.faces_before == 1280
    both = np.concatenate([_brute_distance(np.asarray(m.vertices), d.mesh),
                           _brute_distance(np.asarray(d.mesh.vertices), m)])
    assert d.sampled == len(both)
    assert d.max_error == pytest.approx(both.max(), rel=1e-9, abs=1e-15)
    assert d.mean_error == pytest.approx(both.mean(), rel=1e-9)
    assert 0 < d.max_error < 0.1  # a sphere of radius 1 at 300 faces


def test_a_mesh_above_max_faces_loads_only_decimated(monkeypatch, tmp_path):
    path = tmp_path / "blob.stl"
    trimesh.creation.icosphere(subdivisions=4).export(path)  # 5120 faces
    monkeypatch.setattr(load_module, "MAX_FACES", 3000)
    with pytest.raises(MeshError, match="decimate=N"):
        load_part(path)
    part = load_part(path, decimate=2000)
    assert len(part.mesh.faces) <= 2000
    assert any(r.startswith("decimated 5,120 triangles to") and "surface error" in r
               for r in part.repairs)
    with pytest.raises(MeshError, match="decimate: expected a face count"):
        load_part(path, decimate=3001)


def test_a_count_above_the_mesh_s_leaves_the_file_as_it_would_load():
    """--decimate with more faces than the mesh has changes nothing: the same part and the
    same report as without it (an STL's welded triangles are no repair either way)."""
    from pathlib import Path

    cube = Path(__file__).resolve().parents[1] / "meshes" / "cube.stl"
    plain, kept = load_part(cube, units="dm"), load_part(cube, units="dm", decimate=100)
    assert plain.repairs == kept.repairs == ()
    assert np.array_equal(plain.mesh.faces, kept.mesh.faces)
    assert np.array_equal(plain.mesh.vertices, kept.mesh.vertices)
