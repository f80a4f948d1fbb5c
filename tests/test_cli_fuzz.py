"""Property-based fuzz of ``synth plan``, ``rank`` and ``score``: hostile option values and
broken input files never give a traceback or an internal error (exit 3), every refusal is one
line with exit status 2, values outside an option's documented range are always refused, and a
refused run leaves the files at its output paths as they were."""

from __future__ import annotations

import io
import json
import math
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from synth.cli import EXIT_INPUT, main
from synth.plan import params as lim
from tests.cli_support import BIG, CUBE_FC, earlier_output

FUZZ = settings(max_examples=100, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow])


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """A folder with a tiny mesh, a good candidate file and sentinel files at every output
    path."""
    d = tmp_path_factory.mktemp("fuzz")
    trimesh.creation.box().export(d / "box.stl")
    (d / "good.json").write_text(json.dumps([CUBE_FC]))
    for name in ("out.json", "out.png", "out.glb", "ranked.json", "scores.json"):
        earlier_output(d / name, name)  # synth's own: replaceable, but not by a failed run
    return d


def _sentinels(d):
    return {name: (d / name).read_bytes()
            for name in ("out.json", "out.png", "out.glb", "ranked.json", "scores.json")}


def _check(d, argv, out_of_range=False):
    """Run ``synth`` in-process and assert the properties of the module docstring."""
    before = _sentinels(d)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main([str(a) for a in argv])
    text = err.getvalue()
    assert "Traceback" not in text + out.getvalue()
    assert code in (0, 1, 2), (argv, code, text)
    errors = [line for line in text.splitlines() if line.startswith("synth: error: ")]
    if out_of_range:
        assert code == EXIT_INPUT, (argv, text)
    if code == EXIT_INPUT or errors:
        assert len(text.strip().splitlines()) == 1 and len(errors) == 1, (argv, text)
        assert _sentinels(d) == before, argv
    return code


# -- option values -----------------------------------------------------------------------------

HOSTILE = st.one_of(
    st.sampled_from(["-1", "0", "-0", "0.0", "1", "2", "3", "7", "65", "101", "1e15", "1e16",
                     "1e308", "-1e308", "1e400", "1e-400", "nan", "-nan", "inf", "-inf",
                     "Infinity", "", " ", "abc", "0x10", "1_0", "\u0663", "True", "None",
                     BIG, "-" + BIG, BIG + ".5", "9" * 5000, str(2**63), str(2**63 - 1),
                     "10000001", "99", "1000000000000"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**20), max_value=10**20).map(str),
    st.text(max_size=6),
)


def _number(text, kind):
    """The value argparse would give the option, or None when it refuses the text."""
    try:
        return kind(text)
    except (ValueError, OverflowError):
        return None


def _in(lo, hi, *, open_lo=False, open_hi=False, kind=float):
    """A predicate: the text parses as ``kind`` and lies in the documented range."""
    def ok(text):
        v = _number(text, kind)
        if v is None or (kind is float and not math.isfinite(v)):
            return False
        return (v > lo if open_lo else v >= lo) and (v < hi if open_hi else v <= hi)
    return ok


LENGTH = _in(0, lim.MAX_LENGTH, open_lo=True)
FINGER_OPTIONS = {"--finger-radius": LENGTH, "--body-length": LENGTH, "--body-radius": LENGTH,
                  "--approach-cone": _in(0, 90, open_hi=True),
                  "--sharp-angle": _in(0, 180, open_lo=True, open_hi=True)}
