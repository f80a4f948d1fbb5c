"""A function that crashes the process calling it, as a bug in native code does; this module
imports nothing else, so a child process that runs it starts fast."""

from __future__ import annotations

import ctypes
from typing import Any

__all__ = ["segfault"]


def segfault(*args: Any) -> None:
    """Crash the calling process with SIGSEGV (a read of address 0)."""
    ctypes.string_at(0)
