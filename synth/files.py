"""Writing result files whole or not at all.

Every file synth writes goes to a temporary file in the target's folder, is flushed to disk,
and is renamed over the target only once it is complete (``os.replace`` is atomic within one
file system), so a full disk, a crash or a kill leaves either the old file or the new one,
never half of one. And synth replaces only files it wrote (:func:`wrote_by_synth` tells them
by their first bytes): never an input, nor a file of the user's that happens to have the
name.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from synth.errors import OutputError

__all__ = ["atomic_path", "atomic_paths", "writing", "write_atomic", "wrote_by_synth"]


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: Read once, at import: reading it means setting it, which races with other threads.
_UMASK = _read_umask()


@contextlib.contextmanager
def writing(target: str | os.PathLike[str]) -> Iterator[None]:
    """Turn an ``OSError`` raised in the block into :class:`OutputError` naming ``target``
    (wrap the writing of each file in it, so that an error names the right file)."""
    try:
        yield
    except OSError as e:
        raise OutputError(f"{target}: could not be written ({e.strerror or e}); any file of "
                          f"that name was left as it was") from e


@contextlib.contextmanager
def atomic_paths(targets: Sequence[str | os.PathLike[str]]) -> Iterator[list[Path]]:
    """Temporary paths next to ``targets``, renamed over them together when the block succeeds.

    Each temporary file keeps its target's suffix (writers that pick a format from it, such as
    matplotlib and h5py, still work). If the block raises, every temporary file is removed and
    no target is touched: a set of files is replaced only once all of them are written. The
    renames come one after the other, so a failure of a rename itself (rare: the folder
    vanished) can leave the earlier targets replaced. Errors raised in the block pass through
    unchanged; wrap each file's writing in :func:`writing`.

    Examples
    --------
    >>> with atomic_paths(["plan.json", "plan.png"]) as (tmp_json, tmp_png):  # doctest: +SKIP
    ...     with writing("plan.json"):
    ...         tmp_json.write_text(text)
    ...     with writing("plan.png"):
    ...         fig.savefig(tmp_png)
    """
    outs = [Path(t) for t in targets]
    tmps: list[Path] = []
    try:
        for out in outs:
            folder = out.parent if str(out.parent) else Path(".")
            try:
                fd, name = tempfile.mkstemp(prefix=f".{out.name}.",
                                            suffix=f".part{out.suffix}", dir=folder)
            except OSError as e:
                raise OutputError(f"{out}: cannot write here ({e.strerror or e})") from e
            os.close(fd)
            tmps.append(Path(name))
            os.chmod(name, 0o666 & ~_UMASK)  # mkstemp makes it private; give open()'s mode
        yield list(tmps)
        for tmp, out in zip(tmps, outs, strict=True):
            with writing(out):
                with open(tmp, "rb+") as fh:  # on disk before the rename, not only in cache
                    os.fsync(fh.fileno())
        for tmp, out in zip(tmps, outs, strict=True):
            with writing(out):
                os.replace(tmp, out)
    finally:
        for tmp in tmps:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary path next to ``target``, renamed to ``target`` when the block succeeds (see
    :func:`atomic_paths`); an ``OSError`` in the block becomes :class:`OutputError` naming
    the target.

    Examples
    --------
    >>> with atomic_path("plan.png") as tmp:  # doctest: +SKIP
    ...     fig.savefig(tmp)
    """
    with atomic_paths([target]) as (tmp,), writing(target):
        yield tmp


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


#: The format of a JSON document synth writes (its grasps, rankings, scores, exports), but not
#: a gripper description (``synth.gripper``), which people write by hand.
_SYNTH_JSON = re.compile(rb'"format"\s*:\s*"synth\.(?!gripper")')


def wrote_by_synth(path: str | os.PathLike[str]) -> bool:
    """Whether an existing file is one of synth's outputs, from its first bytes: a JSON
    document whose ``format`` names one of synth's (in its first 64 KB), a PNG with a
    ``synth.run_id`` text chunk, a GLB whose scene extras hold a ``synth`` entry. A file that
    cannot be read or parsed is not."""
    try:
        with open(path, "rb") as f:
            head = f.read(1 << 16)
            if head.startswith(b"glTF") and len(head) >= 20:
                f.seek(20)  # the JSON chunk, its length in the header
                doc = json.loads(f.read(min(int.from_bytes(head[12:16], "little"), 1 << 26)))
                scenes = doc.get("scenes") if isinstance(doc, dict) else None
                scene = scenes[0] if isinstance(scenes, list) and scenes else None
                return any(isinstance(e, dict) and "synth" in e for e in (
                    doc.get("extras") if isinstance(doc, dict) else None,
                    scene.get("extras") if isinstance(scene, dict) else None))
    except (OSError, ValueError, RecursionError):
        return False
    if head.startswith(b"\x89PNG\r\n\x1a\n"):
        return b"tEXtsynth.run_id\x00" in head or b"iTXtsynth.run_id\x00" in head
    return head.lstrip()[:1] == b"{" and bool(_SYNTH_JSON.search(head))
