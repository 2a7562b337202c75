"""rclpy's loggers over ``nodes.core.log.Logger`` (stdout lines, and ``rosout`` for a node's logger):
``debug``/``info``/``warn``/``warning``/``error``/``fatal`` with ``once=``, ``skip_first=`` and
``throttle_duration_sec=``, ``set_level``, ``get_child``."""

from __future__ import annotations

import enum
import threading
import time
from typing import Any

from nodes.core.log import Logger as CoreLogger


class LoggingSeverity(enum.IntEnum):
    UNSET = 0
    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


_default_level = int(LoggingSeverity.INFO)
_loggers: dict[str, RcutilsLogger] = {}
_lock = threading.Lock()


def _level(level: Any) -> int:
    if isinstance(level, str):
        from nodes.core.log import parse_level

        return parse_level(level)
    return int(level)


def set_default_level(level: Any) -> None:
    global _default_level
    _default_level = _level(level)
    for logger in _loggers.values():
        if not logger._explicit:
            logger._core.level = _default_level


class RcutilsLogger:
    def __init__(self, name: str = "", core: CoreLogger | None = None) -> None:
        self.name = name
        self._core = core if core is not None else CoreLogger(name or "rclpy", _default_level)
        self._explicit = False
        self._calls: dict[tuple[Any, ...], list[Any]] = {}   # call site -> [count, last time]
        self._lock = threading.Lock()

    def get_child(self, name: str) -> RcutilsLogger:
        if not name:
            raise ValueError("Child logger name must not be empty.")
        full = f"{self.name}.{name}" if self.name else name
        child = RcutilsLogger(full, CoreLogger(full, self._core.level))
        child._core.set_sink(self._core._sink)
        return child

    def set_level(self, level: Any) -> bool:
        self._core.level = _level(level)
        self._explicit = True
        return True

    def get_effective_level(self) -> LoggingSeverity:
        return LoggingSeverity(self._core.level)

    def is_enabled_for(self, severity: Any) -> bool:
        return _level(severity) >= self._core.level

    def log(self, message: Any, severity: Any, **kwargs: Any) -> bool:
        level = _level(severity)
        if level < self._core.level:
            return False
        if kwargs and not self._admit(kwargs):
            return False
        self._core.log(level, str(message))
        return True

    def _admit(self, kwargs: dict[str, Any]) -> bool:
        unknown = set(kwargs) - {"once", "skip_first", "throttle_duration_sec", "throttle_time_source_type"}
        if unknown:
            raise TypeError(f"unsupported logging argument(s): {', '.join(sorted(unknown))}")
        import sys

        frame = sys._getframe(3)
        site = (frame.f_code.co_filename, frame.f_lineno)
        now = time.monotonic()
        with self._lock:
            state = self._calls.setdefault(site, [0, None])
            state[0] += 1
            if kwargs.get("once") and state[0] > 1:
                return False
            if kwargs.get("skip_first") and state[0] == 1:
                return False
            period = kwargs.get("throttle_duration_sec")
            if period:
                if state[1] is not None and now - state[1] < float(period):
                    return False
                state[1] = now
        return True

    def debug(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.DEBUG, **kwargs)

    def info(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.INFO, **kwargs)

    def warning(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.WARN, **kwargs)

    def warn(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.WARN, **kwargs)

    def error(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.ERROR, **kwargs)

    def fatal(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.FATAL, **kwargs)


def get_logger(name: str) -> RcutilsLogger:
    if not name:
        raise ValueError("Logger name must not be empty.")
    with _lock:
        logger = _loggers.get(name)
        if logger is None:
            logger = _loggers[name] = RcutilsLogger(name)
        return logger


def _register(name: str, logger: RcutilsLogger) -> None:
    """A node's logger, found again by ``get_logger(node name)`` and ``set_logger_level``."""
    with _lock:
        _loggers[name] = logger


def set_logger_level(name: str, level: Any, detailed_error: bool = False) -> None:
    get_logger(name).set_level(level)


def get_logger_effective_level(name: str) -> LoggingSeverity:
    return get_logger(name).get_effective_level()


def get_logger_level(name: str) -> LoggingSeverity:
    return get_logger(name).get_effective_level()


def initialize() -> None:
    return None


def shutdown() -> None:
    return None


def clear_config() -> None:
    return None


def get_logging_directory() -> str:
    import os

    return os.path.expanduser(os.environ.get("ROS_LOG_DIR", "~/.ros/log"))