PLAN_OPTIONS = {
    "--contacts": _in(7, lim.MAX_CONTACTS, kind=int),  # 7: the defaults are frictionless
    "--fingers": lambda t: t == "auto" or _in(2, lim.MAX_FINGERS, kind=int)(t),
    "--mu": _in(0, lim.MAX_MU),
    "--edges": _in(lim.MIN_EDGES, lim.MAX_EDGES, kind=int),
    "--top": _in(1, lim.MAX_TOP, kind=int),
    "--time": _in(0, math.inf, open_lo=True, open_hi=True),
    "--evals": _in(lim.MIN_EVALS, lim.MAX_EVALS, kind=int),
    "--min-d-star": _in(0, 1),
    "--seed": _in(0, lim.MAX_SEED, kind=int),
    "--table": _in(-lim.MAX_LENGTH, lim.MAX_LENGTH),
    **FINGER_OPTIONS,
}
RANK_OPTIONS = {"--mu": _in(0, lim.MAX_MU), "--max-distance": _in(0, lim.MAX_LENGTH),
                "--edges": _in(lim.MIN_EDGES, lim.MAX_EDGES, kind=int),
                "--top": _in(0, math.inf, open_hi=True, kind=int), **FINGER_OPTIONS}
SCORE_OPTIONS = {"--mu": _in(0, lim.MAX_MU),
                 "--edges": _in(lim.MIN_EDGES, lim.MAX_EDGES, kind=int),
                 "--top": _in(0, math.inf, open_hi=True, kind=int)}


def _option_args(option, value):
    # "--opt=value": a value such as "-1" or "" is then the option's, never a new option
    return [f"{option}={value}"]


@FUZZ
@given(option=st.sampled_from(sorted(PLAN_OPTIONS)), value=HOSTILE)
def test_plan_options(work, option, value):
    valid = PLAN_OPTIONS[option](value)
    budget = [] if option == "--evals" else ["--evals", "100"]
    budget += [] if option == "--time" else ["--time", "0.5"]
    outputs = ["--no-files"] if valid else ["--out", work / "out.json"]  # no pictures to draw
    _check(work, ["plan", work / "box.stl", *_option_args(option, value), *budget, "--quiet",
                  "--units", "mm", *outputs], out_of_range=not valid)


@FUZZ
@given(option=st.sampled_from(sorted(RANK_OPTIONS)), value=HOSTILE)
def test_rank_options(work, option, value):
    valid = RANK_OPTIONS[option](value)
    _check(work, ["rank", work / "box.stl", work / "good.json", *_option_args(option, value),
                  "--quiet", "--units", "mm", "--out", work / "ranked.json"],
           out_of_range=not valid)


@FUZZ
@given(option=st.sampled_from(sorted(SCORE_OPTIONS)), value=HOSTILE)
def test_score_options(work, option, value):
    _check(work, ["score", work / "good.json", *_option_args(option, value), "--out",
                  work / "scores.json"], out_of_range=not SCORE_OPTIONS[option](value))


# -- input files -------------------------------------------------------------------------------

JSON_TOKENS = st.sampled_from(["1e400", "-1e400", "NaN", "Infinity", BIG, "-" + BIG, '"x"',
                               "null", "[]", "{}", "true", "[[1, 2]]", "[[1, 2, 3]]",
                               "[" * 3000 + "]" * 3000, "[[0, 0, 0]]", "[[1e300, 0, 0]]",
                               "[" + ", ".join(["[1, 0, 0]"] * 70) + "]", "-1", "101", "0.5"])


@st.composite
def broken_json(draw):
    """A single-candidate document with one field replaced by a hostile token, or cut, or a
    byte changed, or random bytes."""
    how = draw(st.sampled_from(["field", "top", "cut", "byte", "random"]))
    text = json.dumps([dict(CUBE_FC, mu=0.5)])
    if how == "field":
        key = draw(st.sampled_from(["points", "normals", "mu", "name"]))
        doc = [dict(CUBE_FC, mu=0.5)]
        doc[0][key] = "@@"
        return json.dumps(doc).replace('"@@"', draw(JSON_TOKENS)).encode()
    if how == "top":
        return draw(JSON_TOKENS).encode()
    if how == "cut":
        return text.encode()[: draw(st.integers(0, len(text) - 1))]
    if how == "byte":
        data = bytearray(text.encode())
        data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        return bytes(data)
    return draw(st.binary(max_size=300))


NPZ_VALUES = st.sampled_from([0.0, 1.0, -1.0, np.nan, np.inf, 1e300, 1e16, 1e-320])


