"""One logging helper for every node: stdout lines plus ``rcl_interfaces/msg/Log`` on ``rosout``."""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable

LEVELS = {"debug": 10, "info": 20, "warn": 30, "warning": 30, "error": 40, "fatal": 50}
NAMES = {10: "DEBUG", 20: "INFO", 30: "WARN", 40: "ERROR", 50: "FATAL"}


class Logger:
    def __init__(self, name: str, level: str | int = "info",
                 sink: Callable[[int, str, str, float], None] | None = None) -> None:
        self.name = name
        self.level = LEVELS[level.lower()] if isinstance(level, str) else int(level)
        self._sink = sink  # publishes to rosout; set by the node once its publisher exists
        self._once: set[str] = set()
        self._last: dict[str, float] = {}
        self._lock = threading.Lock()

    def set_sink(self, sink: Callable[[int, str, str, float], None] | None) -> None:
        self._sink = sink

    def log(self, level: int, msg: str) -> None:
        if level < self.level:
            return
        now = time.time()
        stream = sys.stderr if level >= 40 else sys.stdout
        try:
            print(f"[{NAMES.get(level, level)}] [{now:.6f}] [{self.name}]: {msg}", file=stream, flush=True)
        except (BrokenPipeError, ValueError):
            pass  # stdout gone (parent exited): rosout still gets it
        sink = self._sink
        if sink is not None:
            try:
                sink(level, self.name, msg, now)
            except Exception:  # noqa: BLE001 - logging must never raise into the caller
                pass

    def debug(self, msg: str) -> None:
        self.log(10, msg)

    def info(self, msg: str) -> None:
        self.log(20, msg)

    def warn(self, msg: str) -> None:
        self.log(30, msg)

    warning = warn

    def error(self, msg: str) -> None:
        self.log(40, msg)

    def fatal(self, msg: str) -> None:
        self.log(50, msg)

    def warn_once(self, msg: str, key: str | None = None) -> None:
        """Log ``msg`` the first time ``key`` (default: the message) is seen."""
        k = key or msg
        with self._lock:
            if k in self._once:
                return
            self._once.add(k)
        self.warn(msg)

    def warn_throttle(self, period_s: float, msg: str, key: str | None = None) -> None:
        """Log at most once per ``period_s`` for ``key`` (default: the message)."""
        k = key or msg
        now = time.monotonic()
        with self._lock:
            if now - self._last.get(k, -1e18) < period_s:
                return
            self._last[k] = now
        self.warn(msg)
