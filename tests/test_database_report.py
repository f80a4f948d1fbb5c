"""What loading did to each mesh, in a grasp database (``meshes.mesh_report``, schema 2).

A real-planner build over meshes whose loading differs (two objects far apart, a clean box, a
box with flipped faces, a broken file), the report kept from plugged-in planners, ``synth db
info`` and the exports, and schema-1 files: read as they are, migrated when a build writes.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

import synth
from synth.cli import main
from synth.database import GraspDatabase, build_database, export_database
from synth.database.schema import SCHEMA_VERSION, canonical_json
from synth.database.worker import mesh_report, run_one
from synth.errors import DatabaseError
from synth.plan import plan_mesh_file
from tests.db_support import PARAMS, PLANNER, make_mesh_dir, snapshot, write_v1_copy

REAL_PARAMS = {"evals": 1000, "top": 2, "seed": 0}  # small budget; still 2 grasps on boxes
LOADED = ("two.stl", "clean.stl", "flip.stl", "ball.stl")


def _write_meshes(d: Path) -> None:
    d.mkdir()
    far = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    far.apply_translation((30.0, 0.0, 0.0))
    trimesh.util.concatenate([trimesh.creation.box(), far]).export(d / "two.stl")
    trimesh.creation.box(extents=(1.0, 2.0, 3.0)).export(d / "clean.stl")
    box = trimesh.creation.box()
    faces = box.faces.copy()
    faces[:2] = faces[:2, ::-1]  # two faces wound the wrong way: the loader re-orients them
    trimesh.Trimesh(box.vertices, faces, process=False).export(d / "flip.stl")
    trimesh.creation.icosphere(subdivisions=2).export(d / "ball.stl")  # no frictionless grasp
    (d / "empty.stl").write_bytes(b"")


@pytest.fixture(scope="module")
def real(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(mesh folder, database) built in this process with the real planner."""
    root = tmp_path_factory.mktemp("report")
    mesh_dir = root / "meshes"
    _write_meshes(mesh_dir)
    out = root / "grasps.sqlite"
    env = os.environ.pop("SYNTH_DB_PLANNER", None)
    try:
        build_database([mesh_dir], out, REAL_PARAMS, workers=0, quiet=True)
    finally:
        if env is not None:
            os.environ["SYNTH_DB_PLANNER"] = env
    return mesh_dir, out


def _expected_report(path: Path) -> dict[str, Any]:
    mesh = dict(plan_mesh_file(path, REAL_PARAMS)["mesh"])
    del mesh["path"], mesh["sha256"]
    return mesh


def test_real_build_stores_what_loading_did(real: tuple[Path, Path]) -> None:
    mesh_dir, out = real
    with GraspDatabase(out) as db:
        assert db.schema_version == SCHEMA_VERSION == 4
        by_name = {m.name: m for m in db.meshes()}
        assert {n: m.status for n, m in by_name.items()} == {
            "two.stl": "done", "clean.stl": "done", "flip.stl": "done", "ball.stl": "failed",
            "empty.stl": "failed",
        }  # fmt: skip
        assert by_name["ball.stl"].error_kind == "no_grasp"  # planned: its report is kept
        for name in LOADED:
            m, part = by_name[name], synth.load_part(mesh_dir / name)
            assert m.report is not None and "path" not in m.report and "sha256" not in m.report
            assert m.report == _expected_report(mesh_dir / name)  # the plan document's mesh
            assert m.report["units"] == m.units and m.report["length"] == m.length
            assert m.report["dropped"] == list(part.dropped)
            assert m.report["repairs"] == list(part.repairs)
            assert m.report["warnings"] == list(part.warnings)
            assert {"precision", "center_mass", "volume", "bodies"} <= set(m.report)
        two = by_name["two.stl"].report
        assert len(two["dropped"]) == 1  # the small far box; its line is load_part's
        assert len(two["bodies"]) == 1 and two["bodies"][0]["faces"] == 12
        assert math.isclose(two["volume"], 1.0)
        clean = by_name["clean.stl"].report
        assert clean["repairs"] == [] and clean["dropped"] == []
        assert math.isclose(clean["volume"], 6.0)
        assert len(by_name["flip.stl"].report["repairs"]) == 1  # re-oriented faces
        assert by_name["empty.stl"].report is None  # failed before planning
    conn = sqlite3.connect(out)
    raw = dict(conn.execute("SELECT name, mesh_report FROM meshes").fetchall())
    conn.close()
    assert raw["empty.stl"] is None
    assert raw["two.stl"] == canonical_json(by_name["two.stl"].report)  # canonical JSON text


