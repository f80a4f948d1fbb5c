"""Loading meshes into parts: formats, repairs, equivalence of encodings, bad files."""

from __future__ import annotations

import io
import json
import re
import zipfile
from contextlib import redirect_stderr, redirect_stdout
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


def test_a_byte_order_mark_before_a_text_mesh_is_read_past(tmp_path: Path) -> None:
    """Editors on Windows start text files with a UTF-8 byte-order mark: an OBJ lost its first
    vertex to it ('face 2 refers to vertex 4, but the file has 3 vertices')."""
    tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    texts = {"obj": tet, "stl": trimesh.exchange.stl.export_stl_ascii(box),
             "off": trimesh.exchange.off.export_off(box)}
    for ext, text in texts.items():
        plain, marked = tmp_path / f"plain.{ext}", tmp_path / f"marked.{ext}"
        plain.write_text(text)
        marked.write_bytes(b"\xef\xbb\xbf" + text.encode())
        a, b = load_part(plain), load_part(marked)
        assert np.array_equal(a.mesh.vertices, b.mesh.vertices), ext
        assert np.array_equal(a.mesh.faces, b.mesh.faces), ext
        assert a.sha256 != b.sha256  # the file's own bytes, mark and all
    # a binary STL whose free 80-byte header starts with the same three bytes is binary
    data = bytearray(trimesh.exchange.stl.export_stl(box))
    data[:80] = b"\xef\xbb\xbf" + b"x" * 77
    (tmp_path / "binary.stl").write_bytes(bytes(data))
    assert len(load_part(tmp_path / "binary.stl").mesh.faces) == 12


def test_an_unsupported_extension_lists_the_formats_in_words(tmp_path: Path) -> None:
    notes = tmp_path / "README.md"
    notes.write_text("# notes\n")
    with pytest.raises(MeshError) as info:
        load_part(notes)
    assert str(info.value).endswith("unsupported format 'md'; expected one of stl, obj, ply, "
                                    "off, glb, gltf, 3mf")  # not a Python tuple


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


# -- parts far smaller than 1 in their units, and coordinates too coarse for the part ------------

def _structure(part: Part) -> tuple:
    """What a change of scale leaves alone."""
    return (len(part.mesh.faces), len(part.regions), part.watertight, len(part.bodies),
            tuple(np.bincount(part.features.edge_kind, minlength=4)),
            tuple(np.bincount(part.features.vertex_kind, minlength=6)))


def _d_star(part: Part, points: np.ndarray) -> float:
    """Trinkle's d* of frictionless contacts at ``points`` on ``part``, moments scaled by its
    size as the planner scales them."""
    from synth.scores import form_closure
    from synth.scores.quality import scaled_wrenches

    c = part.resolve(points)
    assert len(c.points) == len(points)  # on faces: one contact each
    return form_closure(scaled_wrenches(c.points, c.normals, part.center_mass,
                                        part.length)).d_star


@pytest.mark.parametrize("side", [1e-7, 1e-8])
def test_a_tiny_float32_cube_loads_and_scores_like_the_unit_cube(tmp_path: Path,
                                                                 side: float) -> None:
    """A cube of side 1e-7 or 1e-8 in a binary STL is float32 to full precision: it loads as
    the cube of side 1 does (round coordinates such as 5e-08 are no sign of a text file of 8
    decimals, and a face of area 1e-14 has a normal), and the same grasp scaled down has the
    same d*; its plan is as good."""
    from synth import PlanParams, plan_part

    unit_path, tiny_path = tmp_path / "unit.stl", tmp_path / "tiny.stl"
    trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(unit_path)
    trimesh.creation.box(extents=(side,) * 3).export(tiny_path)
    unit, tiny = load_part(unit_path), load_part(tiny_path)
    assert _structure(tiny) == _structure(unit)
    assert tiny.volume == pytest.approx(side**3, rel=1e-6)
    assert tiny.length == pytest.approx(side * np.sqrt(3.0), rel=1e-6)
    assert tiny.precision < 1e-6 * tiny.length  # float32's, not a decimal's
    assert np.allclose(np.linalg.norm(tiny.mesh.face_normals, axis=1), 1.0)
    params = PlanParams(top=3, seed=0, evals=2000)
    best = plan_part(unit, params).grasps[0]
    assert _d_star(tiny, best.points * side) == pytest.approx(_d_star(unit, best.points),
                                                              rel=1e-6)
    assert _d_star(unit, best.points) == pytest.approx(best.d_star, rel=1e-6)
    planned = plan_part(tiny, params).grasps
    assert planned and planned[0].d_star == pytest.approx(best.d_star, rel=1e-5)


