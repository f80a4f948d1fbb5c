"""Grasps counted in fingers (synth.plan.placements, ``synth plan --fingers``).

Every grasp is verified by the independent check (tests/independent_check.py), which solves
d* again with scipy and re-derives each fingertip from its contacts.
"""

from __future__ import annotations

import json
from pathlib import Path

import manifold3d as mf
import numpy as np
import pytest
import trimesh

from synth import PlanParams, load_part
from synth.cli import main
from synth.errors import InputError
from synth.fingers import default_fingers
from synth.plan.placements import placement_pool, placement_seeds
from tests.independent_check import Pieces, check_document

BRACKET = Path(__file__).resolve().parent.parent / "meshes" / "bracket.stl"


@pytest.fixture(scope="module")
def vgroove(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2 x 1 x 1 block with a 90-degree V-groove along x across its top face."""
    block = mf.Manifold.cube((2.0, 1.0, 1.0), center=True)
    cut = mf.Manifold.cube((3.0, 0.5, 0.5), center=True).rotate((45, 0, 0)).translate(
        (0, 0, 0.5))
    m = (block - cut).to_mesh()
    path = tmp_path_factory.mktemp("vgroove") / "vgroove.stl"
    trimesh.Trimesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts)).export(path)
    return path


def _plan(path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, dict, str]:
    # a time cap far above the work keeps the outcome fixed by --seed and --evals alone
    code = main(["plan", str(path), "--json", "--no-files", "--seed", "0", "--top", "3",
                 "--time", "600", *extra])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out.strip() else {}), out.err


def _fingers_of(grasp: dict) -> np.ndarray:
    return np.asarray(grasp["fingers"]["contact_finger"])


def test_groove_placements_seat_one_tip_on_both_faces(vgroove: Path) -> None:
    part = load_part(vgroove)
    fingers = default_fingers(part)
    r = fingers.tip_radius
    pool = placement_pool(part, fingers, np.random.default_rng(0), 300, 300, 50)
    two = np.flatnonzero(pool.count == 2)
    assert len(two) > 10 and (pool.count == 3).sum() == 0  # the groove is open at both ends
    P, N = pool.points[two, :2], pool.normals[two, :2]
    centres = P - r * N  # the tip each contact alone would take (inward normals)
    assert np.abs(centres[:, 0] - centres[:, 1]).max() < 1e-9 * part.length
    # the two contacts are on the groove's two faces (inward normals (0, +-1, -1) / sqrt 2)
    # and on the mesh itself
    assert np.allclose(N[..., 1].sum(axis=1), 0.0) and np.allclose(N[..., 2], -np.sqrt(0.5))
    mesh = trimesh.load(vgroove)
    _, dist, _ = trimesh.proximity.closest_point(mesh, P.reshape(-1, 3))
    assert dist.max() < 1e-9 * part.length
    # the crease runs along y = 0 at z = 0.5 - 0.25 sqrt 2 (the cut is a 0.5 square turned
    # 45 degrees about x, centred on the top face); a tip of radius r in the 90-degree groove
    # has its centre r sqrt 2 above the crease
    crease_z = 0.5 - np.sqrt(2) * 0.25
    assert np.allclose(centres[:, 0, 1], 0.0, atol=1e-9)
    assert np.allclose(centres[:, 0, 2], crease_z + r * np.sqrt(2), atol=1e-9)


def test_seeds_give_grooves_a_fair_share() -> None:
    part = load_part(BRACKET)
    pool = placement_pool(part, default_fingers(part), np.random.default_rng(1), 600, 200, 60)
    seeds = placement_seeds(pool, 4000, 4, np.random.default_rng(2))
    assert (np.diff(np.sort(seeds, axis=1), axis=1) > 0).all()  # distinct placements
    in_pool = np.bincount(pool.count, minlength=4)[1:] / len(pool)
    in_seeds = np.bincount(pool.count[seeds].ravel(), minlength=4)[1:] / seeds.size
    # grooves and the one inside corner are a few percent of the placements, but a fingertip
    # is about as likely to go there as onto a face (a set holds the corner at most once)
    assert (in_pool[1:] < 0.1).all() and (in_seeds > 0.2).all(), (in_pool, in_seeds)


def test_vgroove_block_is_held_by_five_fingers(vgroove: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    code, doc, err = _plan(vgroove, capsys, "--fingers", "5")
    assert code == 0, err
    assert not check_document(vgroove, doc, Pieces(vgroove))
    for g in doc["grasps"]:
        ids = _fingers_of(g)
        assert len(set(ids.tolist())) == 5 and len(ids) >= 7 and g["d_star"] > 0
        assert np.bincount(ids).max() == 2  # at least one tip sits in the groove


def test_vgroove_block_cannot_be_held_by_four_fingers(
        vgroove: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Frictionless form closure needs 7 contacts with normals in at least 4 directions. A tip
    in the groove makes 2 contacts, always with the groove's same 2 normals; 4 tips with 7
    contacts need 3 in the groove, which leaves 3 directions. So no 4-finger grasp exists, and
    the planner must not report one."""
    code, doc, err = _plan(vgroove, capsys, "--fingers", "4")
    assert code == 1 and not doc["grasps"], err
    assert "no form-closure grasp with 4 fingers" in doc["message"]


def test_three_fingers_that_cannot_make_seven_contacts_are_explained(
        vgroove: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, doc, err = _plan(vgroove, capsys, "--fingers", "3")
    assert code == 1 and not doc["grasps"], err
    assert "3 fingers cannot make the 7 contacts" in doc["message"]
    assert "at most 2" in doc["message"]


def test_auto_holds_the_bracket_with_fewer_than_seven_fingers(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, doc, err = _plan(BRACKET, capsys, "--fingers", "auto")
    assert code == 0, err
    assert not check_document(BRACKET, doc, Pieces(BRACKET))
    n = {len(set(_fingers_of(g).tolist())) for g in doc["grasps"]}
    assert len(n) == 1 and n.pop() < 7
    assert f"with {len(set(_fingers_of(doc['grasps'][0]).tolist()))} fingers" in doc["message"]


@pytest.mark.parametrize("value", [1, 13, "many", 2.5])
def test_finger_counts_are_validated(value: object) -> None:
    with pytest.raises(InputError, match="fingers: expected"):
        PlanParams(fingers=value)  # type: ignore[arg-type]


def test_cli_refuses_a_bad_finger_count(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["plan", str(BRACKET), "--no-files", "--fingers", "lots"])
    err = capsys.readouterr().err
    assert code == 2 and err.strip().count("\n") == 0 and "--fingers" in err, err
