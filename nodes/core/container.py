"""``python -m nodes.core.container``: a component container, several nodes in one OS process.

As rclcpp_components' ``component_container``: the launcher starts it for a ``node_container`` entry with one
``--composable '{"plugin": "MODULE::Class", "argv": [...]}'`` per ``composable_node`` (``argv`` is the node's
usual command line: ``--name``, ``--ns``, ``--params-file``, ``--remap``). Every node is built as
``run_node`` would build it, but all of them share one Zenoh session with in-process hand-off switched on
(``intraprocess.py``): a message between two of them is the published object itself, and the same message
still reaches every other process over Zenoh. Each node keeps its own graph presence, parameters,
services and ROS 2 twin, so ``zenroid node list`` shows each of them, as separate processes would.

The container is itself a node (its name and namespace), which serves ``~/get_parameters``: the launcher's
health probe and ``wait_for`` see the process through it. The first composed node spins on the main
thread (the simulator's stepping loop keeps the process's main thread, which ``exclusive_cpu`` pins), the
others each on a thread of their own. The nodes share the process's fate: when one node's loop ends or
fails, the container ends them all, and the launcher respawns the whole container.
"""

from __future__ import annotations

import argparse
import importlib
import json
import signal
import sys
import threading
from dataclasses import dataclass
from typing import Any

from nodes.core import intraprocess
from nodes.core.node import Node
from nodes.core.params import ParameterError
from nodes.core.runner import accepts_keyword, add_node_arguments, connect_from_args, node_kwargs
from nodes.core.session import open_peer

PLUGIN_SEPARATOR = "::"   # launch_ros's spelling: "package::Class"; ours "python.module::NodeClass"
JOIN_TIMEOUT_S = 5.0      # for each node's spin thread once shutdown is requested
CONFIGURATION_ERROR = 2   # as run_node: a configuration the node refused (not worth respawning)


class CompositionError(ValueError):
    """A composable node that cannot be loaded: bad plugin, bad arguments."""


@dataclass
class Composable:
    """One node to load: its class and its node command line."""

    plugin: str
    factory: type
    args: argparse.Namespace


def load_plugin(plugin: str) -> type:
    """``MODULE::Class`` → the Node subclass (imported; never evaluated)."""
    module_name, separator, class_name = plugin.partition(PLUGIN_SEPARATOR)
    if not separator or not module_name or not class_name or PLUGIN_SEPARATOR in class_name:
        raise CompositionError(f"plugin '{plugin}' must look like python.module{PLUGIN_SEPARATOR}NodeClass")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise CompositionError(f"plugin '{plugin}': cannot import '{module_name}': {exc}") from None
    factory = getattr(module, class_name, None)
    if not (isinstance(factory, type) and issubclass(factory, Node)):
        raise CompositionError(f"plugin '{plugin}': '{module_name}' has no Node subclass '{class_name}'")
    return factory


def parse_composable(text: str) -> Composable:
    try:
        entry = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CompositionError(f"--composable is not JSON: {exc}") from None
    if not isinstance(entry, dict) or not isinstance(entry.get("plugin"), str) or not isinstance(
            entry.get("argv", []), list) or not all(isinstance(a, str) for a in entry.get("argv", [])):
        raise CompositionError('--composable must be {"plugin": "module::Class", "argv": ["--name", ...]}')
    parser = argparse.ArgumentParser(prog=entry["plugin"], add_help=False, exit_on_error=False)
    add_node_arguments(parser)
    try:
        args = parser.parse_args(entry.get("argv", []))
    except (argparse.ArgumentError, SystemExit) as exc:
        raise CompositionError(f"plugin '{entry['plugin']}': bad node arguments {entry.get('argv')}: {exc}") from None
    return Composable(entry["plugin"], load_plugin(entry["plugin"]), args)


def build_node(composable: Composable, session: Any, connect: list[str] | None) -> Node:
    """The node as ``run_node`` builds it from the same command line, on the container's session."""
    default_name = getattr(composable.factory, "default_name", None) or composable.factory.__name__
    kwargs: dict[str, Any] = node_kwargs(composable.args, default_name)
    kwargs["session"] = session
    kwargs["connect"] = connect
    if accepts_keyword(composable.factory, "cli_args"):
        kwargs["cli_args"] = composable.args
    return composable.factory(**kwargs)


class Container:
    """The container node and the nodes loaded into it; ``run`` spins them until one ends or a signal."""

    def __init__(self, args: argparse.Namespace, composables: list[Composable]) -> None:
        self.connect = connect_from_args(args)
        self.session = open_peer(self.connect)
        intraprocess.enable(self.session)
        self.nodes: list[Node] = []
        self.failed = False
        self._ended = threading.Event()
        try:
            kwargs = node_kwargs(args, "component_container")
            kwargs.update(session=self.session, connect=self.connect)
            self.manager = Node("component_container", **kwargs)
            for composable in composables:
                node = build_node(composable, self.session, self.connect)
                self.nodes.append(node)
                self.manager.logger.info(f"loaded '{node.fully_qualified_name}' ({composable.plugin})")
        except BaseException:
            self.close()
            raise

    def request_shutdown(self) -> None:
        self._ended.set()
        for node in (*self.nodes, getattr(self, "manager", None)):
            if node is not None:
                node.request_shutdown()

    def _spin(self, node: Node) -> None:
        try:
            node.spin()
        except BaseException as exc:  # noqa: BLE001 - any node's failure ends the process (one fate)
            self.failed = True
            node.logger.error(f"spin ended with {type(exc).__name__}: {exc}: ending the container")
        finally:
            # one node's loop ended (a failure, or it asked to stop): the others go with it, as the
            # process they share would with separate processes' fates combined
            self.request_shutdown()

    def run(self) -> int:
        threads = [threading.Thread(target=self._spin, args=(node,), daemon=True, name=f"spin:{node.name}")
                   for node in (*self.nodes[1:], self.manager)]
        for thread in threads:
            thread.start()
        if self.nodes:
            self._spin(self.nodes[0])   # the main thread: the first node's loop (the simulator's stepping)
        else:
            self._ended.wait()
        for thread in threads:
            thread.join(timeout=JOIN_TIMEOUT_S)
        for node in self.nodes:
            node.executor.run_callback(node.on_process_exit, where="on_process_exit")
        return 1 if self.failed else 0

    def close(self) -> None:
        for node in reversed(self.nodes):
            try:
                node.destroy()
            except Exception as exc:  # noqa: BLE001 - destroy the others anyway
                print(f"destroying {node.name}: {exc}", file=sys.stderr)
        manager = getattr(self, "manager", None)
        if manager is not None:
            manager.destroy()
        intraprocess.disable(self.session)
        self.session.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="run several nodes in one process (a component container)")
    add_node_arguments(parser)
    parser.add_argument("--composable", action="append", default=[], metavar="JSON",
                        help='a node to load: {"plugin": "python.module::NodeClass", "argv": [node arguments]}')
    args = parser.parse_args(argv)
    try:
        composables = [parse_composable(text) for text in args.composable]
    except CompositionError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return CONFIGURATION_ERROR
    try:
        container = Container(args, composables)
    except (CompositionError, ParameterError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return CONFIGURATION_ERROR
    except KeyboardInterrupt:
        print("component_container: interrupted while starting", file=sys.stderr)
        return 130

    def on_signal(signum: int, _frame: Any) -> None:
        container.manager.logger.info(f"received {signal.Signals(signum).name}, shutting down")
        container.request_shutdown()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        return container.run()
    finally:
        container.close()


if __name__ == "__main__":
    sys.exit(main())