def test_round_numbers_are_no_sign_of_fixed_decimals() -> None:
    """Coordinates of one or two significant digits (a box at +-0.5, +-5e-08) are written
    exactly with any number of decimals: their precision is the float's; a value that 4
    decimals would write as 0 was not written with 4."""
    from synth.part.tolerances import coordinate_precision

    for half in (0.5, 5e-8, 5e-9):
        box = np.array([[half, -half, half], [-half, half, -half]], np.float32).astype(float)
        assert coordinate_precision(box) == pytest.approx(half * 2.0**-24), half
    scan = np.array([[0.1235, -2.4871, 1.0], [0.5, 3.25, -0.0042]])  # %.4f
    assert coordinate_precision(scan) == pytest.approx(5e-5)


def test_float32_coordinates_too_coarse_for_the_part_are_said_so(tmp_path: Path) -> None:
    """A cube of side 1 a billion units from the origin in a binary STL: float32 values there
    are 64 apart, so the file cannot hold the cube; the message says so, not that too few
    triangles were usable."""
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    box.apply_translation((1e9, 0.0, 0.0))
    path = tmp_path / "far.stl"
    box.export(path)
    with pytest.raises(MeshError) as info:
        load_part(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ") and "usable" not in msg
    for words in ("coordinates cannot resolve the part", "float32", "1e+09", "64 apart",
                  "coarser than the part", "near the origin"):
        assert words in msg, (words, msg)


def test_coarse_float32_coordinates_are_warned_of(tmp_path: Path) -> None:
    """The same cube a million units out: float32 values there are 0.0625 apart, which hold
    its corners exactly but make every tolerance a few percent of its size (its edges then
    take contacts that a cube at the origin keeps on its faces): loaded, with a warning; the
    cube at the origin and ten thousand units out get none."""
    warned = {}
    for offset in (0.0, 1e4, 1e6):
        box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
        box.apply_translation((offset, 0.0, 0.0))
        path = tmp_path / f"box{offset:g}.stl"
        box.export(path)
        part = load_part(path, units="m")
        warned[offset] = [w for w in part.warnings if w.startswith("coarse coordinates")]
    assert not warned[0.0] and not warned[1e4]
    assert len(warned[1e6]) == 1 and "% of the part's size" in warned[1e6][0]
    assert "near the origin" in warned[1e6][0]


def test_decimation_to_too_few_faces_names_the_decimation() -> None:
    pytest.importorskip("fast_simplification")
    with pytest.raises(MeshError) as info:
        load_part(MESHES / "cube.stl", decimate=4)
    msg = str(info.value)
    assert "decimating its 12 triangles to 4 left only" in msg and "decimate" in msg
    assert "of 2" not in msg


# -- malformed files: what is wrong, in the file's words, never the reader's --------------------

#: Words of library internals that must not reach a message.
INTERNALS = re.compile(r"\b\w*(Error|Exception|Iteration)\b|Traceback|resolver|numpy|trimesh"
                       r"|axis \d|out of bounds")


def _malformed_files(tmp: Path) -> dict[str, tuple[Path, list[str]]]:
    out: dict[str, tuple[Path, list[str]]] = {}

    def put(label: str, name: str, data: str | bytes, words: list[str]) -> None:
        p = tmp / name
        p.write_bytes(data.encode() if isinstance(data, str) else data)
        out[label] = (p, words)

    tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
    put("obj index", "oob.obj", tri + "f 1 2 4\n",
        ["face 1 (line 4) refers to vertex 4", "the file has 3 vertices"])
    put("obj negative index", "neg.obj", tri + "f 1 2 -4\n", ["refers to vertex -4"])
    put("obj text", "garbage.obj", "v a b c\n" + tri + "f 1 2 3\n",
        ["line 1", "a vertex must be three numbers", "'v a b c'"])
    put("obj corner", "corner.obj", tri + "f 1 2 x\n",
        ["line 4", "corners must be vertex numbers", "'x'"])
    put("obj two numbers", "flat.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        ["line 1", "three numbers", "found 2"])
    header = ("ply\nformat ascii 1.0\nelement vertex 3\n{props}element face 1\n"
              "property list uchar int vertex_indices\nend_header\n")
    put("ply no y", "noy.ply",
        header.format(props="property float x\nproperty float z\n") + "0 0\n1 0\n0 1\n3 0 1 2\n",
        ["the PLY header declares no y coordinate for its vertices"])
    put("ply index", "oob.ply",
        header.format(props="property float x\nproperty float y\nproperty float z\n")
        + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        ["face 0 refers to vertex 3", "the file has 3 vertices"])
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("[Content_Types].xml", "<?xml version='1.0'?><Types/>")
    put("3mf no model", "nomodel.3mf", archive.getvalue(), ["the 3MF holds no model"])
    put("3mf not zip", "text.3mf", "not a zip\n", ["not a 3MF file", "ZIP"])
    gltf = {"asset": {"version": "2.0"}, "buffers": [{"uri": "/etc/passwd", "byteLength": 36}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "max": [1, 1, 1], "min": [0, 0, 0]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}
    put("gltf outside", "passwd.gltf", json.dumps(gltf),
        ["the glTF refers to a buffer outside its folder: /etc/passwd"])
    gltf["buffers"] = [{"uri": "missing.bin", "byteLength": 36}]
    put("gltf missing", "missing.gltf", json.dumps(gltf),
        ["the glTF refers to a buffer file that does not exist: missing.bin"])
    return out


def test_malformed_files_are_refused_in_plain_words(tmp_path: Path) -> None:
    for label, (path, words) in _malformed_files(tmp_path).items():
        with pytest.raises(MeshError) as info:
            load_part(path)
        msg = str(info.value)
        assert msg.startswith(f"{path}: "), (label, msg)
        for w in words:
            assert w in msg, (label, w, msg)
        assert not INTERNALS.search(msg), (label, msg)


def test_malformed_files_exit_2_with_one_line(tmp_path: Path) -> None:
    """The command line says the same in one line on stderr, with exit status 2."""
    from synth.cli import EXIT_INPUT, main

    files = _malformed_files(tmp_path)
    far = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    far.apply_translation((1e9, 0.0, 0.0))
    far.export(tmp_path / "far.stl")
    tiny = tmp_path / "tiny.stl"
    trimesh.creation.box(extents=(1e-7,) * 3).export(tiny)
    cases = [*files.values(), (tmp_path / "far.stl", ["coarser than the part"]),
             (MESHES / "cube.stl", ["decimating its 12 triangles to 4"])]
    for path, words in cases:
        extra = ["--decimate", "4"] if path.name == "cube.stl" else []
        err = io.StringIO()
        with redirect_stdout(io.StringIO()), redirect_stderr(err):
            code = main(["plan", str(path), "--evals", "2000", "--no-files", *extra])
        lines = err.getvalue().strip().splitlines()
        assert code == EXIT_INPUT and len(lines) == 1, (path, code, lines)
        assert lines[0].startswith(f"synth: error: {path}: "), lines
        assert all(w in lines[0] for w in words) and not INTERNALS.search(lines[0]), lines
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
        assert main(["plan", str(tiny), "--evals", "2000", "--no-files"]) == 0
