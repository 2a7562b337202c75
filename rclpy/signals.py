"""SIGINT and SIGTERM as rclpy handles them: every context is shut down and spinning executors wake;
SIGINT then raises KeyboardInterrupt in the main thread, SIGTERM makes ``spin`` raise
ExternalShutdownException."""

from __future__ import annotations

import enum
import signal
import threading
from typing import Any


class SignalHandlerOptions(enum.IntEnum):
    NO = 0
    SIGINT = 1
    SIGTERM = 2
    ALL = 3


_installed: dict[int, Any] = {}


def _handler(signum: int, frame: Any) -> None:
    from rclpy.context import get_default_context

    context = get_default_context()
    context.signalled = signum   # also seen by an init still waiting for its router
    if context.ok():
        context._shut_by_signal = True
    context.try_shutdown()
    if signum == signal.SIGINT:
        previous = _installed.get(signal.SIGINT)
        if callable(previous) and previous not in (signal.SIG_IGN, signal.SIG_DFL):
            previous(signum, frame)
        else:
            raise KeyboardInterrupt


def install_signal_handlers(options: SignalHandlerOptions = SignalHandlerOptions.ALL) -> None:
    if threading.current_thread() is not threading.main_thread():
        return   # Python only lets the main thread install handlers
    wanted = []
    if options in (SignalHandlerOptions.SIGINT, SignalHandlerOptions.ALL):
        wanted.append(signal.SIGINT)
    if options in (SignalHandlerOptions.SIGTERM, SignalHandlerOptions.ALL):
        wanted.append(signal.SIGTERM)
    for signum in wanted:
        if signum not in _installed:
            _installed[signum] = signal.signal(signum, _handler)


def get_current_signal_handlers_options() -> SignalHandlerOptions:
    has_int, has_term = signal.SIGINT in _installed, signal.SIGTERM in _installed
    if has_int and has_term:
        return SignalHandlerOptions.ALL
    return SignalHandlerOptions.SIGINT if has_int else SignalHandlerOptions.SIGTERM if has_term \
        else SignalHandlerOptions.NO


def uninstall_signal_handlers() -> None:
    if threading.current_thread() is not threading.main_thread():
        return
    for signum, previous in list(_installed.items()):
        signal.signal(signum, previous)
        del _installed[signum]
