"""rclpy.utilities: ``ok``, ``shutdown``, ``try_shutdown``, ``get_default_context``, ``remove_ros_args``."""

from __future__ import annotations

from typing import Any

from rclpy.arguments import remove_ros_args
from rclpy.context import Context, get_default_context

__all__ = ["get_available_rmw_implementations", "get_default_context", "get_rmw_implementation_identifier", "ok",
           "remove_ros_args", "shutdown", "timeout_sec_to_nsec", "try_shutdown"]


def ok(*, context: Context | None = None) -> bool:
    return (context or get_default_context()).ok()


def shutdown(*, context: Context | None = None, uninstall_handlers: bool | None = None) -> None:
    """Shut the context down. After Ctrl-C (which already shut it down) this is quiet, where rclpy raises."""
    ctx = context or get_default_context()
    from rclpy import signals

    if ctx is get_default_context() and ctx._shut_by_signal:
        ctx.try_shutdown()
    else:
        ctx.shutdown()
    if uninstall_handlers or (uninstall_handlers is None and ctx is get_default_context()):
        signals.uninstall_signal_handlers()


def try_shutdown(*, context: Context | None = None, uninstall_handlers: bool | None = None) -> None:
    ctx = context or get_default_context()
    from rclpy import signals

    ctx.try_shutdown()
    if uninstall_handlers or (uninstall_handlers is None and ctx is get_default_context()):
        signals.uninstall_signal_handlers()


def get_rmw_implementation_identifier() -> str:
    return "rmw_zenoh_cpp"


def get_available_rmw_implementations() -> set[str]:
    return {"rmw_zenoh_cpp"}


def timeout_sec_to_nsec(timeout_sec: Any) -> int:
    if timeout_sec is None or timeout_sec < 0:
        return -1
    return int(float(timeout_sec) * 1e9)