def test_info_counts_loading(real: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    mesh_dir, out = real
    parts = [synth.load_part(mesh_dir / n) for n in LOADED]
    expected = {
        "with_report": 4,
        "repaired": 1,
        "with_dropped": 1,
        "with_warnings": sum(bool(p.warnings) for p in parts),
    }
    with GraspDatabase(out) as db:
        info = db.info()
    assert {k: getattr(info, k) for k in expected} == expected
    assert main(["db", "info", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {k: doc[k] for k in expected} == expected and doc["schema_version"] == SCHEMA_VERSION
    assert main(["db", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert (
        f"loading: 1 mesh repaired, 1 with dropped objects, {expected['with_warnings']} with "
        "warnings (of 4 with a loading report)"
    ) in text


def test_exports_carry_the_report(real: tuple[Path, Path], tmp_path: Path) -> None:
    _, out = real
    with GraspDatabase(out) as db:
        reports = {m.id: m.report for m in db.meshes()}
    export_database(out, tmp_path / "e.json")
    doc = json.loads((tmp_path / "e.json").read_text())
    assert {m["id"]: m["report"] for m in doc["meshes"]} == reports
    export_database(out, tmp_path / "e.npz")
    with np.load(tmp_path / "e.npz") as z:
        got = dict(zip(z["mesh_id"].tolist(), z["mesh_report"].tolist(), strict=True))
    assert {i: json.loads(t) if t else None for i, t in got.items()} == reports
    h5py = pytest.importorskip("h5py")
    export_database(out, tmp_path / "e.h5")
    with h5py.File(tmp_path / "e.h5", "r") as f:
        ids = f["meshes/id"][()].tolist()
        texts = [t.decode() for t in f["meshes/report"][()]]
    assert {i: json.loads(t) if t else None for i, t in zip(ids, texts, strict=True)} == reports


def test_plugged_in_planners_report_what_they_give(tmp_path: Path) -> None:
    mesh_dir = make_mesh_dir(tmp_path)
    box = str(mesh_dir / "box.stl")
    params = {**PARAMS, "contacts": 7, "mu": 0.0, "finger_radius": None}
    plain = run_one(box, params, PLANNER)
    assert plain.ok and json.loads(plain.report) == {"length": 1.0, "units": "unknown"}
    bare = run_one(box, params, "tests.db_fakeplanner:plan_without_mesh")
    assert bare.ok and bare.report is None and bare.units is None
    odd = run_one(box, params, "tests.db_fakeplanner:plan_with_report")
    assert odd.ok and json.loads(odd.report) == {
        "center_mass": [0.0, 0.0, 0.0], "volume": None, "repairs": ["welded 3 vertices"],
        "warnings": [], "dropped": ["dropped object 1"], "extra": {"count": 2},
        "length": 1.0, "units": "unknown",
    }  # fmt: skip
    with pytest.raises(ValueError, match="not an object"):
        mesh_report("box.stl")
    assert mesh_report(None) is None

    out = tmp_path / "odd.sqlite"
    build_database([mesh_dir], out, PARAMS, workers=0,
                   planner="tests.db_fakeplanner:plan_with_report")  # fmt: skip
    with GraspDatabase(out) as db:
        info = db.info()
        assert (info.with_report, info.repaired, info.with_dropped, info.with_warnings) == (
            4, 4, 4, 0,
        )  # fmt: skip
        assert {m.status: m.report is None for m in db.meshes()} == {
            "done": False, "failed": True, "duplicate": True,
        }  # fmt: skip
    out = tmp_path / "bare.sqlite"
    build_database([mesh_dir], out, PARAMS, workers=0,
                   planner="tests.db_fakeplanner:plan_without_mesh")  # fmt: skip
    with GraspDatabase(out) as db:
        assert all(m.report is None for m in db.meshes()) and db.info().with_report == 0


# -- schema 1 files ----------------------------------------------------------------------------


@pytest.fixture()
def v1(tmp_path: Path) -> tuple[Path, Path, Path]:
    """(mesh folder, current-schema database, the same as a schema-1 file) with the test
    planner."""
    mesh_dir = make_mesh_dir(tmp_path)
    v2 = tmp_path / "v2.sqlite"
    build_database([mesh_dir], v2, PARAMS, workers=0, planner=PLANNER)
    old = tmp_path / "v1.sqlite"
    write_v1_copy(v2, old)
    return mesh_dir, v2, old


def _versions(path: Path) -> tuple[str, int, bool]:
    conn = sqlite3.connect(path)
    try:
        meta = conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()[0]
        user = conn.execute("PRAGMA user_version").fetchone()[0]
        cols = [r[1] for r in conn.execute("PRAGMA table_info(meshes)")]
    finally:
        conn.close()
    return meta, user, "mesh_report" in cols


def test_v1_file_is_read_as_it_is(
    v1: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _, v2, old = v1
    assert _versions(old) == ("1", 1, False)
    data = old.read_bytes()
    with GraspDatabase(old) as db:
        assert db.schema_version == 1
        assert all(m.report is None for m in db.meshes())
        assert db.mesh("box.stl").report is None
        info = db.info()
        assert info.schema_version == 1 and info.done == 4 and info.with_report == 0
        with GraspDatabase(v2) as new:
            late = ("squeeze_per_weight", "least_squeeze", "margin")  # columns v1 never had
            got, want = ([g.to_dict() for g in d.top("box", 2)] for d in (db, new))
            assert all(g[k] is None for g in got for k in late)
            assert all(g[k] is not None for g in want for k in late[:1])
            assert [{k: v for k, v in g.items() if k not in late} for g in got] == [
                {k: v for k, v in g.items() if k not in late} for g in want
            ]
    assert snapshot(old, report=False) == snapshot(v2, report=False)
    assert main(["db", "info", str(old)]) == 0
    assert "loading: no mesh reports (schema 1 file)" in capsys.readouterr().out
    export_database(old, tmp_path / "old.json")
    export_database(old, tmp_path / "old.npz")
    exported = json.loads((tmp_path / "old.json").read_text())["meshes"]
    assert len(exported) == 7 and all(m["report"] is None for m in exported)
    with np.load(tmp_path / "old.npz") as z:
        assert set(z["mesh_report"].tolist()) == {""}
    assert old.read_bytes() == data and _versions(old) == ("1", 1, False)


def test_build_migrates_a_v1_file_in_place(v1: tuple[Path, Path, Path]) -> None:
    mesh_dir, v2, old = v1
    with pytest.raises(DatabaseError, match="other planner parameters"):
        build_database([mesh_dir], old, {**PARAMS, "seed": 99}, workers=0, planner=PLANNER)
    assert _versions(old) == ("1", 1, False)  # a refused build does not migrate
    before_meshes, before_grasps = snapshot(old, report=False)

    trimesh.creation.box(extents=(0.5, 1.0, 2.0)).export(mesh_dir / "new.stl")
    report = build_database([mesh_dir], old, PARAMS, workers=0, planner=PLANNER, quiet=True)
    assert (report.planned, report.done) == (1, 1)
    assert _versions(old) == ("4", 4, True)
    with GraspDatabase(old) as db:
        assert db.schema_version == 4 and db.meta["schema_version"] == "4"
        meshes = {m.id: m for m in db.meshes()}
        new = next(m for m in meshes.values() if m.name == "new.stl")
        assert new.status == "done" and new.report == {"length": 2.0, "units": "unknown"}
        assert all(m.report is None for m in meshes.values() if m.id != new.id)
        assert db.info().with_report == 1
    after_meshes, after_grasps = snapshot(old, report=False)
    assert [r for r in after_meshes if r[0] != new.id] == before_meshes  # v1 rows survive
    assert [g for g in after_grasps if g[0] != new.id] == before_grasps
    assert snapshot(v2)[0][0][-1] == {"length": 1.0, "units": "unknown"}  # box.stl, fresh v2

    # a second run on the migrated file changes nothing
    report = build_database([mesh_dir], old, PARAMS, workers=0, planner=PLANNER, quiet=True)
    assert report.planned == 0 and snapshot(old, report=False) == (after_meshes, after_grasps)


def test_failed_migration_leaves_the_v1_file_whole(v1: tuple[Path, Path, Path]) -> None:
    mesh_dir, _, old = v1
    conn = sqlite3.connect(old)
    conn.execute(
        "CREATE TRIGGER no_update BEFORE UPDATE ON meta BEGIN SELECT RAISE(ABORT, 'meta is "
        "frozen'); END"
    )
    conn.commit()
    conn.close()
    before = snapshot(old, report=False)
    with pytest.raises(DatabaseError, match="cannot migrate.*meta is frozen"):
        build_database([mesh_dir], old, PARAMS, workers=0, planner=PLANNER, quiet=True)
    assert _versions(old) == ("1", 1, False)  # the ALTER TABLE was rolled back with the rest
    assert snapshot(old, report=False) == before


def test_newer_schema_is_refused(v1: tuple[Path, Path, Path], tmp_path: Path) -> None:
    mesh_dir, v2, _ = v1
    newer = tmp_path / "v5.sqlite"
    shutil.copyfile(v2, newer)
    conn = sqlite3.connect(newer)
    conn.execute("UPDATE meta SET value = '5' WHERE key = 'schema_version'")
    conn.execute("PRAGMA user_version = 5")
    conn.commit()
    conn.close()
    data = newer.read_bytes()
    for mode in ("r", "w"):
        with pytest.raises(DatabaseError, match="schema version 5, this synth reads versions 1 "
                           "to 4") as err:  # fmt: skip
            GraspDatabase(newer, mode=mode)
        assert str(newer) in str(err.value)
    with pytest.raises(DatabaseError, match="schema version 5"):
        build_database([mesh_dir], newer, PARAMS, workers=0, planner=PLANNER)
    assert newer.read_bytes() == data
