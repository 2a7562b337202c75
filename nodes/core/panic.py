"""A Zenoh panic ends the process.

zenoh-python surfaces a Rust panic as ``pyo3_runtime.PanicException`` (a ``BaseException``): after one, the
session's locks are poisoned and every later Zenoh call panics too, or blocks. A process in that state
serves nothing yet keeps its pid, so nothing would respawn it: the first panic Python sees ends the process
at once, without the usual shutdown (closing a poisoned session is what hangs), with ``PANIC_EXIT``.
"""

from __future__ import annotations

import os
import sys
import threading
import traceback
from types import TracebackType

PANIC_EXIT = 70   # EX_SOFTWARE: an internal error; the launcher respawns the node like any crash


def is_zenoh_panic(exc: BaseException | None) -> bool:
    """Is ``exc`` (or what it was raised from or during) a Rust panic surfaced by pyo3?"""
    seen = 0
    while exc is not None and seen < 10:
        if type(exc).__name__ == "PanicException" and type(exc).__module__ == "pyo3_runtime":
            return True
        exc = exc.__cause__ or exc.__context__
        seen += 1
    return False


def die(exc: BaseException, where: str) -> None:
    """Say why on stderr (the launcher's log of this node) and end the process now."""
    try:
        tb = traceback.extract_tb(exc.__traceback__)
        at = f" at {tb[-1].filename}:{tb[-1].lineno}" if tb else ""
        sys.stderr.write(f"[FATAL] Zenoh panicked in {where}{at}: {str(exc)[:300]}; the session is unusable: "
                         f"ending the process (status {PANIC_EXIT})\n")
        sys.stderr.flush()
    finally:
        os._exit(PANIC_EXIT)


def _excepthook(kind: type[BaseException], exc: BaseException, tb: TracebackType | None) -> None:
    if is_zenoh_panic(exc):
        die(exc, "the main thread")
    _previous_excepthook(kind, exc, tb)


def _thread_excepthook(args: threading.ExceptHookArgs) -> None:
    if is_zenoh_panic(args.exc_value):
        die(args.exc_value, f"thread {args.thread.name if args.thread else '?'}")
    _previous_thread_excepthook(args)


_previous_excepthook = sys.excepthook
_previous_thread_excepthook = threading.excepthook


def install() -> None:
    """Uncaught panics in any thread end the process (callbacks and spin loops call ``die`` themselves)."""
    sys.excepthook = _excepthook
    threading.excepthook = _thread_excepthook
