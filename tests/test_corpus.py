"""Every mesh of the real-mesh corpus (meshes/corpus, made by nobody on this project) plans
through the command line, and every grasp passes the independent check; certified contact
regions are sampled densely and never break."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from synth import load_part
from synth.cli import main
from tests.independent_check import Pieces, check_document
from tests.robust_check import d_star_solve, sample_polygon, wrenches

CORPUS = Path(__file__).resolve().parent.parent / "meshes" / "corpus"
ENTRIES = json.loads((CORPUS / "corpus.json").read_text())


def _plan(entry: dict, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, str, str]:
    # a time cap far above the work keeps the outcome fixed by the seed and the budget alone
    args = ["plan", str(CORPUS / entry["file"]), "--json", "--no-files", "--time", "600",
            "--regions", *extra]
    if entry["units"]:
        args += ["--units", entry["units"]]
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_corpus_is_small_and_documented() -> None:
    files = {p.name for p in CORPUS.iterdir() if p.is_file()} - {"corpus.json", "README.md"}
    assert files == {e["file"] for e in ENTRIES}
    assert sum((CORPUS / f).stat().st_size for f in files) < 4_000_000
    readme = (CORPUS / "README.md").read_text()
    for e in ENTRIES:
        assert e["file"] in readme and e["licence"] and e["source_package"]
    assert len(ENTRIES) >= 35
    assert sum("compound" in e["kind"] for e in ENTRIES) >= 12
    assert sum("polyhedral" in e["kind"] and "compound" not in e["kind"] for e in ENTRIES) >= 10


@pytest.mark.parametrize("entry", ENTRIES, ids=[e["file"] for e in ENTRIES])
def test_corpus_mesh_plans_and_every_grasp_passes_the_independent_check(
        entry: dict, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _plan(entry, capsys)
    assert "internal error" not in err and "Traceback" not in err, err
    if entry["expect"] == "refused":
        assert code == 2 and err.strip().count("\n") == 0 and entry["file"] in err, err
        return
    if entry["expect"] == "friction":  # nearly a body of revolution (see corpus.json)
        doc = json.loads(out)
        assert code == 1 and not doc["grasps"], err
        assert "none within the physical floor" in doc["message"]
        assert "nearly free to rotate about" in doc["message"]
        assert ("try --mu > 0 with --contacts 3 or 4"
                in doc["message"])
        code, out, err = _plan(entry, capsys, "--mu", "0.5", "--contacts", "4")
    doc = json.loads(out)
    assert code == 0, err
    assert doc["grasps"], doc["message"]
    mesh = doc["mesh"]
    assert sum(b["faces"] for b in mesh["bodies"]) > 0 and mesh["repairs"] is not None
    failures = check_document(CORPUS / entry["file"], doc, Pieces(CORPUS / entry["file"]))
    assert not failures, "\n".join(failures[:20])
    _check_regions(doc)


@pytest.mark.parametrize("entry", [e for e in ENTRIES if e["expect"] != "refused"],
                         ids=[e["file"] for e in ENTRIES if e["expect"] != "refused"])
def test_corpus_part_surface_lies_on_the_file_surface(entry: dict) -> None:
    """The loader's repairs (welds, sliver flips and merges, unions, holes it fills) leave the
    surface where the file has it: 2,000 points sampled on the loaded part's faces are within
    the independent check's on-surface tolerance of the file's own triangles."""
    part = load_part(CORPUS / entry["file"], units=entry["units"] or None)
    tri = np.asarray(part.mesh.triangles)
    rng = np.random.default_rng(0)
    pick = rng.choice(len(tri), size=min(len(tri), 2000), replace=False)
    pts = np.einsum("fk,fkx->fx", rng.dirichlet([1.0, 1.0, 1.0], size=len(pick)), tri[pick])
    pieces = Pieces(CORPUS / entry["file"])
    off = pieces.distance(pts)
    assert off.max() <= pieces.tol, (f"a point of face {pick[np.argmax(off)]} is "
                                     f"{off.max():.3g} off the file's surface "
                                     f"(tolerance {pieces.tol:.3g}); repairs {part.repairs}")


def _check_regions(doc: dict) -> None:
    """100,000 uniform placements in every certified 7-contact grasp's regions, scored from
    the null vector of each wrench matrix (numpy): all form closure, none below the reported
    d_star_min."""
    rng = np.random.default_rng(0)
    center, length = np.array(doc["mesh"]["center_mass"]), doc["mesh"]["length"]
    for g in doc["grasps"]:
        reg = g["contact_regions"]
        assert reg is not None and reg["tolerance"] == g["tolerance"] >= 0
        if not reg["certified"] or len(g["points"]) != 7:
            continue
        n = 100_000
        pts = np.stack([sample_polygon(p, n, rng) for p in reg["polygons"]], axis=1)
        N = np.repeat(np.array(g["normals"])[None], n, axis=0)
        d = np.concatenate([d_star_solve(wrenches(pts[s:s + 25_000], N[s:s + 25_000], center,
                                                length)) for s in range(0, n, 25_000)])
        assert d.min() > 0, f"grasp {g['rank']}: a placement in its regions is not closure"
        assert d.min() >= reg["d_star_min"] - 1e-7, g["rank"]
