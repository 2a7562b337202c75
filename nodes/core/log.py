"""One logging helper for every node: stdout lines plus ``rcl_interfaces/msg/Log`` on ``rosout``.

Floods are contained here, once for every node: an identical line (same level and text) is let through a
few times, then at most once per ``REPEAT_PERIOD`` s with "(N identical lines suppressed)"; warnings and
errors from one call site are rate-limited even when their text varies (a flood of rejections that each
name a different value); a line longer than ``MAX_CHARS`` is cut with "… (N more characters)" so a huge
name in a bad message is never copied whole into the log.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable

LEVELS = {"debug": 10, "info": 20, "warn": 30, "warning": 30, "error": 40, "fatal": 50}
NAMES = {10: "DEBUG", 20: "INFO", 30: "WARN", 40: "ERROR", 50: "FATAL"}

MAX_CHARS = 2000
# identical lines: a burst of REPEAT_BURST, then one per REPEAT_PERIOD s
REPEAT_BURST, REPEAT_PERIOD = 3, 1.0
# warnings and errors from one call site (any text): a burst of SITE_BURST, then SITE_RATE per second
SITE_BURST, SITE_RATE = 20, 5.0
_MAX_KEYS = 1024  # distinct lines remembered (at most ~2 MB of text), then forgotten at once


def parse_level(level: str | int) -> int:
    """``"debug"``/``"INFO"``/``20`` → 20; raises ValueError naming the choices."""
    if isinstance(level, int) and not isinstance(level, bool):
        if level in NAMES:
            return level
    elif isinstance(level, str):
        if level.strip().lower() in LEVELS:
            return LEVELS[level.strip().lower()]
        if level.strip().isdigit() and int(level) in NAMES:
            return int(level)
    raise ValueError(f"unknown log level {level!r} (choose from debug, info, warn, error, fatal)")


def truncate(text: str, limit: int = MAX_CHARS) -> str:
    if len(text) <= limit:
        return text
    return f"{text[:limit]}… ({len(text) - limit} more characters)"


class _Bucket:
    """Token bucket: ``take()`` is True while tokens last; ``suppressed`` counts the refusals since the last pass."""

    __slots__ = ("tokens", "stamp", "suppressed", "first_suppressed")

    def __init__(self, burst: float, now: float) -> None:
        self.tokens = burst
        self.stamp = now
        self.suppressed = 0
        self.first_suppressed = 0.0

    def take(self, burst: float, rate: float, now: float) -> bool:
        self.tokens = min(burst, self.tokens + (now - self.stamp) * rate)
        self.stamp = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        if not self.suppressed:
            self.first_suppressed = now
        self.suppressed += 1
        return False


class Logger:
    def __init__(self, name: str, level: str | int = "info",
                 sink: Callable[[int, str, str, float], None] | None = None) -> None:
        self.name = name
        self.level = parse_level(level)
        self._sink = sink  # publishes to rosout; set by the node once its publisher exists
        self._once: set[str] = set()
        self._last: dict[str, float] = {}
        self._lock = threading.Lock()
        self._repeats: dict[tuple[int, str], _Bucket] = {}
        self._sites: dict[tuple[str, int], _Bucket] = {}

    def set_sink(self, sink: Callable[[int, str, str, float], None] | None) -> None:
        self._sink = sink

    def set_level(self, level: str | int) -> None:
        """Change the threshold at run time (``zenroid log level NODE debug``)."""
        self.level = parse_level(level)

    @property
    def level_name(self) -> str:
        return NAMES.get(self.level, str(self.level)).lower()

    def log(self, level: int, msg: str, *, per_site: bool = True) -> None:
        """``per_site=False``: a line its caller already limits per key (``warn_throttle``), exempt from the
        per-call-site budget, so that one place logging for many keys (a rejection per endpoint) still
        shows each key's line."""
        if level < self.level:
            return
        msg = truncate(str(msg))
        now_mono = time.monotonic()
        with self._lock:
            note = self._admit(level, msg, now_mono, per_site)
        if note is None:
            return
        self._emit(level, msg + note)

    def _admit(self, level: int, msg: str, now: float, per_site: bool = True) -> str | None:
        """None to drop the line, else a suffix reporting what was suppressed before it."""
        if len(self._repeats) > _MAX_KEYS:
            self._repeats.clear()
        if len(self._sites) > _MAX_KEYS:
            self._sites.clear()
        bucket = self._repeats.get((level, msg))
        if bucket is None:
            bucket = self._repeats[(level, msg)] = _Bucket(REPEAT_BURST, now)
        if not bucket.take(REPEAT_BURST, 1.0 / REPEAT_PERIOD, now):
            return None
        site_bucket = None
        if level >= 30 and per_site:
            site = _call_site()
            site_bucket = self._sites.get(site)
            if site_bucket is None:
                site_bucket = self._sites[site] = _Bucket(SITE_BURST, now)
            if not site_bucket.take(SITE_BURST, SITE_RATE, now):
                bucket.tokens += 1.0  # not shown: the identical-line budget is not spent
                return None
        notes = []
        if bucket.suppressed:
            notes.append(f"{bucket.suppressed} identical line{'s' if bucket.suppressed > 1 else ''} suppressed "
                         f"in {now - bucket.first_suppressed:.1f} s")
            bucket.suppressed = 0
        if site_bucket is not None and site_bucket.suppressed:
            notes.append(f"{site_bucket.suppressed} similar line{'s' if site_bucket.suppressed > 1 else ''} "
                         f"from the same place suppressed in {now - site_bucket.first_suppressed:.1f} s")
            site_bucket.suppressed = 0
        return f" ({'; '.join(notes)})" if notes else ""

    def _emit(self, level: int, msg: str) -> None:
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

    def warn_throttle(self, period_s: float, msg: str, key: str | None = None, *, per_site: bool = True) -> None:
        """Log at most once per ``period_s`` for ``key`` (default: the message). ``per_site=False`` only where
        the keys are bounded by the program itself (one per endpoint), never by what arrives."""
        k = key or msg
        now = time.monotonic()
        with self._lock:
            if len(self._last) > _MAX_KEYS:
                self._last.clear()
            if now - self._last.get(k, -1e18) < period_s:
                return
            self._last[k] = now
        self.log(30, msg, per_site=per_site)


def _call_site() -> tuple[str, int]:
    """(file, line) of the first frame outside this module: where the node called the logger."""
    frame = sys._getframe(1)
    while frame is not None and frame.f_code.co_filename == __file__:
        frame = frame.f_back  # type: ignore[assignment]
    return (frame.f_code.co_filename, frame.f_lineno) if frame is not None else ("?", 0)
