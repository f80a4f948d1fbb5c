"""How a process opens a grasp database file: readers leave no trace, one writer at a time.

Reading (:func:`open_reader`) never writes: the file is opened with SQLite's ``mode=ro`` URI,
which creates no file for a database at rest (a build leaves it in rollback-journal mode, see
:func:`rest`) and reads a running build's write-ahead log (``-wal``). A file left in WAL mode
without a ``-wal`` file -- written by an older synth, or whose build could not switch it back --
would make ``mode=ro`` create ``-wal`` and ``-shm`` files (or fail in a folder that cannot be
written), so it is opened with ``immutable=1`` instead, under a shared lock that keeps a build
from starting while it is read. A ``-wal`` file left by a killed build is read, never ignored.

Writing (:func:`open_writer`) takes an exclusive ``flock`` on the database file, held from
before the file is created until the connection is closed: a second build of the same file,
started at the same moment or later, is refused with a :class:`DatabaseError` saying the
database is busy, instead of racing the first one.

Closing any descriptor of a file drops every POSIX lock SQLite holds on that file in this
process, so the descriptors opened here are kept open until the last connection this module
opened on that file is released (:func:`release`), never closed while another one may be
using the file. Connections to the same file opened elsewhere in the process, bypassing this
module, are not protected.
"""

from __future__ import annotations

import fcntl
import os
import sqlite3
import threading
from urllib.parse import quote

from synth.errors import DatabaseError, DatabaseFileError

__all__ = ["open_reader", "open_writer", "release", "rest"]

#: Descriptors opened on each file, by (device, inode): closed together when the last is
#: released, so that no close drops another connection's POSIX locks (see the module notes).
_OPEN: dict[tuple[int, int], list[int]] = {}
_RELEASED: dict[tuple[int, int], int] = {}
_GUARD = threading.Lock()

_SQLITE_MAGIC = b"SQLite format 3\x00"
_WAL_HEADER = slice(18, 20)  # SQLite header bytes 18 and 19: 1 rollback journal, 2 WAL


def _read_header(path: str, fd: int) -> bytes:
    """The first 100 bytes of the file; refuse a non-empty file that is not SQLite."""
    try:
        head = os.pread(fd, 100, 0)
    except OSError as e:
        raise DatabaseError(f"{path}: cannot read grasp database: {e.strerror or e}") from e
    if head and not head.startswith(_SQLITE_MAGIC):
        from synth.filetype import DATABASE, require

        require(path, DATABASE)  # a mesh, a grasp file: named as such
        raise DatabaseFileError(f"{path}: not a synth grasp database (not an SQLite file)")
    return head


def _register(fd: int) -> int:
    """Keep ``fd`` open until :func:`release`; returns it."""
    st = os.fstat(fd)
    with _GUARD:
        _OPEN.setdefault((st.st_dev, st.st_ino), []).append(fd)
    return fd


def release(fd: int | None) -> None:
    """Release a handle returned by :func:`open_reader` or :func:`open_writer` (None:
    nothing), after closing its connection.

    Its lock ends now (an exclusive or shared ``flock`` is dropped); the descriptor itself is
    closed when every handle on the same file in this process has been released, because
    closing a descriptor of the file would drop the POSIX locks SQLite holds for the other
    connections.
    """
    if fd is None:
        return
    fcntl.flock(fd, fcntl.LOCK_UN)
    st = os.fstat(fd)
    key = (st.st_dev, st.st_ino)
    with _GUARD:
        fds = _OPEN.get(key, [])
        _RELEASED[key] = _RELEASED.get(key, 0) + 1
        if _RELEASED[key] < len(fds):
            return
        del _OPEN[key], _RELEASED[key]
    for f in fds:
        os.close(f)


def open_reader(path: str) -> tuple[sqlite3.Connection, int]:
    """Open the existing SQLite file ``path`` read-only, without creating any file.

    Returns
    -------
    conn : sqlite3.Connection
        A read-only connection (``isolation_level=None``).
    handle : int
        A file descriptor of the file (holding a shared lock while ``conn`` reads an
        immutable file); give it to :func:`release` after closing ``conn``.

    Raises
    ------
    DatabaseError
        Naming ``path``, if it cannot be read or is not an SQLite file.
    """
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except OSError as e:
        raise DatabaseError(f"{path}: cannot read grasp database: {e.strerror or e}") from e
    lock = None
    try:
        head = _read_header(path, fd)
        if head[_WAL_HEADER] == b"\x02\x02" and not os.path.exists(path + "-wal"):
            try:
                fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
                lock = fd  # no build writes it, and none can start while it is read
            except BlockingIOError:
                pass  # a build is starting: its -wal is about to exist, read it with mode=ro
        query = "mode=ro&immutable=1" if lock is not None else "mode=ro"
        conn = sqlite3.connect(
            f"file:{quote(os.path.abspath(path))}?{query}", uri=True, isolation_level=None
        )
    except sqlite3.Error as e:
        release(_register(fd))  # closed at once unless other handles use the file
        raise DatabaseError(f"{path}: cannot open grasp database: {e}") from e
    except BaseException:
        release(_register(fd))
        raise
    return conn, _register(fd)


def open_writer(path: str) -> tuple[sqlite3.Connection, int]:
    """Open (creating it if missing) the database file ``path`` as its only writer.

    Returns
    -------
    conn : sqlite3.Connection
        A read-write connection (``isolation_level=None``).
    lock : int
        The file descriptor holding the exclusive lock; :func:`release` it after closing
        ``conn``.

    Raises
    ------
    DatabaseError
        Naming ``path``: the database is busy (another ``synth db build`` writes it, or a
        reader holds an immutable view of it), the file cannot be opened for writing, or it
        is not an SQLite file (then it is left as it is).
    """
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
    except OSError as e:
        raise DatabaseError(f"{path}: cannot open grasp database for writing: "
                            f"{e.strerror or e}") from e  # fmt: skip
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise DatabaseError(
                f"{path}: database busy: another 'synth db build' is writing it (or a reader "
                "holds it); run this build when that one has finished, or use another --out file"
            ) from None
        _read_header(path, fd)
        conn = sqlite3.connect(path, isolation_level=None)
    except sqlite3.Error as e:
        release(_register(fd))
        raise DatabaseError(f"{path}: cannot open grasp database: {e}") from e
    except BaseException:
        release(_register(fd))
        raise
    return conn, _register(fd)


def rest(conn: sqlite3.Connection) -> None:
    """Leave a written database in rollback-journal mode, its ``-wal`` and ``-shm`` removed.

    A file at rest is readable with ``mode=ro`` anywhere, even in a read-only folder, without
    creating files. While another connection has the file open the switch is refused; the file
    then stays in WAL mode, which is as valid (readers still work), until the next build.
    """
    try:
        conn.execute("PRAGMA journal_mode = DELETE")
    except sqlite3.OperationalError:
        pass  # "database is locked": a reader has the file open
