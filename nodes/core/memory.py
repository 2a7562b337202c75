"""Giving memory back after a flood of big messages.

A few hundred big payloads (megabytes each, decoded into millions of Python objects, reassembled by Zenoh
from fragments) leave the C heap fragmented: glibc keeps the freed pages, so a node that once handled a
flood keeps its peak RSS for good. After a large payload we ask glibc to return free pages to the system
(``malloc_trim(0)``, which walks every arena), once per burst: a large payload schedules a trim ``DELAY_S``
later, and every further one of the burst postpones it. Elsewhere than glibc this does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import threading
import time
from collections.abc import Callable

LARGE_BYTES = 64 * 1024   # a payload this big (or bigger) schedules a trim
DELAY_S = 0.5            # after the last large payload (a burst is trimmed once, when it is over)


def _load_trim() -> Callable[[int], int] | None:
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):   # not glibc (musl, macOS): nothing to do
        return None
    trim.argtypes = [ctypes.c_size_t]
    trim.restype = ctypes.c_int
    return trim


_trim = _load_trim()
M_MMAP_THRESHOLD = -3          # mallopt parameter (malloc.h)
MMAP_THRESHOLD_BYTES = 64 * 1024


def _fix_mmap_threshold() -> None:
    """Allocations of MMAP_THRESHOLD_BYTES and more always get their own mapping, returned when freed.

    glibc's default threshold adapts: once a big block is freed it rises to that block's size (up to 32 MB),
    so every later payload-sized buffer (Zenoh's reassembly, our copy, msgpack's strings) comes from the heap
    and a burst of them leaves the heap fragmented for good. A fixed threshold keeps them out of it."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
        libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
    except (OSError, AttributeError):
        pass


if _trim is not None:
    _fix_mmap_threshold()
_lock = threading.Lock()
_due: float | None = None      # monotonic time the pending trim runs at (None: none pending)
trims = 0   # how many trims ran (tests, statistics)


def release_now() -> bool:
    """Return the C heap's free pages to the system now; False where that is not possible."""
    global trims
    if _trim is None:
        return False
    _trim(0)
    trims += 1
    return True


def after_payload(size: int) -> None:
    """Call with the size of every payload received (and again once a large one has been handled): a large
    one schedules a trim DELAY_S later, postponed by every further large payload of the same burst."""
    global _due
    if size < LARGE_BYTES or _trim is None:
        return
    with _lock:
        pending = _due is not None
        _due = time.monotonic() + DELAY_S
    if not pending:
        threading.Thread(target=_wait_and_trim, daemon=True, name="malloc-trim").start()


def _wait_and_trim() -> None:
    global _due
    while True:
        with _lock:
            wait = _due - time.monotonic() if _due is not None else 0.0
            if wait <= 0:
                _due = None
                break
        time.sleep(wait)
    release_now()


def release_soon() -> None:
    """Schedule a trim after work that freed much memory outside a payload (a deleted model, a mesh read)."""
    after_payload(LARGE_BYTES)


def trim_periodically(period_s: float = 5.0) -> None:
    """A process that relays payloads without seeing them in Python (the launcher's embedded router): trim
    every ``period_s`` s on a daemon thread."""
    if _trim is None:
        return

    def loop() -> None:
        while True:
            time.sleep(period_s)
            release_now()

    threading.Thread(target=loop, daemon=True, name="malloc-trim-periodic").start()
