"""``run_node``: the one argument parser every node executable shares, and a clean process lifecycle."""

from __future__ import annotations

import argparse
import signal
import sys
from collections.abc import Callable
from typing import Any

from nodes.core import panic
from nodes.core.names import parse_assignment
from nodes.core.params import ParameterError, load_params_file, parse_value
from nodes.core.session import loopback_endpoint


def add_node_arguments(parser: argparse.ArgumentParser) -> None:
    """The shared node options (zenoh-python examples style: one parser for every program)."""
    g = parser.add_argument_group("node")
    g.add_argument("--name", help="override the node name")
    g.add_argument("--ns", "--namespace", dest="namespace", default=None, help="namespace (e.g. humanoid)")
    g.add_argument("--param", "-p", action="append", default=[], metavar="NAME:=VALUE", help="set a parameter")
    g.add_argument("--params-file", action="append", default=[], metavar="FILE", help="ROS-style YAML parameters")
    g.add_argument("--remap", "-r", action="append", default=[], metavar="FROM:=TO", help="remap a name")
    g.add_argument("--log-level", default="info", choices=["debug", "info", "warn", "error"])
    add_connection_arguments(parser)


def add_connection_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--zenoh-port", type=int, default=None,
                        help="connect to the router on tcp/127.0.0.1:PORT (default: $ZENOH_CONNECT or 7447)")


def connect_from_args(args: argparse.Namespace) -> list[str] | None:
    port = getattr(args, "zenoh_port", None)
    return [loopback_endpoint(port)] if port else None


def node_kwargs(args: argparse.Namespace, node_name: str) -> dict[str, Any]:
    """Constructor keyword arguments for a Node from parsed shared arguments."""
    params: dict[str, Any] = {}
    namespace = args.namespace or ""
    name = args.name or node_name
    for path in args.params_file:
        params.update(load_params_file(path, name, namespace))
    for item in args.param:
        key, value = parse_assignment(item)
        params[key] = parse_value(value)
    remap = dict(parse_assignment(r) for r in args.remap)
    kwargs: dict[str, Any] = {"namespace": namespace, "params": params, "remap": remap,
                              "connect": connect_from_args(args), "log_level": args.log_level}
    if args.name:
        kwargs["node_name"] = args.name
    return kwargs


def run_node(factory: Callable[..., Any], argv: list[str] | None = None, *,
             parser: argparse.ArgumentParser | None = None) -> int:
    """Parse the shared arguments, build the node, spin until SIGINT/SIGTERM, always close the session.

    ``factory`` is a Node subclass (or any callable taking Node keyword arguments). Extra
    node-specific options can be added to ``parser``; they are passed as ``cli_args=`` when the
    factory accepts it.
    """
    parser = parser or argparse.ArgumentParser(description=(factory.__doc__ or "").strip().split("\n")[0] or None)
    add_node_arguments(parser)
    args = parser.parse_args(argv)
    panic.install()
    default_name = getattr(factory, "default_name", None) or getattr(factory, "__name__", "node")
    try:
        kwargs = node_kwargs(args, default_name)
    except (ValueError, ParameterError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if accepts_keyword(factory, "cli_args"):
        kwargs["cli_args"] = args
    try:
        node = factory(**kwargs)  # a failing constructor has already closed its session (Node.__init_subclass__)
    except (ParameterError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # Ctrl-C while the node was still starting (a slow machine, a long import or wait): a short line,
        # not a traceback; the half-built node has closed its session on the way out
        print(f"{default_name}: interrupted while starting", file=sys.stderr)
        return 130

    def on_signal(signum: int, _frame: Any) -> None:
        node.logger.info(f"received {signal.Signals(signum).name}, shutting down")
        node.request_shutdown()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        node.spin()
    except BaseException as exc:
        if panic.is_zenoh_panic(exc):
            panic.die(exc, "spin")   # before the shutdown below: closing a poisoned session hangs
        raise
    finally:
        node.executor.run_callback(node.on_process_exit, where="on_process_exit")  # the shutdown hook
        node.destroy()
    return 0


def accepts_keyword(factory: Callable[..., Any], name: str) -> bool:
    import inspect

    try:
        return name in inspect.signature(factory).parameters
    except (TypeError, ValueError):
        return False
