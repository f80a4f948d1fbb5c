"""Large temporaries without fresh pages: the allocator's policy during a load or a plan.

Loading and planning a large mesh allocate and free many arrays of tens of MB (a 1.3M-face
mesh's (f, 3) float arrays are 31 MB). glibc's ``malloc`` serves each block above its mmap
threshold (at most 32 MB unless set) from a fresh mapping and unmaps it when freed, so the
kernel faults in and zeroes new pages for every temporary; and numpy advises huge pages for
arrays of 4 MB and more, which a kernel that compacts memory on the spot
(``/sys/kernel/mm/transparent_hugepage/defrag``: ``madvise``) serves with stalls.

:func:`reuse_memory` keeps freed blocks in the heap for reuse while it is active (the mmap
and trim thresholds of ``mallopt`` at 1 GB), with numpy's huge-page advice off. On exit it
restores numpy's advice and gives the heap's free memory back to the system
(``malloc_trim``). glibc's thresholds cannot be read, and setting one ends glibc's own
adjustment of them for the process: they are left where that adjustment takes them after a
large block (32 MB, trimming at 64 MB), and a ``MALLOC_MMAP_THRESHOLD_`` or
``MALLOC_TRIM_THRESHOLD_`` of the environment is replaced. :func:`synth.load_part` and
:func:`synth.plan_part` run inside it. Where the C library is not glibc, the thresholds are
not touched.

Measured on the 1.3M-face blob of ``scripts/bench_scale.py`` (load and plan, one CPU): 4.88
and 5.49 s of CPU time, 1.01 and 1.80 s of it the system's, without it; 4.13 and 4.31 s,
0.35 and 0.33 s the system's, with it; the peak resident memory 1,089 -> 1,102 MB.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import wraps
from typing import Any, TypeVar

import numpy as np

__all__ = ["reuse_memory", "reusing_memory"]

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: The thresholds while active, and those set on exit (glibc's dynamic ones after a free of
#: a block of 32 MB or more, its largest).
_KEEP = 1 << 30
_MMAP_AFTER, _TRIM_AFTER = 32 << 20, 64 << 20

_lock = threading.Lock()
_depth = 0
_hugepage_before = True


def _glibc() -> Any:
    """glibc through ctypes, or None (another C library, or none found)."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name or "libc.so.6")
        libc.gnu_get_libc_version  # noqa: B018 (present in glibc only)
        return libc
    except (OSError, AttributeError):
        return None


_LIBC = _glibc()


def _hugepage_setter() -> Callable[[bool], bool] | None:
    """numpy's setter of its huge-page advice (private: ``numpy._core.multiarray`` in numpy 2,
    ``numpy.core.multiarray`` in numpy 1), or None if this numpy has none."""
    for name in ("_core", "core"):
        module = getattr(getattr(np, name, None), "multiarray", None)
        setter = getattr(module, "_set_madvise_hugepage", None)
        if setter is not None:
            return setter  # type: ignore[no-any-return]
    return None


_SETTER = _hugepage_setter()


def _set_hugepage(on: bool) -> bool:
    """Set numpy's huge-page advice; returns the previous setting (True if numpy has none)."""
    return bool(_SETTER(on)) if _SETTER is not None else True


@contextmanager
def reuse_memory() -> Iterator[None]:
    """Keep large freed blocks for reuse inside the block (see the module's notes); nested
    uses act once, at the outermost."""
    global _depth, _hugepage_before
    with _lock:
        if _depth == 0:
            if _LIBC is not None:  # (a threshold glibc refuses is left as it was)
                _LIBC.mallopt(_M_MMAP_THRESHOLD, _KEEP)
                _LIBC.mallopt(_M_TRIM_THRESHOLD, _KEEP)
            _hugepage_before = _set_hugepage(False)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _set_hugepage(_hugepage_before)
                if _LIBC is not None:
                    _LIBC.mallopt(_M_MMAP_THRESHOLD, _MMAP_AFTER)
                    _LIBC.mallopt(_M_TRIM_THRESHOLD, _TRIM_AFTER)
                    _LIBC.malloc_trim(0)


F = TypeVar("F", bound=Callable[..., Any])


def reusing_memory(func: F) -> F:
    """``func`` run inside :func:`reuse_memory`."""
    @wraps(func)
    def run(*args: Any, **kwargs: Any) -> Any:
        with reuse_memory():
            return func(*args, **kwargs)
    return run  # type: ignore[return-value]
