"""Run native code that may crash in a child process, so a crash cannot end the command.

A segmentation fault inside a C++ library (manifold3d on a robot's visual mesh of thousands
of open pieces did this) kills the whole process; Python cannot catch it. So the calls that
hand a library meshes it may not cope with run in one child Python process per parent
process: started on first use, reused by every later call (a call costs a round trip
through a pipe, tens of microseconds plus the pickling of its arrays), and started again
after a crash. The child imports only what the called function imports, ignores Ctrl-C
(the parent handles it) and ends with its parent (end of input, or on Linux the kernel's
parent-death signal).

A call whose child dies raises :class:`NativeCrash`, which names the signal; the caller
skips what the call was for and says so.

Examples
--------
>>> call_isolated("math:hypot", 3.0, 4.0)
5.0
"""

from __future__ import annotations

import atexit
import os
import pickle
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any, BinaryIO

from synth.errors import InternalError

__all__ = ["NativeCrash", "call_isolated", "die_with_parent", "how_it_ended"]

_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>
_PACKAGE_ROOT = str(Path(__file__).resolve().parent.parent)


class NativeCrash(InternalError):
    """The child process died during a call (a crash in native code, or killed).

    Attributes
    ----------
    function : str
        The ``module:function`` called.
    signal : int or None
        The signal that ended the child (None: it exited with ``code``).
    code : int
        Its exit status (minus the signal number when a signal ended it).
    """

    def __init__(self, function: str, code: int) -> None:
        self.function = function
        self.code = code
        self.signal = -code if code < 0 else None
        super().__init__(f"{function} crashed: {self.how}")

    @property
    def how(self) -> str:
        """The way the child ended, in words (see :func:`how_it_ended`)."""
        return how_it_ended(self.code)


def how_it_ended(code: int | None) -> str:
    """A process's end from its exit status (``Popen.returncode``, ``Process.exitcode``:
    minus the signal number when a signal ended it), in words.

    Examples
    --------
    >>> how_it_ended(-11)
    'killed by SIGSEGV (segmentation fault)'
    >>> how_it_ended(3)
    'exited with status 3'
    """
    if code is None:
        return "ended, how is unknown"
    if code >= 0:
        return f"exited with status {code}"
    try:
        sig = signal.Signals(-code)
    except ValueError:
        return f"killed by signal {-code}"
    text = signal.strsignal(sig) or ""
    more = " (out of memory?)" if sig == signal.SIGKILL else ""
    return f"killed by {sig.name}" + (f" ({text[0].lower() + text[1:]})" if text else "") + more


def die_with_parent() -> None:
    """On Linux, have the kernel send SIGKILL to this process when its parent dies."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):
        pass  # the end of its input stops it too


class _Child:
    """The child process and its two pipes."""

    def __init__(self) -> None:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([_PACKAGE_ROOT] + (
            [env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
        self.proc = subprocess.Popen(
            [sys.executable, "-c", "from synth.isolate import _serve; _serve()"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env)
        self.send: BinaryIO = self.proc.stdin  # type: ignore[assignment]
        self.receive: BinaryIO = self.proc.stdout  # type: ignore[assignment]
        pickle.dump(list(sys.path), self.send)  # the parent's imports work in the child

    def call(self, function: str, args: tuple[Any, ...]) -> tuple[bool, Any]:
        """``(True, result)`` or ``(False, the exception the function raised)``."""
        try:
            pickle.dump((function, args), self.send, protocol=pickle.HIGHEST_PROTOCOL)
            self.send.flush()
            return pickle.load(self.receive)  # type: ignore[no-any-return]
        except (EOFError, BrokenPipeError, pickle.UnpicklingError):
            raise NativeCrash(function, self.proc.wait()) from None

    def close(self) -> None:
        try:
            self.send.close()
        except OSError:
            pass
        self.proc.wait()

    def kill(self) -> None:
        """End the child at once (a call was abandoned: its answer must not be read as the
        next call's)."""
        self.proc.kill()
        self.close()


_lock = threading.Lock()
_child: _Child | None = None


def call_isolated(function: str, *args: Any) -> Any:
    """``module.function(*args)`` in the child process; its result (arguments and result
    are pickled).

    Parameters
    ----------
    function : str
        ``"module:function"``, importable in the child (the parent's ``sys.path`` is).
    *args
        Its arguments.

    Returns
    -------
    Whatever the function returns.

    Raises
    ------
    NativeCrash
        The child died during the call; the next call starts a new one.
    Exception
        Whatever the function raised, raised again here.
    """
    global _child
    with _lock:
        if _child is None:
            _child = _Child()
        try:
            ok, value = _child.call(function, args)
        except NativeCrash:
            _child.close()
            _child = None
            raise
        except BaseException:  # Ctrl-C, a time limit's alarm: the call is abandoned midway
            _child.kill()
            _child = None
            raise
    if not ok:
        raise value
    return value


@atexit.register
def _stop_child() -> None:
    global _child
    if _child is not None:
        _child.close()
        _child = None


def _serve() -> None:
    """The child's loop: read ``(function, args)``, answer ``(True, result)`` or
    ``(False, exception)``, until the parent closes the pipe."""
    import importlib

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    die_with_parent()
    source = os.fdopen(os.dup(0), "rb")
    answer = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # whatever the libraries print goes to stderr, never into the answers
    sys.path[:] = pickle.load(source)
    while True:
        try:
            function, args = pickle.load(source)
        except EOFError:
            return
        module, _, name = function.partition(":")
        try:
            reply = (True, getattr(importlib.import_module(module), name)(*args))
        except Exception as e:  # noqa: BLE001 - raised again in the parent
            reply = (False, e)
        try:
            data = pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as e:  # noqa: BLE001 - an exception that does not pickle
            data = pickle.dumps((False, InternalError(f"{function}: {type(e).__name__}: {e}")))
        answer.write(data)
        answer.flush()
