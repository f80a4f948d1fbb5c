"""The part as MuJoCo collides it: the planned part's convex bodies as they are, others through
CoACD (cached), flat pieces left out; OBJ files whose vertices are split along normal or
texture seams give the same pieces as a welded copy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

pytest.importorskip("coacd")
pytest.importorskip("mujoco")

from synth.errors import SimulationError  # noqa: E402
from synth.part import load_part  # noqa: E402
from synth.sim import convex_pieces  # noqa: E402
from synth.sim.decompose import _solid  # noqa: E402
from tests.sim_support import write_cube, write_split_obj  # noqa: E402

BRACKET = Path(__file__).resolve().parent.parent / "meshes" / "bracket.stl"


def test_a_convex_body_is_used_as_it_is(tmp_path):
    p = convex_pieces(load_part(write_cube(tmp_path)), cache=None)
    assert len(p.pieces) == 1 and p.decomposed == 0 and p.error == 0 and p.flat == 0
    assert p.volume == pytest.approx(1.0)
    assert np.allclose(p.inertia, np.eye(3) / 6)  # a unit cube of unit density


def test_a_non_convex_body_is_decomposed_once_and_cached(tmp_path):
    cache = tmp_path / "cache"
    part = load_part(BRACKET, units="dm")
    a = convex_pieces(part, cache=cache)
    assert a.decomposed == 1 and len(a.pieces) >= 2 and not a.cached
    hulls = [trimesh.convex.convex_hull(v) for v in a.pieces]
    # the pieces cover the L bracket, and add little: the error is their excess volume
    assert 0 <= a.error < 0.05
    assert sum(h.volume for h in hulls) >= part.volume * (1 - 1e-6)
    assert len(list(cache.glob("*.npz"))) == 1
    b = convex_pieces(part, cache=cache)
    assert b.cached and len(b.pieces) == len(a.pieces)
    assert all(np.array_equal(u, v) for u, v in zip(a.pieces, b.pieces, strict=True))


@pytest.mark.parametrize("split", ["normal", "uv"])
def test_split_vertex_obj_files_give_the_welded_part_s_pieces(tmp_path, split):
    # a cube written with its vertices split per face (by normal) or along a texture seam:
    # read raw, it is six open sheets (or two); the planned part is one closed convex body
    raw = trimesh.load(write_split_obj(tmp_path, split), process=False, force="mesh")
    assert not raw.is_watertight
    part = load_part(write_split_obj(tmp_path, split))
    p = convex_pieces(part, cache=None)
    assert len(p.pieces) == 1 and p.decomposed == 0 and p.volume == pytest.approx(1.0)


def test_a_flat_piece_has_no_volume():
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    assert not _solid(flat) and not _solid(flat[:3])
    assert _solid(np.vstack([flat, [[0, 0, 1.0]]]))


def test_a_part_of_flat_pieces_only_is_synth_s_failure_not_the_input_s(tmp_path, monkeypatch):
    import synth.sim.decompose as dec

    monkeypatch.setattr(dec, "_decompose", lambda *a: ([np.eye(3)], False))
    with pytest.raises(SimulationError, match="no piece of the part has a volume"):
        convex_pieces(load_part(BRACKET, units="dm"), cache=None)


def test_a_body_united_from_convex_pieces_is_simulated_as_those_pieces(tmp_path):
    # two overlapping boxes stored as two objects of a collision mesh: the loader unites them
    # into one (non-convex) body; its pieces for MuJoCo are the two boxes, not CoACD's
    a = trimesh.creation.box((1.0, 1.0, 1.0))
    b = trimesh.creation.box((2.0, 0.5, 0.5))
    b.apply_translation([0.8, 0.0, 0.0])
    scene = trimesh.Scene()
    scene.add_geometry(a, "a")
    scene.add_geometry(b, "b")
    path = tmp_path / "two.obj"
    scene.export(path)
    part = load_part(path)
    assert len(part.bodies) == 1 and not part.bodies[0].convex
    p = convex_pieces(part, cache=None)
    assert p.decomposed == 0 and len(p.pieces) == 2 and p.error == 0
    got = sorted(float(np.ptp(v[:, 0])) for v in p.pieces)
    assert got == pytest.approx([1.0, 2.0])
