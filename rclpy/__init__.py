"""zenroid's rclpy: ROS 2 Python programs run unchanged on the zenroid runtime (``nodes.core``), no ROS install.

As in rclpy, importing this package does not import ``rclpy.node``: ``import rclpy`` then ``rclpy.node.Node``
fails with AttributeError here as it does on ROS 2. API coverage and the deliberate differences:
docs/rclpy.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions, install_signal_handlers, uninstall_signal_handlers
from rclpy.task import Future
from rclpy.utilities import get_default_context, get_rmw_implementation_identifier, ok, try_shutdown
from rclpy.utilities import shutdown as _shutdown

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node

__all__ = ["Context", "Future", "Parameter", "SignalHandlerOptions", "create_node", "get_default_context",
           "get_global_executor", "get_rmw_implementation_identifier", "init", "install_signal_handlers", "ok",
           "shutdown", "spin",
           "spin_once", "spin_until_future_complete", "try_shutdown", "uninstall_signal_handlers"]

ZENROID = True   # tells programs (and people) which rclpy they got


class InitContextManager:
    """What ``rclpy.init()`` returns: ``with rclpy.init():`` shuts the context down on the way out."""

    def __init__(self, context: Context) -> None:
        self.context = context

    def __enter__(self) -> InitContextManager:
        return self

    def __exit__(self, *exc: Any) -> None:
        try_shutdown(context=self.context)


def init(*, args: list[str] | None = None, context: Context | None = None, domain_id: int | None = None,
         signal_handler_options: SignalHandlerOptions | None = None) -> InitContextManager:
    context = get_default_context() if context is None else context
    if signal_handler_options is None:
        signal_handler_options = SignalHandlerOptions.ALL if context is get_default_context() \
            else SignalHandlerOptions.NO
    install_signal_handlers(signal_handler_options)
    context.init(args, domain_id=domain_id)
    return InitContextManager(context)


def shutdown(*, context: Context | None = None, uninstall_handlers: bool | None = None) -> None:
    _shutdown(context=context, uninstall_handlers=uninstall_handlers)


def get_global_executor() -> Executor:
    from rclpy.executors import get_global_executor as _global

    return _global()


def create_node(node_name: str, *, context: Context | None = None, cli_args: list[str] | None = None,
                namespace: str | None = None, use_global_arguments: bool = True, enable_rosout: bool = True,
                start_parameter_services: bool = True, parameter_overrides: list[Parameter] | None = None,
                allow_undeclared_parameters: bool = False,
                automatically_declare_parameters_from_overrides: bool = False,
                enable_logger_service: bool = False) -> Node:
    from rclpy.node import Node

    return Node(node_name, context=context, cli_args=cli_args, namespace=namespace,
                use_global_arguments=use_global_arguments, enable_rosout=enable_rosout,
                start_parameter_services=start_parameter_services, parameter_overrides=parameter_overrides,
                allow_undeclared_parameters=allow_undeclared_parameters,
                automatically_declare_parameters_from_overrides=automatically_declare_parameters_from_overrides,
                enable_logger_service=enable_logger_service)


def spin_once(node: Node, *, executor: Executor | None = None, timeout_sec: float | None = None) -> None:
    executor = get_global_executor() if executor is None else executor
    try:
        executor.add_node(node)
        executor.spin_once(timeout_sec=timeout_sec)
    finally:
        executor.remove_node(node)


def spin(node: Node, executor: Executor | None = None) -> None:
    executor = get_global_executor() if executor is None else executor
    try:
        executor.add_node(node)
        while executor.context.ok():
            executor.spin_once()
    finally:
        executor.remove_node(node)


def spin_until_future_complete(node: Node, future: Future, executor: Executor | None = None,
                               timeout_sec: float | None = None) -> None:
    executor = get_global_executor() if executor is None else executor
    added = False
    try:
        added = executor.add_node(node)
        executor.spin_until_future_complete(future, timeout_sec)
    finally:
        if added:
            executor.remove_node(node)
