"""Loading meshes into parts: formats, repairs, equivalence of encodings, bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.errors import InputError, MeshError
from synth.part import Part, load_part

MESHES = Path(__file__).resolve().parent.parent / "meshes"
NAMES = ["cube", "prism", "bracket", "tee", "nut", "cylinder", "sphere", "torus"]


def _signature(part: Part) -> tuple:
    """What must agree between two encodings of one solid."""
    v = np.round(np.asarray(part.mesh.vertices), 6)
    return (
        len(part.mesh.faces),
        tuple(map(tuple, v[np.lexsort(v.T[::-1])].tolist())),
        round(part.volume, 9),
        tuple(np.round(part.center_mass, 9)),
        len(part.regions),
        tuple(sorted(round(r.area, 9) for r in part.regions)),
        tuple(np.bincount(part.features.edge_kind, minlength=4)),
        tuple(np.bincount(part.features.vertex_kind, minlength=6)),
    )


@pytest.mark.parametrize("name", NAMES)
def test_sample_meshes_load_closed_and_small(name: str) -> None:
    path = MESHES / f"{name}.stl"
    assert path.stat().st_size < 300_000
    part = load_part(path, units="decimeters")
    assert part.watertight and part.volume > 0
    # STL stores three vertices per triangle: welding them is reading, not a repair, and a
    # clean file needs no repair
    assert part.repairs == () and part.warnings == () and part.dropped == ()
    assert len(part.bodies) == 1 and part.bodies[0].closed
    assert part.units == "decimeters" and part.source == str(path)
    assert len(part.sha256) == 64
    assert part.length == pytest.approx(np.linalg.norm(part.mesh.extents))


def test_analytic_mass_properties() -> None:
    cube = load_part(MESHES / "cube.stl", units="decimeters")
    assert cube.volume == pytest.approx(1.0, abs=1e-9)
    assert np.allclose(cube.center_mass, 0.0, atol=1e-9)
    assert cube.length == pytest.approx(np.sqrt(3.0))
    bracket = load_part(MESHES / "bracket.stl")
    assert bracket.volume == pytest.approx(0.5 + 0.3125 + 0.140625, rel=1e-6)


def test_unknown_unit_is_a_warning_and_bad_unit_an_error() -> None:
    part = load_part(MESHES / "cube.stl")
    assert part.units is None
    assert any("unit" in w for w in part.warnings)
    with pytest.raises(MeshError, match="unit"):
        load_part(MESHES / "cube.stl", units="furlongs-ish")


def _write_obj_with_seams(mesh: trimesh.Trimesh, path: Path) -> None:
    """Every face corner gets its own ``vt``: the OBJ reader splits every vertex."""
    lines = [f"v {x:.9f} {y:.9f} {z:.9f}" for x, y, z in mesh.vertices]
    k = 0
    for f in mesh.faces:
        ids = []
        for v in f:
            k += 1
            lines.append(f"vt {(k * 0.37) % 1:.6f} {(k * 0.61) % 1:.6f}")
            ids.append(f"{v + 1}/{k}")
        lines.append("f " + " ".join(ids))
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("name", ["bracket", "nut"])
def test_encodings_of_one_part_load_to_the_same_model(name: str, tmp_path: Path) -> None:
    ref = load_part(MESHES / f"{name}.stl")
    mesh = ref.mesh.copy()
    # ASCII STL
    ascii_path = tmp_path / "a.stl"
    ascii_path.write_bytes(trimesh.exchange.stl.export_stl_ascii(mesh).encode())
    assert ascii_path.read_bytes().startswith(b"solid")
    # OBJ with texture seams: the raw reader really duplicates vertices
    obj_path = tmp_path / "seams.obj"
    _write_obj_with_seams(mesh, obj_path)
    raw = trimesh.load(obj_path, process=False, force="mesh")
    assert len(raw.vertices) == 3 * len(mesh.faces) > len(mesh.vertices)
    assert not raw.is_watertight
    # flipped faces: a third flipped, then everything inverted
    rng = np.random.default_rng(0)
    faces = mesh.faces.copy()
    flip = rng.random(len(faces)) < 0.33
    faces[flip] = faces[flip][:, ::-1]
    flipped = trimesh.Trimesh(mesh.vertices, faces, process=False)
    inverted = trimesh.Trimesh(mesh.vertices, mesh.faces[:, ::-1], process=False)
    flip_path = tmp_path / "flipped.stl"
    flipped.export(flip_path)
    # other formats
    ply_path, off_path, glb_path = tmp_path / "m.ply", tmp_path / "m.off", tmp_path / "m.glb"
    mesh.export(ply_path)
    mesh.export(off_path)
    mesh.export(glb_path)

    sig = _signature(ref)
    loaded = {
        "ascii": load_part(ascii_path),
        "obj": load_part(obj_path),
        "flipped": load_part(flip_path),
        "inverted": load_part(inverted),
        "ply": load_part(ply_path),
        "off": load_part(off_path),
        "glb": load_part(glb_path),
    }
    for label, part in loaded.items():
        assert _signature(part) == sig, label
    assert any("welded" in r for r in loaded["obj"].repairs)
    assert any("re-oriented" in r for r in loaded["flipped"].repairs)
    assert any("re-oriented" in r for r in loaded["inverted"].repairs)


def test_3mf_when_reader_available(tmp_path: Path) -> None:
    pytest.importorskip("lxml")
    ref = load_part(MESHES / "cube.stl")
    path = tmp_path / "cube.3mf"
    ref.mesh.export(path)
    assert _signature(load_part(path)) == _signature(ref)


def test_several_bodies_default_largest_and_choice(tmp_path: Path) -> None:
    big = trimesh.creation.box((1.0, 1.0, 1.0))
    small = trimesh.creation.box((0.2, 0.2, 0.2))
    small.apply_translation((3.0, 0.0, 0.0))
    scene = trimesh.Scene()
    scene.add_geometry(small, geom_name="small", node_name="small")
    scene.add_geometry(big, geom_name="big", node_name="big")
    path = tmp_path / "two.glb"
    scene.export(path)
    part = load_part(path)
    assert part.volume == pytest.approx(1.0)
    assert any("largest" in r for r in part.dropped)
    assert load_part(path, body="small").volume == pytest.approx(0.008)
    assert load_part(path, body="all").volume == pytest.approx(1.008)
    with pytest.raises(MeshError, match="not found"):
        load_part(path, body="nothing")
    # one STL with two disconnected shells behaves the same way
    both = trimesh.util.concatenate([small, big])
    stl = tmp_path / "two.stl"
    both.export(stl)
    assert load_part(stl).volume == pytest.approx(1.0)
    assert load_part(stl, body="all").volume == pytest.approx(1.008)


def test_open_mesh_is_repaired_or_warned(tmp_path: Path) -> None:
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    holed = trimesh.Trimesh(box.vertices, box.faces[1:], process=False)  # one triangle gone
    part = load_part(holed)
    assert part.watertight and part.volume == pytest.approx(1.0)
    assert any("filled" in r or "closed" in r for r in part.repairs)
    cyl = trimesh.creation.cylinder(radius=0.5, height=1.0, sections=32)
    top = cyl.face_normals[:, 2] > 0.5
    open_cyl = trimesh.Trimesh(cyl.vertices, cyl.faces[~top], process=False)  # a cup
    part = load_part(open_cyl)
    if part.watertight:
        assert any("closed" in r or "filled" in r for r in part.repairs)
    else:
        assert any("not watertight" in w for w in part.warnings)
        assert (part.features.edge_kind == 3).sum() == 32


def _bad_files(tmp: Path) -> dict[str, tuple[Path, str]]:
    cube = load_part(MESHES / "cube.stl").mesh
    out: dict[str, tuple[Path, str]] = {}
    p = tmp / "empty.stl"
    p.write_bytes(b"")
    out["empty"] = (p, "empty")
    p = tmp / "truncated.stl"
    data = trimesh.exchange.stl.export_stl(cube)
    p.write_bytes(data[: len(data) - 70])
    out["truncated"] = (p, "truncated")
    rng = np.random.default_rng(1)
    p = tmp / "random.stl"
    p.write_bytes(rng.bytes(5000))
    out["random_stl"] = (p, "STL")
    p = tmp / "random.obj"
    p.write_bytes(rng.bytes(5000))
    out["random_obj"] = (p, "not a text OBJ")
    p = tmp / "triangle.stl"
    trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False).export(p)
    out["triangle"] = (p, "triangle")
    p = tmp / "nan.stl"
    p.write_text(
        "solid x\n" + "".join(
            f"facet normal 0 0 1\nouter loop\nvertex {a}\nvertex 1 0 0\nvertex 0 1 0\n"
            "endloop\nendfacet\n" for a in ["nan 0 0", "0 0 1", "1 1 1", "0 1 1"]
        ) + "endsolid x\n"
    )
    out["nan"] = (p, "NaN")
    p = tmp / "sheet.stl"
    grid = trimesh.Trimesh(
        [[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0]],
        [[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]], process=False)
    grid.export(p)
    out["sheet"] = (p, "plane")
    p = tmp / "notes.txt"
    p.write_text("hello")
    out["format"] = (p, "unsupported")
    out["missing"] = (tmp / "missing.stl", "no such file")
    p = tmp / "words.stl"  # text that is no STL: trimesh reads an empty scene
    p.write_text("hello world\n")
    out["text"] = (p, "holds no triangle mesh: nothing readable as triangles when read as STL")
    p = tmp / "points.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    out["points"] = (p, "holds no triangle mesh: only points when read as OBJ")
    return out


def test_bad_files_get_one_clear_error(tmp_path: Path) -> None:
    for label, (path, reason) in _bad_files(tmp_path).items():
        with pytest.raises(MeshError) as info:
            load_part(path)
        msg = str(info.value)
        assert str(path) in msg, label
        assert reason.lower() in msg.lower(), (label, msg)


def test_bad_inputs() -> None:
    with pytest.raises(MeshError, match="expected a path"):
        load_part(42)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="sharp_angle"):
        load_part(MESHES / "cube.stl", sharp_angle=4.0)
    part = load_part(MESHES / "cube.stl")
    with pytest.raises(AttributeError):
        part.units = "meters"  # type: ignore[misc]


def test_unit_abbreviations_are_accepted():
    from pathlib import Path

    from synth import MeshError, load_part

    cube = Path(__file__).resolve().parent.parent / "meshes" / "cube.stl"
    assert load_part(cube, units="mm").units == "millimeters"
    assert load_part(cube, units="dm").units == "decimeters"
    with pytest.raises(MeshError, match="unknown length unit 'furlongs'"):
        load_part(cube, units="furlongs")


def test_a_mesh_above_the_face_limit_is_refused_with_advice() -> None:
    from synth.part.load import MAX_FACES

    rng = np.random.default_rng(0)
    n = MAX_FACES + 1
    big = trimesh.Trimesh(rng.random((1000, 3)), rng.integers(0, 1000, (n, 3)), process=False,
                          validate=False)
    with pytest.raises(MeshError, match=f"{n:,} triangles.*decimate"):
        load_part(big)


@pytest.mark.parametrize("limit, freed", [(0, True), (10**9, False)])
def test_the_file_as_read_is_freed_before_the_part_is_built(
        monkeypatch: pytest.MonkeyPatch, limit: int, freed: bool) -> None:
    """A trimesh mesh is a reference cycle: the loader collects the file as read once it is
    welded, from ``_COLLECT_FACES`` triangles on (below, with the automatic collector off, it
    stays alive: the control that shows the test can fail)."""
    import gc
    import weakref

    import synth.part.load as loader
    import synth.part.model as model

    read, alive = loader._read, []

    def reading(path: Path):  # type: ignore[no-untyped-def]
        raw, digest, units = read(path)
        alive.append(weakref.ref(raw[0][1]))
        return raw, digest, units

    init = model.Part.__init__

    def building(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        alive.append(alive[0]() is not None)
        init(self, *args, **kwargs)

    monkeypatch.setattr(loader, "_read", reading)
    monkeypatch.setattr(loader, "_COLLECT_FACES", limit)
    monkeypatch.setattr(model.Part, "__init__", building)
    was = gc.isenabled()
    gc.disable()
    try:
        load_part(MESHES / "nut.stl", units="mm")
    finally:
        if was:
            gc.enable()
    assert alive[1] is not freed
