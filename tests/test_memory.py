"""The allocator's policy during a load or a plan: blocks reused inside, everything restored
and given back outside."""

from __future__ import annotations

import resource

import numpy as np
import pytest

from synth import memory


def _advice() -> bool:
    """numpy's huge-page advice now (set and put back)."""
    before = memory._set_hugepage(True)
    memory._set_hugepage(before)
    return before


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        return next(int(x.split()[1]) for x in f if x.startswith("VmRSS")) / 1024


needs_setter = pytest.mark.skipif(memory._SETTER is None,
                                  reason="this numpy has no huge-page advice to set")


@needs_setter
@pytest.mark.parametrize("advice", [True, False])
def test_numpy_advice_is_off_inside_and_restored_after_nesting(advice: bool) -> None:
    before = memory._set_hugepage(advice)
    try:
        with memory.reuse_memory():
            assert not _advice()
            with memory.reuse_memory():
                assert not _advice()
            assert not _advice()  # the inner block's end restores nothing
        assert _advice() == advice
    finally:
        memory._set_hugepage(before)


@needs_setter
def test_a_load_restores_it(tmp_path) -> None:
    import trimesh

    from synth import load_part

    path = tmp_path / "box.stl"
    trimesh.creation.box().export(path)
    before = memory._set_hugepage(True)
    try:
        load_part(path)
        assert _advice()
    finally:
        memory._set_hugepage(before)


def test_an_exception_inside_restores_it() -> None:
    before = _advice()
    with pytest.raises(KeyError), memory.reuse_memory():
        raise KeyError("x")
    assert _advice() == before and memory._depth == 0


@pytest.mark.skipif(memory._LIBC is None, reason="not glibc")
def test_large_blocks_are_reused_inside_and_given_back_after() -> None:
    """A 64 MB array made and freed again and again: inside, only the first touches new
    pages; after the block, the heap's free memory goes back to the system."""
    n = 8 << 20  # 64 MB of float64
    pages = (n * 8) // resource.getpagesize()
    with memory.reuse_memory():
        np.ones(n)
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        for _ in range(5):
            np.ones(n)
        faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
        assert faults < 0.01 * pages  # 16,384 pages a round
        held = _rss_mb()
    assert held - _rss_mb() > 50
