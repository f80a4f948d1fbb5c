"""Candidate files: the fast JSON parser (orjson, when installed) and the standard library's
give the same values, and everything orjson refuses still goes through the standard one."""

from __future__ import annotations

import gc
import json
import sys

import numpy as np
import pytest

from synth.errors import InputError
from synth.grasps import candidates
from synth.grasps.candidates import parse_json, read_candidate_table


def _stdlib_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "orjson", None)  # import orjson now raises ImportError


def test_both_parsers_read_a_candidate_file_identically(tmp_path, monkeypatch) -> None:
    pytest.importorskip("orjson")
    rng = np.random.default_rng(1)
    P, N = rng.normal(size=(50, 7, 3)) * 1e3, rng.normal(size=(50, 7, 3))
    doc = [{"name": f"g{i}", "points": p, "normals": q, "mu": 0.1 * (i % 3)}
           for i, (p, q) in enumerate(zip(P.tolist(), N.tolist(), strict=True))]
    path = tmp_path / "c.json"
    path.write_text(json.dumps(doc))
    fast = read_candidate_table(path)
    with monkeypatch.context() as m:
        _stdlib_only(m)
        slow = read_candidate_table(path)
    (f,), (s,) = fast.groups, slow.groups
    np.testing.assert_array_equal(f.points, s.points)  # bit for bit
    np.testing.assert_array_equal(f.normals, s.normals)
    np.testing.assert_array_equal(fast.mu, slow.mu)
    assert fast.names == slow.names
    np.testing.assert_array_equal(f.points, P)


@pytest.mark.parametrize("raw", [
    b"[NaN, 1]",                              # not JSON, but the standard library reads it
    b"[" + b"9" * 400 + b"]",                 # beyond 64 bits
    b'{"a": 1, "a": 2}',                      # duplicate keys: the last wins
])
def test_what_orjson_refuses_is_parsed_as_the_standard_library_does(raw, monkeypatch) -> None:
    expected = json.loads(raw.decode())
    assert repr(parse_json(raw)) == repr(expected)


def test_nesting_too_deep_for_both_is_the_standard_librarys_recursion_error() -> None:
    with pytest.raises(RecursionError):
        parse_json(b"[" * 100_000 + b"]" * 100_000)


def test_malformed_json_raises_the_standard_librarys_error(monkeypatch) -> None:
    with pytest.raises(json.JSONDecodeError):
        parse_json(b'[{"points": [1, 2,]}]')
    monkeypatch.setitem(sys.modules, "orjson", None)
    with pytest.raises(json.JSONDecodeError):
        parse_json(b'[{"points": [1, 2,]}]')
    assert candidates.parse_json(b"[1.5]") == [1.5]


@pytest.mark.parametrize("text", ['[{"points": [[0, 0, 0]], "normals": [[0, 0, 1]]}]',
                                  "[{", "[]"])
def test_the_garbage_collector_is_back_on_after_reading_or_failing(tmp_path, text) -> None:
    # the JSON reader pauses the cyclic collector while it builds the parsed document
    path = tmp_path / "c.json"
    path.write_text(text)
    assert gc.isenabled()
    try:
        read_candidate_table(path)
    except InputError:
        pass
    assert gc.isenabled()
    gc.disable()
    try:  # a caller that turned it off keeps it off
        try:
            read_candidate_table(path)
        except InputError:
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()
