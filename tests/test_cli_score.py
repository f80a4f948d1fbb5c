"""``synth score`` end to end: good files, every kind of malformed input."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from synth.cli import main
from synth.grasps import read_candidates

CUBE_FC = {
    "name": "good",
    "points": [[.5, .1, .1], [-.5, -.1, -.1], [.1, .5, .1], [-.1, -.5, -.1],
               [.2, .2, -.5], [-.2, .2, -.5], [.2, .4, .5]],
}
CUBE_FC["normals"] = (-np.sign(CUBE_FC["points"]) * (np.abs(CUBE_FC["points"]) == 0.5)).tolist()
NO_TOP = {
    "name": "no-top",
    "points": [[.5, .2, 0], [-.5, -.2, 0], [.1, .5, 0], [-.3, -.5, 0], [.2, .1, -.5],
               [-.2, .3, -.5], [.3, -.3, -.5]],
    "normals": [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1], [0, 0, 1]],
}


def _write(tmp_path, obj, name="c.json"):
    p = tmp_path / name
    p.write_text(json.dumps(obj))
    return p


def test_ranked_table_and_json(tmp_path, capsys):
    f = _write(tmp_path, {"candidates": [NO_TOP, CUBE_FC]})
    out = tmp_path / "out.json"
    assert main(["score", str(f), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.index("good") < text.index("no-top")
    assert "free to translate along +z" in text
    doc = json.loads(out.read_text())
    assert [c["name"] for c in doc["candidates"]] == ["good", "no-top"]
    assert [c["rank"] for c in doc["candidates"]] == [1, 2]
    assert doc["candidates"][0]["d_star"] == pytest.approx(0.5)
    assert doc["candidates"][0]["closure"] == "form"


def test_npz_and_friction(tmp_path, capsys):
    P = np.array([CUBE_FC["points"], NO_TOP["points"]], dtype=float)
    N = np.array([CUBE_FC["normals"], NO_TOP["normals"]], dtype=float)
    f = tmp_path / "c.npz"
    np.savez(f, points=P, normals=N)
    assert len(read_candidates(f)) == 2
    assert main(["score", str(f), "--mu", "0.5", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {c["closure"] for c in doc["candidates"]} == {"frictional form"}


BAD = [
    ({"candidates": [{"points": [[0, 0, 1]] * 7}]}, "candidate 0: missing field 'normals'"),
    ({"candidates": [dict(NO_TOP, normals=NO_TOP["normals"][:6])]}, "shape"),
    ({"candidates": [dict(NO_TOP, points=[[float("nan"), 0, 0]] + NO_TOP["points"][1:])]},
     "field 'points' row 0 is not finite"),
    ({"candidates": [CUBE_FC, dict(NO_TOP, normals=[[0, 0, 0]] + NO_TOP["normals"][1:])]},
     "candidate 1 (no-top): field 'normals' row 0 has zero length"),
    ({"candidates": [dict(NO_TOP, points=NO_TOP["points"][:5], normals=NO_TOP["normals"][:5])]},
     "5 contacts, but at least 7"),
    ({"something": []}, "expected a list"),
    ([], "holds no candidates"),
]


@pytest.mark.parametrize("obj, message", BAD)
def test_malformed_input_one_line_each_no_traceback(tmp_path, obj, message):
    f = _write(tmp_path, obj)
    proc = subprocess.run([sys.executable, "-m", "synth", "score", str(f)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.strip().splitlines() if line.startswith("synth: ")]
    assert len(errors) == 1 and errors[0].startswith("synth: error: ")
    assert message in errors[0]
    assert str(f) in errors[0] or "candidate" in errors[0]


def test_a_bad_candidate_does_not_stop_the_others(tmp_path):
    bad = dict(NO_TOP, name="broken", normals=[[0, 0, 0]] + NO_TOP["normals"][1:])
    f = _write(tmp_path, {"candidates": [NO_TOP, bad, CUBE_FC, {"name": "x"}]})
    out = tmp_path / "out.json"
    proc = subprocess.run([sys.executable, "-m", "synth", "score", str(f), "--out", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("synth: error:")]
    assert len(errors) == 2
    assert "candidate 1 (broken): field 'normals' row 0 has zero length" in errors[0]
    assert "candidate 3 (x): missing field 'points'" in errors[1]
    assert proc.stdout.index("good") < proc.stdout.index("no-top")
    doc = json.loads(out.read_text())
    assert [(c["rank"], c["name"]) for c in doc["candidates"]] == [(1, "good"), (2, "no-top")]
    assert [e["index"] for e in doc["errors"]] == [1, 3]


def test_closure_ranks_above_rank_deficient_grasps(tmp_path, capsys):
    """A grasp with d* > 0 but rank < 6 is not form closure and never outranks one."""
    flat = {"name": "flat", "points": [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0],
                                       [0.5, 0.5, 0], [-0.5, -0.5, 0], [0.5, -0.5, 0]],
            "normals": [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [-1, -1, 0], [1, 1, 0],
                        [-1, 1, 0]]}
    f = _write(tmp_path, [flat, CUBE_FC])
    assert main(["score", str(f), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [c["name"] for c in doc["candidates"]] == ["good", "flat"]
    assert doc["candidates"][1]["closure"] == "force" and doc["candidates"][1]["d_star"] > 0
    assert doc["candidates"][1]["matrix_rank"] < 6


def test_unreadable_files(tmp_path, capsys):
    assert main(["score", str(tmp_path / "missing.json")]) == 2
    junk = tmp_path / "junk.json"
    junk.write_bytes(b"\x00\xff not json")
    assert main(["score", str(junk)]) == 2
    npz = tmp_path / "bad.npz"
    npz.write_bytes(b"PK not a zip")
    assert main(["score", str(npz)]) == 2
    err = capsys.readouterr().err
    assert err.count("synth: error:") == 3 and "Traceback" not in err


def test_the_count_line_is_singular_for_one_candidate(tmp_path, capsys):
    """"1 candidates scored" read wrong."""
    assert main(["score", str(_write(tmp_path, [CUBE_FC]))]) == 0
    assert capsys.readouterr().err.strip() == "1 candidate scored, 1 with closure"
    assert main(["score", str(_write(tmp_path, [CUBE_FC, NO_TOP]))]) == 0
    assert capsys.readouterr().err.strip() == "2 candidates scored, 1 with closure"
