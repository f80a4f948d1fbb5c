"""``synth sim`` and ``synth plan --sim``: labels in the JSON, one line for bad input."""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import pytest
import trimesh

pytest.importorskip("mujoco")

from synth.cli import main  # noqa: E402
from synth.sim import SimSettings  # noqa: E402
from tests.sim_support import CUBE6, CUBE7, write_cube, write_grasps, write_split_obj  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_sim_labels_every_grasp_in_place(tmp_path, capsys):
    path = write_grasps(tmp_path, write_cube(tmp_path), *CUBE6)
    assert main(["sim", str(path), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "0 of 1 grasps held" in out and "gravity +x   translate along +x" in out
    doc = json.loads(path.read_text())
    s = doc["grasps"][0]["sim"]
    assert s["held"] is False and s["failed_at"] == "gravity" and s["escape_cos"] > 0.98
    assert s["simulator"] == doc["sim"]["settings"]["simulator"] == "synth.sim 3"
    assert doc["sim"]["contact"]["condim"] == 1 and doc["sim"]["settings"]["grip"] == 10.0
    assert doc["grasps"][0]["d_star"] == 0.5  # the rest of the file is kept


def test_sim_out_and_no_files(tmp_path, capsys):
    path = write_grasps(tmp_path, write_cube(tmp_path), *CUBE6)
    before = path.read_text()
    assert main(["sim", str(path), "--out", str(tmp_path / "labelled.json"), "--quiet",
                 "--sim-shake", "0"]) == 0
    assert path.read_text() == before
    capsys.readouterr()
    assert "sim" in json.loads((tmp_path / "labelled.json").read_text())["grasps"][0]
    assert main(["sim", str(path), "--no-files", "--json", "--sim-shake", "0"]) == 0
    assert json.loads(capsys.readouterr().out)["grasps"][0]["sim"]["failed_at"] == "gravity"


def test_without_mujoco_the_command_names_the_extra(tmp_path, capsys, monkeypatch):
    path = write_grasps(tmp_path, write_cube(tmp_path), *CUBE6)
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco raises ImportError
    assert main(["sim", str(path)]) == 2
    assert "pip install 'synth[sim]'" in _one_line(capsys.readouterr().err)
    assert main(["plan", str(path.parent / "cube.stl"), "--sim", "--no-files"]) == 2
    assert "mujoco, which is not installed" in _one_line(capsys.readouterr().err)


def test_bad_input_is_one_line(tmp_path, capsys):
    mesh = write_cube(tmp_path)
    path = write_grasps(tmp_path, mesh, *CUBE6)
    assert main(["sim", str(path), "--sim-grip", "-1"]) == 2
    assert "--sim-grip" in _one_line(capsys.readouterr().err)
    # a mesh where the grasp file belongs is named as such, before any option is looked at
    assert main(["sim", str(mesh)]) == 2
    assert "a mesh file (STL), not a grasp file" in _one_line(capsys.readouterr().err)
    assert main(["sim", str(mesh), "--no-files"]) == 2
    assert "a mesh file (STL), not a grasp file" in _one_line(capsys.readouterr().err)
    doc = json.loads(path.read_text())
    doc["grasps"][0]["fingers"]["tip_radius"] = "big"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    assert main(["sim", str(bad)]) == 2
    assert "field grasps[0].fingers.tip_radius" in _one_line(capsys.readouterr().err)
    doc = json.loads(path.read_text())
    doc["mesh"]["sha256"] = hashlib.sha256(b"another mesh").hexdigest()
    bad.write_text(json.dumps(doc))
    assert main(["sim", str(bad)]) == 2
    assert "has changed since the grasps were planned" in _one_line(capsys.readouterr().err)
    doc["mesh"]["sha256"] = None
    doc["mesh"]["path"] = str(tmp_path / "gone.stl")
    bad.write_text(json.dumps(doc))
    assert main(["sim", str(bad)]) == 2
    assert "gone.stl: no such file" in _one_line(capsys.readouterr().err)
    assert main(["sim", str(bad), "--mesh", str(mesh), "--no-files", "--sim-shake", "0"]) == 0


def test_a_gripper_grasp_file_is_simulated_with_its_pads(tmp_path, capsys):
    from synth.part import load_part
    from synth.plan.gripper import GripperParams, plan_gripper
    from synth.sim.jaws import simulate_jaw_document

    mesh = ROOT / "meshes" / "cube.stl"
    part = load_part(mesh, units="cm")
    doc = plan_gripper(part, GripperParams(top=2, samples=60)).to_json()
    doc["mesh"].update(body="largest", sharp_angle=30.0)
    doc["mesh"].pop("path", None)  # a file of an older synth names no mesh
    path = tmp_path / "jaws.json"
    path.write_text(json.dumps(doc))
    assert main(["sim", str(path), "--sim-shake", "0"]) == 2
    assert "--mesh" in _one_line(capsys.readouterr().err)
    assert main(["sim", str(path), "--mesh", str(mesh), "--sim-shake", "0", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "2 of 2 grasps held" in text and "Franka" in text
    # N/weight to 3 decimals, as the plan's gripper table has it
    lines = text.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["#", "d*"])
    rows = [line.split() for line in lines[head + 1:head + 3]]
    assert [r[2] for r in rows] == [f"{g['measures']['squeeze_per_weight']:.3f}"
                                    for g in doc["grasps"]]
    got = [g["sim"] for g in json.loads(path.read_text())["grasps"]]
    want = [g["sim"] for g in simulate_jaw_document(doc, part, SimSettings(shake=0.0))[
        "grasps"]]
    untimed = [[{k: v for k, v in s.items() if k != "seconds"} for s in x] for x in (got, want)]
    assert untimed[0] == untimed[1]
    # --mu simulates with another coefficient; the plan's own stays in the file
    assert main(["sim", str(path), "--mesh", str(mesh), "--sim-shake", "0", "--quiet",
                 "--mu", "0.3"]) == 0
    capsys.readouterr()
    again = json.loads(path.read_text())
    assert again["model"]["mu"] == doc["model"]["mu"] and again["sim"]["contact"]["mu"] == 0.3
    # another mesh (larger, or the same moved), or a broken field, is one line naming it
    other = tmp_path / "big.stl"
    trimesh.creation.box(extents=[2.0, 2.0, 2.0]).export(other)
    moved = tmp_path / "moved.stl"
    trimesh.load(mesh).apply_translation([5.0, 0.0, 0.0]).export(moved)
    for wrong in (other, moved):
        assert main(["sim", str(path), "--mesh", str(wrong), "--no-files"]) == 2
        assert "not the mesh these grasps were planned on" in _one_line(
            capsys.readouterr().err)
    doc["grasps"][1]["contacts"] = doc["grasps"][1]["contacts"][:1]
    path.write_text(json.dumps(doc))
    assert main(["sim", str(path), "--mesh", str(mesh), "--no-files"]) == 2
    assert "field grasps[1].contacts: expected two contacts" in _one_line(
        capsys.readouterr().err)


def test_synth_sim_finds_the_planned_mesh_from_any_folder(tmp_path, capsys, monkeypatch):
    # the plan's file stores the mesh's path relative to itself: synth sim run from another
    # folder finds the mesh without --mesh, for point fingers and for a gripper
    (tmp_path / "plans").mkdir()
    (tmp_path / "elsewhere").mkdir()
    mesh = tmp_path / "cube.stl"
    mesh.write_bytes((ROOT / "meshes" / "cube.stl").read_bytes())
    monkeypatch.chdir(tmp_path)
    assert main(["plan", "cube.stl", "--units", "cm", "--top", "1", "--evals", "2000",
                 "--out", "plans/p.json", "--quiet"]) == 0
    assert main(["plan", "cube.stl", "--units", "cm", "--gripper", "franka", "--top", "1",
                 "--samples", "40", "--out", "plans/g.json", "--quiet"]) == 0
    monkeypatch.chdir(tmp_path / "elsewhere")
    (tmp_path / "elsewhere" / "copies").mkdir()
    for name in ("p.json", "g.json"):
        capsys.readouterr()
        assert main(["sim", f"../plans/{name}", "--sim-shake", "0", "--no-files",
                     "--quiet"]) == 0, capsys.readouterr().err
        assert "1 of 1 grasps held" in capsys.readouterr().out
        # a labelled copy written into another folder names the mesh from there
        assert main(["sim", f"../plans/{name}", "--sim-shake", "0", "--quiet",
                     "--out", f"copies/{name}"]) == 0
        stored = json.loads((tmp_path / "elsewhere" / "copies" / name).read_text())
        assert (tmp_path / "elsewhere" / "copies" / stored["mesh"]["path"]).resolve() == \
            mesh.resolve()
    # a mesh that moved is named, with the option that finds it
    mesh.rename(tmp_path / "moved.stl")
    for name in ("p.json", "g.json"):
        capsys.readouterr()
        assert main(["sim", f"../plans/{name}", "--no-files"]) == 2
        err = _one_line(capsys.readouterr().err)
        assert "no such file" in err and "--mesh" in err


@pytest.mark.parametrize("split", ["normal", "uv"])
def test_split_vertex_obj_files_are_labelled_as_their_welded_copy(tmp_path, capsys, split):
    # the same grasp of the same cube, planned on an OBJ whose vertices are split along
    # normal or texture seams and on a welded copy: the simulation sees the planned part
    # (welded) in both, so the labels are the same
    split_mesh = write_split_obj(tmp_path, split)
    welded = tmp_path / "welded.obj"
    trimesh.load(split_mesh, force="mesh").export(welded)  # trimesh merges on loading
    labels = []
    for mesh in (split_mesh, welded):
        path = write_grasps(tmp_path, mesh, *CUBE7, name=f"{mesh.stem}.json")
        assert main(["sim", str(path), "--quiet", "--sim-shake", "0"]) == 0
        capsys.readouterr()
        lab = json.loads(path.read_text())["grasps"][0]["sim"]
        labels.append({k: v for k, v in lab.items() if k not in ("seconds", "steps")})
    assert labels[0] == labels[1] and labels[0]["held"] is True


def test_a_simulation_synth_cannot_run_keeps_the_plan(tmp_path, capsys, monkeypatch):
    # synth's own failure (here a MuJoCo compile's) is never bad input and never loses the
    # plan: the files are written and each grasp's label says why it was not simulated
    import synth.sim.jaws  # noqa: F401  (imported first, it keeps the real compile_spec)
    import synth.sim.scene as scene

    def broken(spec):
        raise scene.SimulationError("MuJoCo cannot load the scene: boom")

    monkeypatch.setattr(scene, "compile_spec", broken)
    out = tmp_path / "bracket.grasps.json"
    assert main(["plan", str(ROOT / "meshes" / "bracket.stl"), "--units", "dm", "--sim",
                 "--top", "2", "--evals", "2000", "--quiet", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    doc = json.loads(out.read_text())
    n = len(doc["grasps"])
    assert n >= 1 and f"0 of {n} grasps held, {n} not simulated (see each label)" in text
    assert out.with_suffix(".png").exists() and out.with_suffix(".glb").exists()
    assert [g["sim"]["failed_at"] for g in doc["grasps"]] == ["error"] * n
    assert all(g["sim"]["held"] is None and "boom" in g["sim"]["reason"]
               for g in doc["grasps"])


def test_plan_sim_stores_a_label_per_grasp(tmp_path, capsys):
    mesh = write_cube(tmp_path)
    out = tmp_path / "cube.grasps.json"
    assert main(["plan", str(mesh), "--sim", "--top", "1", "--evals", "2000", "--quiet",
                 "--out", str(out), "--sim-shake", "0"]) == 0
    doc = json.loads(out.read_text())
    assert doc["mesh"]["load"] == {"units": None, "body": "largest", "sharp_angle": 30.0,
                                   "decimate": None}
    assert all("sim" in g for g in doc["grasps"]) and doc["sim"]["held"] >= 1
    assert "grasps held" in capsys.readouterr().out


def test_fields_the_simulation_does_not_read_are_left_alone(tmp_path, capsys):
    # a point-finger grasp may carry other fields (here a stray 'measures'); the table reads
    # the checked d_star and conditioning, and the field is written back untouched
    path = write_grasps(tmp_path, write_cube(tmp_path), *CUBE6)
    doc = json.loads(path.read_text())
    doc["grasps"][0]["measures"] = "x"
    path.write_text(json.dumps(doc))
    assert main(["sim", str(path), "--sim-shake", "0", "--quiet"]) == 0
    assert "grasps held" in capsys.readouterr().out
    assert json.loads(path.read_text())["grasps"][0]["measures"] == "x"


def _plan_and_rank(mesh: Path, folder: Path, top: int) -> tuple[Path, Path]:
    """A Franka plan of ``mesh`` (in cm) and the ranking of its own poses, as files."""
    plan, ranked = folder / "plan.json", folder / "ranked.json"
    assert main(["plan", str(mesh), "--units", "cm", "--gripper", "franka", "--samples", "60",
                 "--top", str(top), "--out", str(plan), "--quiet"]) == 0
    assert main(["rank", str(mesh), str(plan), "--gripper", "franka", "--units", "cm",
                 "--out", str(ranked), "--quiet"]) == 0
    return plan, ranked


def test_a_ranking_of_poses_from_elsewhere_is_simulated(tmp_path, capsys):
    """``synth rank --gripper`` of a plan's own poses, then ``synth sim`` of the ranking: the
    candidates that landed get the labels the plan's grasps get, in place; the others none."""
    mesh = ROOT / "meshes" / "cube.stl"
    plan, ranked = _plan_and_rank(mesh, tmp_path, 2)
    doc = json.loads(ranked.read_text())
    doc["candidates"].append({**doc["candidates"][0], "status": "collision", "index": 2})
    ranked.write_text(json.dumps(doc))
    capsys.readouterr()
    assert main(["sim", str(plan), "--sim-shake", "0", "--quiet"]) == 0
    assert main(["sim", str(ranked), "--sim-shake", "0", "--quiet"]) == 0
    assert "2 of 2 grasps held" in capsys.readouterr().out
    want = [g["sim"] for g in json.loads(plan.read_text())["grasps"]]
    got = json.loads(ranked.read_text())
    assert got["sim"]["settings"] == json.loads(plan.read_text())["sim"]["settings"]
    for c in got["candidates"][:2]:
        w = want[c["index"]]
        assert (c["sim"]["held"], c["sim"]["failed_at"], c["sim"]["gravity_held"]) == (
            w["held"], w["failed_at"], w["gravity_held"])
    assert "sim" not in got["candidates"][2]


def test_a_ranking_without_a_unit_takes_its_scale_and_one_with_no_landing_is_refused():
    from synth.sim.document import ranking_as_jaw_document

    contact = {"point": [0.0, 0.0, 0.0], "normal": [1.0, 0.0, 0.0]}
    ok = {"status": "ok", "pose": [[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
          "width": 40.0, "contacts": [contact, contact], "measures": {"d_star": 1.0}}
    doc = {"format": "synth.ranked_gripper", "version": 1,
           "mesh": {"path": "m.obj", "units": None, "metres_per_unit": 0.00025, "length": 600.0,
                    "load": {"units": None, "body": "largest", "sharp_angle": 30.0,
                             "decimate": None}},
           "gripper": {"name": "franka", "source": "franka"},
           "model": {"mu": 0.5, "torsion": 20.0},
           "candidates": [{"status": "collision"}, ok]}
    jaws, rows = ranking_as_jaw_document(doc, "r.json")
    assert rows == [1] and jaws["grasps"] == [ok]
    assert jaws["mesh"]["units"] == jaws["mesh"]["load"]["units"] == "0.00025*m"
    assert doc["mesh"]["units"] is None  # the ranking itself is left as it was
    doc["candidates"] = [{"status": "collision"}, {**ok, "pose": [[1.0, 2.0]]}]
    with pytest.raises(ValueError, match=r"candidates\[1\]\.pose: expected a 4 x 4 matrix"):
        ranking_as_jaw_document(doc, "r.json")  # named by its place among the candidates
    doc["candidates"] = [{"status": "collision"}]
    with pytest.raises(ValueError, match="none of its 1 candidates landed"):
        ranking_as_jaw_document(doc, "r.json")
    doc["candidates"], doc["mesh"] = [ok], "m.obj"
    with pytest.raises(ValueError, match="field mesh: expected an object"):
        ranking_as_jaw_document(doc, "r.json")


def test_top_simulates_the_first_grasps_and_leaves_no_stale_label(tmp_path, capsys):
    """``--top N`` simulates a file's first N grasps (a ranking's first N that landed); the
    others carry no label afterwards, not even one of an earlier run."""
    mesh = ROOT / "meshes" / "cube.stl"
    plan, ranked = _plan_and_rank(mesh, tmp_path, 3)
    points = tmp_path / "points.json"
    assert main(["plan", str(mesh), "--units", "cm", "--evals", "2000", "--top", "3",
                 "--out", str(points), "--quiet"]) == 0
    for path, key in ((plan, "grasps"), (ranked, "candidates"), (points, "grasps")):
        assert main(["sim", str(path), "--sim-shake", "0", "--quiet"]) == 0
        assert all("sim" in g for g in json.loads(path.read_text())[key])
        assert main(["sim", str(path), "--sim-shake", "0", "--quiet", "--top", "1"]) == 0
        assert "1 of 1 grasps held" in capsys.readouterr().out
        assert ["sim" in g for g in json.loads(path.read_text())[key]] == [True, False, False]
    assert main(["sim", str(plan), "--top", "1001", "--no-files"]) == 2
    assert "--top" in _one_line(capsys.readouterr().err)


def test_a_gripper_description_file_is_found_from_anywhere(tmp_path, capsys, monkeypatch):
    """A plan made with a gripper description file stores it relative to the plan (as the
    mesh), so synth sim finds it from another folder, and a labelled copy written elsewhere
    names it from there."""
    for d in ("hands", "plans", "elsewhere", "copies"):
        (tmp_path / d).mkdir()
    hand = tmp_path / "hands" / "my_2f85.json"  # boxes only: no mesh files beside it
    hand.write_text((ROOT / "synth" / "fingers" / "grippers" / "robotiq_2f85.json").read_text())
    mesh = tmp_path / "cube.stl"
    mesh.write_bytes((ROOT / "meshes" / "cube.stl").read_bytes())
    monkeypatch.chdir(tmp_path)
    assert main(["plan", "cube.stl", "--units", "cm", "--gripper", "hands/my_2f85.json",
                 "--top", "1", "--samples", "40", "--out", "plans/g.json", "--quiet"]) == 0
    stored = json.loads((tmp_path / "plans" / "g.json").read_text())["gripper"]["source"]
    assert (tmp_path / "plans" / stored).resolve() == hand.resolve()
    monkeypatch.chdir(tmp_path / "elsewhere")
    capsys.readouterr()
    assert main(["sim", "../plans/g.json", "--sim-shake", "0", "--quiet",
                 "--out", "../copies/g.json"]) == 0, capsys.readouterr().err
    copy = json.loads((tmp_path / "copies" / "g.json").read_text())
    assert (tmp_path / "copies" / copy["gripper"]["source"]).resolve() == hand.resolve()
    assert copy["grasps"][0]["sim"]["held"] is True


def test_a_folder_or_missing_file_given_as_mesh_is_named_for_its_option(tmp_path, capsys):
    grasps = write_grasps(tmp_path, write_cube(tmp_path), *CUBE7)
    (tmp_path / "folder").mkdir()
    for mesh, words in ((tmp_path / "folder", "is a folder, not a mesh file"),
                        (tmp_path / "none.stl", "none.stl: no such file")):
        capsys.readouterr()
        assert main(["sim", str(grasps), "--mesh", str(mesh), "--no-files"]) == 2
        err = _one_line(capsys.readouterr().err)
        assert err.startswith("synth: error: --mesh: ") and words in err, err
        assert "mesh.path" not in err
    # the file's own mesh.path naming a folder is named so too
    doc = json.loads(grasps.read_text())
    doc["mesh"]["path"], doc["mesh"]["sha256"] = str(tmp_path / "folder"), None
    grasps.write_text(json.dumps(doc))
    assert main(["sim", str(grasps), "--no-files"]) == 2
    err = _one_line(capsys.readouterr().err)
    assert "field mesh.path" in err and "is a folder, not a mesh file" in err, err


def test_a_gripper_plan_of_a_small_part_simulates(tmp_path, capsys):
    """Every file synth plan writes, synth sim reads: a 1 mm cube held by a Franka Hand keeps
    MuJoCo's default torsional coefficient of the pads, 5 mm, larger than the part."""
    mesh = Path(__file__).resolve().parent.parent / "meshes" / "cube.stl"
    out = tmp_path / "gp.json"
    assert main(["plan", str(mesh), "--gripper", "franka", "--units", "mm", "--top", "1",
                 "--samples", "40", "--out", str(out), "--quiet"]) == 0
    assert json.loads(out.read_text())["model"]["torsion"] == pytest.approx(5.0)
    capsys.readouterr()
    code = main(["sim", str(out), "--no-files"])
    text = capsys.readouterr()
    assert code == 0, text.err
    assert "1 of 1 grasps held" in text.out


def test_sim_labels_a_document_in_place_whatever_its_key_order(tmp_path, capsys):
    """A grasp file re-saved with sorted keys (jq, json.dump(sort_keys=True)) is still the
    document sim reads and labels in place."""
    grasps = write_grasps(tmp_path, write_cube(tmp_path), *CUBE7)
    doc = json.loads(grasps.read_text())
    grasps.write_text(json.dumps(doc, sort_keys=True))
    capsys.readouterr()
    assert main(["sim", str(grasps), "--quiet"]) == 0, capsys.readouterr().err
    assert "sim" in json.loads(grasps.read_text())["grasps"][0]


@pytest.mark.parametrize(("edit", "words"), [
    (lambda g: g["points"].__setitem__(0, [5.0, 5.0, 5.0]), "from the part's surface"),
    (lambda g: g["normals"].__setitem__(0, [-x for x in g["normals"][0]]),
     "fingertip 0 is not one tip radius outside contact 0"),
    (lambda g: g["points"].__setitem__(0, [1e300, 0.0, 0.0]), "above 1e+15 in size"),
])
def test_a_grasp_edited_off_the_part_is_not_held(tmp_path, capsys, edit, words):
    """A contact moved off the part, a normal turned over, a coordinate past the limit: the
    grasp no longer touches the part where its fingers are, so it is labelled not held at the
    start with the reason (its fingers alone were simulated, and held, before); the file's
    other grasps are simulated as before."""
    grasps = write_grasps(tmp_path, write_cube(tmp_path), *CUBE7)
    doc = json.loads(grasps.read_text())
    doc["grasps"].append(json.loads(json.dumps(doc["grasps"][0])))
    edit(doc["grasps"][0])
    grasps.write_text(json.dumps(doc))
    capsys.readouterr()
    assert main(["sim", str(grasps), "--quiet"]) == 0, capsys.readouterr().err
    first, second = (g["sim"] for g in json.loads(grasps.read_text())["grasps"])
    assert first["held"] is False and first["failed_at"] == "start", first
    assert words in first["reason"], first["reason"]
    assert second["held"] is True


def test_the_summary_says_in_words_what_was_simulated():
    """The summary line names the protocol's document and says what a faceted body is (it
    read 'protocol synth.sim 3' and '1 non-convex body collided as its facets')."""
    from synth.cli.sim import summary

    doc = {"format": "synth.grasps", "grasps": [{}, {}],
           "sim": {"held": 2, "seconds": 1.25, "faceted_bodies": 1,
                   "settings": {**SimSettings().to_dict(), "simulator": "synth.sim 3"}}}
    line = summary(doc)
    assert line.startswith("2 of 2 grasps held (balanced point fingers, grip 10 N each, part "
                           "scaled to 0.1 m; weight along +-x, +-y, +-z, shake 1 g; the "
                           "protocol of synth.sim 3, docs/simulation.md); 1 non-convex body "
                           "of the part simulated as thin convex slabs under the facets near "
                           "the hand, as MuJoCo collides convex shapes; 1.2 s"), line
    doc["sim"]["faceted_bodies"] = 0
    assert "slabs" not in summary(doc) and (ROOT / "docs" / "simulation.md").exists()


def test_grasps_left_out_by_top_are_said(tmp_path, capsys):
    """--top 1 of a file of two grasps: one simulated, and a line says one more was left
    without a label (the summary said only '1 of 1 grasps held')."""
    path = write_grasps(tmp_path, write_cube(tmp_path), *CUBE7)
    doc = json.loads(path.read_text())
    doc["grasps"].append(dict(doc["grasps"][0], rank=2))
    path.write_text(json.dumps(doc))
    assert main(["sim", str(path), "--top", "1", "--sim-shake", "0"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "1 more grasp of the file left without a label (--top 1)" in lines
    assert "sim" not in json.loads(path.read_text())["grasps"][1]
    assert main(["sim", str(path), "--sim-shake", "0"]) == 0  # all of them: no such line
    assert not any("left without a label" in line
                   for line in capsys.readouterr().out.splitlines())
