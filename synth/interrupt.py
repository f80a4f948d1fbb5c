"""Ctrl-C that other code swallowed, remembered until synth can act on it.

Python turns SIGINT into ``KeyboardInterrupt`` wherever the main thread is, and some
libraries synth imports on first use catch ``BaseException`` around their own optional
imports: an interrupt in the first half second of a command (while trimesh and scipy load)
was lost, and the command ran to its end. The command line installs :func:`on_interrupt`,
which raises as Python's own handler does and also remembers the interrupt; the long loops
(the progress reports of a plan, a simulation, a database build) call :func:`check`, which
raises it again if it was swallowed.
"""

from __future__ import annotations

import signal
import threading
from typing import Any

__all__ = ["install", "check", "pending", "clear", "run"]

_pending = False


def on_interrupt(signum: int, frame: Any) -> None:
    """SIGINT: remember it, and raise ``KeyboardInterrupt`` as Python's handler does."""
    global _pending
    _pending = True
    raise KeyboardInterrupt


def install() -> Any:
    """Install :func:`on_interrupt` (main thread only); returns the previous handler, or None
    where nothing was installed."""
    clear()
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGINT, on_interrupt)


def pending() -> bool:
    """Whether an interrupt arrived and has not been handled (:func:`clear`)."""
    return _pending


def clear() -> None:
    """The interrupt was handled."""
    global _pending
    _pending = False


def check() -> None:
    """Raise ``KeyboardInterrupt`` again if an interrupt arrived and was swallowed."""
    if _pending:
        raise KeyboardInterrupt


def run() -> int:
    """The ``synth`` console command: :func:`synth.cli.main`, loaded here so that a Ctrl-C
    while the command line's modules load (the first tens of milliseconds) ends it with
    "synth: interrupted" and exit status 130, as later, not with Python's traceback."""
    import sys

    try:
        from synth.cli import main
    except KeyboardInterrupt:
        print("synth: interrupted", file=sys.stderr)
        return 130
    return main()
