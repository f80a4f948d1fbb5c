"""The part as MuJoCo collides it: convex bodies as they are, others through CoACD (cached)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

pytest.importorskip("coacd")
pytest.importorskip("mujoco")

from synth.errors import MeshError  # noqa: E402
from synth.sim import ContactModel, SimSettings, build_scene, convex_pieces  # noqa: E402
from synth.sim.pieces import ConvexPieces  # noqa: E402
from tests.sim_support import write_cube  # noqa: E402

BRACKET = Path(__file__).resolve().parent.parent / "meshes" / "bracket.stl"


def test_a_convex_body_is_used_as_it_is(tmp_path):
    p = convex_pieces(write_cube(tmp_path), [[0.5, 0, 0]], cache=None)
    assert len(p.pieces) == 1 and p.decomposed == 0 and p.error == 0
    assert p.volume == pytest.approx(1.0)
    assert np.allclose(p.inertia, np.eye(3) / 6)  # a unit cube of unit density


def test_a_non_convex_body_is_decomposed_once_and_cached(tmp_path):
    cache = tmp_path / "cache"
    a = convex_pieces(BRACKET, [[0, 0, 0]], cache=cache)
    assert a.decomposed == 1 and len(a.pieces) >= 2 and not a.cached
    hulls = [trimesh.convex.convex_hull(v) for v in a.pieces]
    body = trimesh.load(BRACKET)
    # the pieces cover the L bracket, and add little: the error is their excess volume
    assert 0 <= a.error < 0.05
    assert sum(h.volume for h in hulls) >= body.volume * (1 - 1e-6)
    assert len(list(cache.glob("*.npz"))) == 1
    b = convex_pieces(BRACKET, [[0, 0, 0]], cache=cache)
    assert b.cached and len(b.pieces) == len(a.pieces)
    assert all(np.array_equal(u, v) for u, v in zip(a.pieces, b.pieces))


def test_the_object_the_grasp_touches_is_kept(tmp_path):
    far = trimesh.creation.box((1, 1, 1))
    far.apply_translation([10, 0, 0])
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box((2, 2, 2)), "big")
    scene.add_geometry(far, "small")
    path = tmp_path / "two.obj"
    scene.export(path)
    p = convex_pieces(path, [[10.5, 0, 0], [9.5, 0.2, 0]], cache=None)
    assert len(p.pieces) == 1 and np.allclose(p.pieces[0].mean(axis=0), [10, 0, 0])
    assert p.volume == pytest.approx(1.0)


def test_pieces_mujoco_cannot_load_are_one_line_naming_the_file():
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    p = ConvexPieces((flat,), 1, 0, 0.0, False, np.eye(3) / 6, 1.0, np.zeros(3))
    with pytest.raises(MeshError, match=r"^part\.obj: MuJoCo cannot load .*coplanar"):
        build_scene(p, np.array([[0, 0, 1.0]]), np.array([[0, 0, 1.0]]), 0.1, length=1.5,
                    center_mass=np.zeros(3), volume=1.0, settings=SimSettings(),
                    contact=ContactModel(), mesh_name="part.obj")


def test_a_missing_mesh_is_bad_input(tmp_path):
    with pytest.raises(MeshError, match="no such file"):
        convex_pieces(tmp_path / "none.stl", [[0, 0, 0]])
