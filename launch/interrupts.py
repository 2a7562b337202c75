"""Ctrl-C from the first instant: the launcher's SIGINT/SIGTERM handlers go in before anything else.

A launcher started from a script in the background (``python -m launch humanoid.yaml &``) inherits
SIGINT *ignored* (POSIX shells do that for background jobs), and Python then installs no
KeyboardInterrupt handler. A handler installed only once the router and the supervisor exist left a gap
of a second or more in which Ctrl-C / ``kill -INT`` did nothing at all. So the very first statement of
the launcher installs these handlers: they only record the signal; each start-up stage checks
``requested()``, and the supervisor takes over with ``hand_over`` (replaying what arrived early).
Installing a Python handler also means the nodes start with the default SIGINT action (an exec resets
handled signals, but keeps ignored ones).
"""

from __future__ import annotations

import signal
from collections.abc import Callable
from typing import Any

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_received: list[int] = []
_target: Callable[[int, Any], None] | None = None


def _record(signum: int, frame: Any = None) -> None:
    if _target is not None:
        _target(signum, frame)
    else:
        _received.append(signum)


def install() -> None:
    """Record SIGINT/SIGTERM from now on (idempotent; main thread only, as Python requires)."""
    for sig in SIGNALS:
        if signal.getsignal(sig) is not _record:
            signal.signal(sig, _record)


def requested() -> str | None:
    """The name of the first signal received before the supervisor took over, if any."""
    return signal.Signals(_received[0]).name if _received else None


def hand_over(handler: Callable[[int, Any], None]) -> None:
    """Route signals to ``handler`` from now on, and deliver the ones that arrived before."""
    global _target
    install()
    _target = handler
    early, _received[:] = list(_received), []
    for signum in early:
        handler(signum, None)


def release() -> None:
    """Back to recording (the supervisor is gone)."""
    global _target
    _target = None
