"""Grasp files from elsewhere: every field the simulation reads is checked, one by one."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from synth.errors import InputError
from synth.sim import check_document, read_grasp_file
from tests.sim_support import CUBE7, write_cube, write_grasps


@pytest.fixture
def doc(tmp_path):
    path = write_grasps(tmp_path, write_cube(tmp_path), *CUBE7)
    return json.loads(path.read_text())


def test_a_grasp_file_is_read(doc):
    f = check_document(doc, "g.json")
    g = f.grasps[0]
    assert f.mu == 0 and f.length == pytest.approx(np.sqrt(3)) and len(f.grasps) == 1
    assert g.points.shape == (7, 3) and g.tip_centers.shape == (7, 3) and g.tip_radius > 0
    assert g.measures["d_star"] == 0.5 and np.isnan(g.measures["tolerance"])


def _set(d, path, value):
    *head, last = path
    for key in head:
        d = d[key]
    if value is KeyError:
        del d[last]
    else:
        d[last] = value


@pytest.mark.parametrize("path, value, field", [
    (("format",), "acronym", "format"),
    (("version",), 2, "version"),
    (("mesh",), KeyError, "mesh"),
    (("mesh", "path"), 3, "mesh.path"),
    (("mesh", "length"), -1.0, "mesh.length"),
    (("mesh", "center_mass"), [0, 0], "mesh.center_mass"),
    (("params", "mu"), "0.5", "params.mu"),
    (("grasps",), {}, "grasps"),
    (("grasps", 0, "points"), [[0, 0]] * 7, "grasps[0].points"),
    (("grasps", 0, "normals"), [[0, 0, 2]] * 7, "grasps[0].normals[0]"),
    (("grasps", 0, "fingers", "tip_centers"), KeyError, "grasps[0].fingers.tip_centers"),
    (("grasps", 0, "fingers", "tip_radius"), 0, "grasps[0].fingers.tip_radius"),
    (("grasps", 0, "d_star"), float("nan"), "grasps[0].d_star"),
])
def test_every_field_is_checked(doc, path, value, field):
    bad = copy.deepcopy(doc)
    _set(bad, path, value)
    pattern = field.replace("[", ".").replace("]", ".")  # brackets match any character
    with pytest.raises(InputError, match=rf"g\.json: field {pattern}"):
        check_document(bad, "g.json")


@pytest.mark.parametrize("path, rows, words", [
    (("grasps", 0, "points"), 3, "g.json: grasps[0]: 3 points but 7 normals"),
    (("grasps", 0, "normals"), 6, "g.json: grasps[0]: 7 points but 6 normals"),
    (("grasps", 0, "fingers", "approach"), 1,
     "g.json: grasps[0]: 7 fingers.tip_centers but 1 fingers.approach rows"),
    (("grasps", 0, "fingers", "contact_finger"), 5,
     "g.json: grasps[0]: 7 points but 5 fingers.contact_finger entries"),
])
def test_fields_of_unequal_length_are_named_together(doc, path, rows, words):
    # points cut to 3 rows were blamed on the normals ("expected (3, 3) numbers")
    bad = copy.deepcopy(doc)
    bad["grasps"][0]["fingers"]["contact_finger"] = list(range(7))
    *head, last = path
    d = bad
    for key in head:
        d = d[key]
    d[last] = d[last][:rows]
    with pytest.raises(InputError) as e:
        check_document(bad, "g.json")
    assert str(e.value).startswith(words + "; expected as many ")


def test_files_that_are_not_grasp_files(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_grasp_file(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(InputError, match="bad.json: not JSON"):
        read_grasp_file(tmp_path / "bad.json")
    (tmp_path / "list.json").write_text("[]")  # a candidate list, named so
    with pytest.raises(InputError, match="a list of candidates"):
        read_grasp_file(tmp_path / "list.json")
    (tmp_path / "number.json").write_text("3")
    with pytest.raises(InputError, match="expected a synth.grasps JSON object, got int"):
        read_grasp_file(tmp_path / "number.json")


def test_a_relative_mesh_path_is_found_next_to_the_grasp_file(tmp_path, doc):
    write_cube(tmp_path)
    doc["mesh"]["path"] = "cube.stl"
    (tmp_path / "g.json").write_text(json.dumps(doc))
    assert read_grasp_file(tmp_path / "g.json").mesh_path == tmp_path / "cube.stl"


@pytest.mark.parametrize("fmt, what", [
    ("synth.scores", "a score file of contact sets (JSON written by synth score --out)"),
    ("synth.ranked", "a ranking of contact sets (JSON written by synth rank --out)"),
])
def test_another_synth_file_is_named_as_what_it_is(tmp_path, capsys, fmt, what):
    """A score file or a ranking of contact sets handed to synth sim was refused as "field
    format: expected 'synth.grasps', got 'synth.scores'": the message says what the file is
    and what synth sim takes (without mujoco: the file is read first)."""
    from synth.cli import main

    path = tmp_path / "x.json"
    path.write_text(json.dumps({"format": fmt, "version": 1, "candidates": []}))
    with pytest.raises(InputError) as e:
        read_grasp_file(path)
    assert str(e.value).startswith(f"{path}: {what}, not a plan; synth sim takes a grasp file "
                                   "written by synth plan --out"), e.value
    assert main(["sim", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"synth: error: {e.value}"
    assert "expected 'synth.grasps'" not in err


def test_a_list_of_candidates_is_named_so(tmp_path):
    """A candidate list (synth rank's and synth score's input) read "expected a synth.grasps
    JSON object, got list"."""
    path = tmp_path / "sets.json"
    path.write_text(json.dumps([{"points": [[0, 0, 0]] * 7}]))
    with pytest.raises(InputError, match=r"sets\.json: a list of candidates \(for synth rank or "
                                         r"synth score\), not a plan; synth sim takes"):
        read_grasp_file(path)
