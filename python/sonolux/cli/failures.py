"""What the command does when a run cannot finish: one line for the user, never a traceback.

- :func:`one_line` folds a message onto one line (a core error may carry several).
- :func:`describe_os_error` names the file and what the system said (a missing or read-only
  folder, a full disk).
- :func:`stop_on_sigterm` turns SIGTERM into :class:`Terminated`, so that the outputs being
  written are removed by their ``finally`` blocks as for Ctrl-C.
- :func:`write_crash_log` keeps the traceback of a real bug in a log file, for the report.
"""

from __future__ import annotations

import contextlib
import os
import signal
import tempfile
import time
import traceback
from collections.abc import Iterator
from pathlib import Path

ISSUES_URL = "https://github.com/sonolux/sonolux/issues"


class Terminated(BaseException):  # noqa: N818  (a signal, like KeyboardInterrupt)
    """The process received SIGTERM; raised in the main thread like KeyboardInterrupt."""


def interrupted(exc: BaseException | None) -> bool:
    """Whether ``exc`` is a KeyboardInterrupt or was caused by one (an extension module that
    is loading may wrap Ctrl-C in an error of its own)."""
    seen = 0
    while exc is not None and seen < 20:
        if isinstance(exc, KeyboardInterrupt):
            return True
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


def one_line(exc: BaseException) -> str:
    """The exception's message with its lines joined by "; "."""
    text = str(exc).strip() or type(exc).__name__
    return "; ".join(part.strip() for part in text.splitlines() if part.strip())


def describe_os_error(exc: OSError) -> str:
    """``cannot write out/x.wav: No such file or directory`` and the like."""
    where = exc.filename if exc.filename is not None else ""
    reason = exc.strerror or str(exc)
    if exc.filename2 is not None:
        where = f"{where} -> {exc.filename2}"
    return f"{where}: {reason}" if where else one_line(exc)


@contextlib.contextmanager
def stop_on_sigterm() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread."""
    def handler(signum, frame):  # noqa: ARG001
        raise Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread (the library called from a worker): leave it
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def write_crash_log(exc: BaseException) -> Path | str:
    """Writes the traceback to ``$SONOLUX_LOG_DIR`` (default: the system's temporary folder)
    as ``sonolux-crash-<time>-<pid>.log``; returns its path (or a note if it cannot)."""
    folder = Path(os.environ.get("SONOLUX_LOG_DIR") or tempfile.gettempdir())
    path = folder / f"sonolux-crash-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.log"
    try:
        path.write_text("".join(traceback.format_exception(exc)), encoding="utf-8")
    except OSError:
        return "(no log: set SONOLUX_DEBUG=1 to see the traceback)"
    return path
