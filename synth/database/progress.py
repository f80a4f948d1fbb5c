"""A small progress bar for long runs: one line on a terminal, rewritten in place.

It writes only when its stream is a TTY (and not ``quiet``), at most every ``interval`` seconds,
so logs and pipes stay clean. No dependency beyond the standard library.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from synth.interrupt import check

__all__ = ["ProgressBar", "format_duration"]


def format_duration(seconds: float) -> str:
    """``h:mm:ss`` (or ``m:ss`` under an hour) for a duration in seconds."""
    s = max(0, int(round(seconds)))
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class ProgressBar:
    """Meshes done / failed, grasps stored, rate and ETA, on one line of ``stream``.

    Parameters
    ----------
    total : int
        Number of meshes to plan in this run.
    stream : file, optional
        Where to draw (default ``sys.stderr``).
    quiet : bool
        Never draw.
    interval : float
        Minimum seconds between two redraws.
    width : int
        Characters of the bar itself.

    Examples
    --------
    >>> bar = ProgressBar(10, quiet=True)
    >>> bar.update(done=1, failed=0, grasps=10)
    >>> bar.close()
    """

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        quiet: bool = False,
        interval: float = 0.2,
        width: int = 24,
    ) -> None:
        self.total = max(0, int(total))
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = not quiet and bool(isatty and isatty())
        self.interval = interval
        self.width = width
        self._start = time.monotonic()
        self._last = 0.0
        self._drawn = False

    def line(self, done: int, failed: int, grasps: int) -> str:
        """The text of the bar for these counts (``done`` includes ``failed``)."""
        frac = done / self.total if self.total else 1.0
        fill = int(round(frac * self.width))
        elapsed = time.monotonic() - self._start
        rate = done / elapsed * 60.0 if elapsed > 0 else 0.0
        eta = (self.total - done) * elapsed / done if done else None
        return (
            f"[{'#' * fill}{'.' * (self.width - fill)}] {done}/{self.total} meshes, "
            f"{failed} failed, {grasps} grasps, {rate:.1f}/min, "
            f"ETA {format_duration(eta) if eta is not None else '?'}"
        )

    def update(self, done: int, failed: int, grasps: int, force: bool = False) -> None:
        """Redraw if enabled and ``interval`` has passed (or ``force``); an interrupt
        swallowed since is raised again (:mod:`synth.interrupt`)."""
        check()
        if not self.enabled:
            return
        now = time.monotonic()
        if not force and now - self._last < self.interval:
            return
        self._last = now
        self.stream.write("\r" + self.line(done, failed, grasps) + "\x1b[K")
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """End the bar's line so what follows starts on a fresh one."""
        if self.enabled and self._drawn:
            self.stream.write("\n")
            self.stream.flush()
