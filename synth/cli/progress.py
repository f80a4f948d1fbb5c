"""A one-line progress bar on stderr for long commands (silent when not a terminal)."""

from __future__ import annotations

import sys
import time
from typing import TextIO

from synth.interrupt import check

__all__ = ["LineProgress"]


class LineProgress:
    """Call with ``(fraction, message)``; draws ``[#####.....]  42%  message  3.1 s``.

    Nothing is drawn when ``enabled`` is False, when the stream is not a terminal, or during
    the first half second (short runs stay quiet).
    """

    def __init__(self, enabled: bool = True, stream: TextIO | None = None, width: int = 28):
        self.stream = stream or sys.stderr
        self.enabled = enabled and self.stream.isatty()
        self.width = width
        self.t0 = time.perf_counter()
        self.drawn = False

    def __call__(self, fraction: float, message: str) -> None:
        """Draw the bar at ``fraction`` (clipped to [0, 1]) with ``message`` after it (an
        interrupt swallowed since is raised again: :mod:`synth.interrupt`)."""
        check()
        if not self.enabled or time.perf_counter() - self.t0 < 0.5:
            return
        f = min(max(fraction, 0.0), 1.0)
        fill = int(round(f * self.width))
        line = (f"[{'#' * fill}{'.' * (self.width - fill)}] {100 * f:3.0f}%  {message}  "
                f"{time.perf_counter() - self.t0:.1f} s")
        self.stream.write("\r" + line[:120].ljust(120))
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        """Clear the line."""
        if self.drawn:
            self.stream.write("\r" + " " * 120 + "\r")
            self.stream.flush()
