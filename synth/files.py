"""Writing result files whole or not at all.

Every file synth writes goes to a temporary file in the target's folder and is renamed over
the target only once it is complete (``os.replace`` is atomic within one file system), so a
full disk, a crash or a kill leaves either the old file or the new one, never half of one.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from synth.errors import OutputError

__all__ = ["atomic_path", "write_atomic"]


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary path next to ``target``, renamed to ``target`` when the block succeeds.

    The temporary file keeps the target's suffix (writers that pick a format from it, such as
    matplotlib and h5py, still work). If the block raises, the temporary file is removed and
    ``target`` is untouched; an ``OSError`` becomes :class:`OutputError` naming the target.

    Examples
    --------
    >>> with atomic_path("plan.png") as tmp:  # doctest: +SKIP
    ...     fig.savefig(tmp)
    """
    out = Path(target)
    folder = out.parent if str(out.parent) else Path(".")
    try:
        fd, name = tempfile.mkstemp(prefix=f".{out.name}.", suffix=f".part{out.suffix}",
                                    dir=folder)
    except OSError as e:
        raise OutputError(f"{out}: cannot write here ({e.strerror or e})") from e
    os.close(fd)
    tmp = Path(name)
    mask = os.umask(0)  # mkstemp makes the file private; give it the mode open() would
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    try:
        yield tmp
        os.replace(tmp, out)
    except OSError as e:
        raise OutputError(f"{out}: could not be written ({e.strerror or e}); any file of that "
                          f"name was left as it was") from e
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_atomic(target: str | os.PathLike[str], data: bytes | str | Callable[[Path], None],
                 encoding: str = "utf-8") -> Path:
    """Write ``data`` (bytes, text, or a function that writes a given path) to ``target``
    atomically (see :func:`atomic_path`); returns the target's path."""
    with atomic_path(target) as tmp:
        if callable(data):
            data(tmp)
        elif isinstance(data, bytes):
            tmp.write_bytes(data)
        else:
            tmp.write_text(data, encoding=encoding)
    return Path(target)