@st.composite
def broken_npz(draw):
    """An NPZ archive of hostile arrays (every row alike, so that a file is either wholly
    valid or wholly not), possibly cut or with a byte changed, or random bytes, or a bare
    .npy array."""
    shape = tuple(draw(st.lists(st.integers(0, 4), min_size=0, max_size=4)))
    dtype = draw(st.sampled_from(["f8", "f2", "i1", "u8", "?", "c16", "U3"]))
    with np.errstate(invalid="ignore", over="ignore"):  # nan and 1e300 cast to integers
        arrays = {"points": np.full(shape, draw(NPZ_VALUES)).astype(dtype)}
        if draw(st.booleans()):
            arrays["normals"] = np.full(draw(st.sampled_from([shape, shape[:-1], (1, 7, 3)])),
                                        draw(NPZ_VALUES)).astype(draw(st.sampled_from(["f8",
                                                                                       "U3"])))
    for key in ("names", "mu"):
        if draw(st.booleans()):
            arrays[key] = np.full(draw(st.sampled_from([(), (1,), (2,), (3, 1)])),
                                  draw(NPZ_VALUES))
    buf = io.BytesIO()
    how = draw(st.sampled_from(["npz", "cut", "byte", "random", "npy"]))
    if how == "npy":
        np.save(buf, arrays["points"])
        return buf.getvalue()
    if how == "random":
        return draw(st.binary(max_size=300))
    np.savez(buf, **arrays)
    data = bytearray(buf.getvalue())
    if how == "cut":
        return bytes(data[: draw(st.integers(0, len(data) - 1))])
    if how == "byte":
        data[draw(st.integers(0, len(data) - 1))] ^= draw(st.integers(1, 255))
    return bytes(data)


CANDIDATE_FILES = st.one_of(broken_json().map(lambda b: ("json", b)),
                            broken_npz().map(lambda b: ("npz", b)))


@FUZZ
@given(file=CANDIDATE_FILES)
def test_score_candidate_files(work, file):
    ext, data = file
    path = work / f"cand.{ext}"
    path.write_bytes(data)
    _check(work, ["score", path, "--out", work / "scores.json"])


@settings(FUZZ, max_examples=80)
@given(file=CANDIDATE_FILES)
def test_rank_candidate_files(work, file):
    ext, data = file
    path = work / f"cand.{ext}"
    path.write_bytes(data)
    _check(work, ["rank", work / "box.stl", path, "--quiet", "--units", "mm", "--out",
                  work / "ranked.json"])


def _mesh_bytes(ext):
    data = trimesh.creation.box().export(file_type=ext)
    return data.encode() if isinstance(data, str) else data


MESH_BYTES = {ext: _mesh_bytes(ext) for ext in ("stl", "obj", "ply", "off", "glb", "3mf")}
MESH_BYTES["gltf"] = trimesh.creation.box().export(file_type="gltf")["model.gltf"]


@st.composite
def broken_mesh(draw):
    """Random bytes under a mesh suffix, or a small mesh cut short or with a byte changed."""
    ext = draw(st.sampled_from(["stl", "obj", "ply", "off", "glb", "gltf", "3mf"]))
    how = draw(st.sampled_from(["random", "cut", "byte"]))
    if how == "random":
        return ext, draw(st.binary(max_size=400))
    data = bytearray(MESH_BYTES[ext])
    if how == "cut":
        return ext, bytes(data[: draw(st.integers(0, len(data) - 1))])
    data[draw(st.integers(0, len(data) - 1))] ^= draw(st.integers(1, 255))
    return ext, bytes(data)


@settings(FUZZ, max_examples=60)
@given(mesh=broken_mesh(), command=st.sampled_from(["plan", "rank"]))
def test_mesh_files(work, mesh, command):
    ext, data = mesh
    path = work / f"mesh.{ext}"
    path.write_bytes(data)
    if command == "plan":
        argv = ["plan", path, "--evals", "100", "--time", "0.5", "--out", work / "out.json"]
    else:
        argv = ["rank", path, work / "good.json", "--out", work / "ranked.json"]
    _check(work, [*argv, "--quiet", "--units", "mm"])
