"""Native libraries (FCL, manifold3d) get only meshes they accept, and a crash in one is
confined to a child process: the command goes on and says what it skipped."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from synth.errors import InputError, InternalError
from synth.isolate import NativeCrash, call_isolated
from synth.native import bvh_model, mesh_problem
from tests.native_cases import malformed, open_sphere

REPO = Path(__file__).resolve().parent.parent
#: Meshes of the fuzz set no native library may be given.
REFUSED = {"index out of range", "negative index", "NaN coordinate", "no faces", "no vertices"}


def test_no_malformed_mesh_crashes_a_native_call() -> None:
    """Every malformed mesh through every native call, in a process of its own: it ends
    normally, each call either answers or refuses in words, and the arrays no library may
    be given never reach one."""
    proc = subprocess.run([sys.executable, "-c", "from tests.native_cases import fuzz; fuzz()"],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"status {proc.returncode}: {proc.stderr[-2000:]}"
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    got = {(r["mesh"], r["call"]): r["outcome"] for r in rows}
    cases = malformed()
    for name in cases:
        for call in ("merge_close", "overlap_volumes", "unite", "fcl"):
            assert (name, call) in got, (name, call)
    for (name, call), outcome in got.items():
        if name in REFUSED:
            want = {"merge_close": "none", "unite": "none", "overlap_volumes": "ok"}.get(call)
            if call == "fcl":
                assert outcome.startswith("raised InternalError: a mesh handed to FCL"), outcome
            elif call.startswith("load_part"):
                assert outcome.startswith("refused: "), outcome
            else:
                assert outcome == want, (name, call, outcome)
        else:
            assert not outcome.startswith("raised"), (name, call, outcome)
            if call.startswith("load_part"):
                assert outcome == "loaded", (name, outcome)  # and no crash was confined
    assert sum(c.startswith("load_part") for _, c in got) >= 10


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_what_a_native_library_would_not_accept_is_named(name: str) -> None:
    v, f = malformed()[name]
    problem = mesh_problem(v, f)
    assert problem is not None
    with pytest.raises(InternalError, match="a mesh handed to FCL"):
        bvh_model(v, f)
    from synth.fingers import FingerChecker

    with pytest.raises(InputError, match="^part: "):  # the checker never hands it to FCL
        FingerChecker(trimesh.Trimesh(v, f, process=False, validate=False))
    sphere = open_sphere()
    assert mesh_problem(sphere.vertices, sphere.faces) is None


def test_a_crash_in_the_child_process_is_reported_and_survived() -> None:
    with pytest.raises(NativeCrash) as crash:
        call_isolated("tests.segfault:segfault", np.zeros(3))
    assert crash.value.signal == signal.SIGSEGV
    assert crash.value.how == "killed by SIGSEGV (segmentation fault)"
    assert call_isolated("math:hypot", 3.0, 4.0) == 5.0  # a new child answers
    with pytest.raises(ValueError, match="math domain error"):
        call_isolated("math:sqrt", -1.0)  # what the function raises is raised here


def test_an_abandoned_call_leaves_no_answer_behind() -> None:
    """A call cut short in the parent (Ctrl-C, a database worker's time limit) ends the
    child: the next call gets its own answer, not the abandoned one's."""

    class Stop(Exception):
        pass

    def stop(*_: object) -> None:
        raise Stop

    before = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, 0.3)
    try:
        with pytest.raises(Stop):
            call_isolated("time:sleep", 1.0)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)
    assert call_isolated("math:hypot", 3.0, 4.0) == 5.0


def test_a_repair_that_crashes_is_skipped_with_a_warning(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    """A crash of manifold3d closing one body: the part loads, the body stays open, the
    warning says so, and the file's later bodies are not handed to manifold3d again."""
    from synth.part import load_part, repair

    calls = []
    monkeypatch.setattr(repair, "MERGE_CLOSE", "tests.segfault:segfault")
    real = repair.call_isolated
    monkeypatch.setattr(repair, "call_isolated", lambda *a: calls.append(a[0]) or real(*a))
    two = trimesh.util.concatenate([open_sphere(), open_sphere(5.0)])
    part = load_part(two, units="mm", body="all")
    assert len(calls) == 1 and len(part.bodies) == 2
    assert not any(b.closed for b in part.bodies)
    crashed = [w for w in part.warnings if "crashed" in w]
    assert len(crashed) == 1 and "killed by SIGSEGV (segmentation fault)" in crashed[0]
    assert "kept open" in crashed[0] and "later bodies were not given" in crashed[0]


def test_a_union_that_crashes_keeps_the_bodies_apart(monkeypatch: pytest.MonkeyPatch) -> None:
    from synth.part import compound, load_part

    boxes = trimesh.util.concatenate([trimesh.creation.box(),
                                      trimesh.creation.box().apply_translation([0.5, 0, 0])])
    assert any("united 2" in r for r in load_part(boxes, units="mm").repairs)
    monkeypatch.setattr(compound, "UNITE", "tests.segfault:segfault")
    part = load_part(boxes, units="mm")
    assert len(part.bodies) == 2
    assert any("could not unite" in r and "manifold3d crashed: killed by SIGSEGV" in r
               for r in part.repairs), part.repairs
