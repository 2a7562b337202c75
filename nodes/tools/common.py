"""What every CLI verb shares: connecting like a node (and saying so when nobody answers), the graph with
"did you mean" hints for ROS names, YAML → message, message → YAML, output that survives a closed pipe."""

from __future__ import annotations

import argparse
import contextlib
import difflib
import os
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from typing import Any

import yaml

import msgs
from nodes.core import Node, ServiceError, add_connection_arguments, connect_from_args
from nodes.tools.errors import Failed, UsageError

GRAPH_WAIT = 2.0  # s a verb re-reads the graph before concluding that a node or topic is missing
ROUTER_WAIT = 3.0  # s a verb waits (after the session opened) for a router before giving up (a loaded machine)


def add_common(parser: argparse.ArgumentParser) -> None:
    add_connection_arguments(parser)


def _where(args: argparse.Namespace) -> str:
    from nodes.core.session import ENV_CONFIG, default_endpoints

    if connect_from_args(args):
        return ", ".join(connect_from_args(args) or [])
    if os.environ.get(ENV_CONFIG):
        return f"the endpoints of {ENV_CONFIG}={os.environ[ENV_CONFIG]}"
    return ", ".join(default_endpoints())


def cli_node(args: argparse.Namespace, purpose: str, router_wait: float = ROUTER_WAIT) -> Node:
    """A short-lived node for one CLI command (named so ``node list`` shows what it is).

    Fails (``Failed``, exit 1) when no router or peer answers within ``router_wait`` s: a verb with nobody
    to talk to must say so instead of printing nothing and exiting 0.
    """
    from nodes.core.session import is_connected

    node = Node(f"zenroid_{purpose}_{os.getpid()}", connect=connect_from_args(args), log_level="warn")
    deadline = time.monotonic() + router_wait
    while not is_connected(node.session):
        if time.monotonic() >= deadline:
            node.destroy()
            raise Failed(f"no Zenoh router answers at {_where(args)} (start the stack with `python -m launch "
                         f"humanoid.yaml`; launched with zenoh_port:=N? pass --zenoh-port N)")
        time.sleep(0.05)
    return node


def is_cli_node(name: str) -> bool:
    return name.lstrip("/").startswith("zenroid_")


def snapshot(node: Node, *, include_self: bool = False) -> list[Any]:
    """The live graph seen by a CLI node (without the CLI node's own endpoints unless asked)."""
    from nodes.core import graph

    entries = graph.snapshot(node.session)
    return entries if include_self else [e for e in entries if e.node != node.fully_qualified_name]


def snapshot_until(node: Node, found: Callable[[list[Any]], bool], timeout: float = GRAPH_WAIT) -> list[Any]:
    """Graph snapshots until ``found(entries)`` or ``timeout`` s: a fresh session can get a partial answer
    while its routes to the other peers form (seen on a loaded machine), so a miss is confirmed, not trusted."""
    deadline = time.monotonic() + timeout
    while True:
        entries = snapshot(node)
        if found(entries) or time.monotonic() >= deadline:
            return entries
        time.sleep(0.2)


def require_nodes(entries: Iterable[Any], args: argparse.Namespace) -> None:
    """List verbs: fail when no node (other than CLI helpers) is running at all."""
    if not any(e.kind == "node" and not is_cli_node(e.node) for e in entries):
        raise Failed(f"no nodes are running (the router at {_where(args)} answers, but nobody is there; "
                     "start them with `python -m launch humanoid.yaml`)")


def graph_until(args: argparse.Namespace, purpose: str, found: Callable[[list[Any]], bool]) -> list[Any]:
    """The live graph as seen by a short-lived CLI node, re-read until ``found(entries)`` (``snapshot_until``)."""
    node = cli_node(args, purpose)
    try:
        return snapshot_until(node, found)
    finally:
        node.destroy()


def graph_entries(args: argparse.Namespace, purpose: str, *, require: bool = True) -> list[Any]:
    """The live graph as seen by a short-lived CLI node (``require``: fail when no node runs)."""
    entries = graph_until(args, purpose, lambda es: any(e.kind == "node" and not is_cli_node(e.node) for e in es))
    if require:
        require_nodes(entries, args)
    return entries


def suggest(name: str, candidates: Iterable[str], prefix: str = "") -> str:
    """"; did you mean humanoid/joint_states?" for a ROS name that lives under a namespace here, else ""
    (``prefix="/"`` for node names, which are shown fully qualified)."""
    wanted = name.strip("/")
    pool = sorted({c.strip("/") for c in candidates if c and c.strip("/") != wanted})
    if not wanted or not pool:
        return ""
    matches = [c for c in pool if c.endswith("/" + wanted)]  # /joint_states -> humanoid/joint_states
    if not matches:
        tail = wanted.rsplit("/", 1)[-1]
        matches = [c for c in pool if c.rsplit("/", 1)[-1] == tail and c.count("/") >= 1] or \
            difflib.get_close_matches(wanted, pool, n=3, cutoff=0.75)
    if not matches:
        return ""
    return f"; did you mean {' or '.join(prefix + m for m in matches[:3])}?"


def require_node(node: Node, name: str) -> str:
    """The fully qualified name of a running node, or ``Failed`` with a hint (``/joint_commander`` →
    did you mean /humanoid/joint_commander?)."""
    target = "/" + name.strip("/")
    entries = snapshot_until(node, lambda es: any(e.kind == "node" and e.node == target for e in es))
    names = {e.node for e in entries if e.kind == "node"}
    if target in names:
        return target
    hint = suggest(target, [n for n in names if not is_cli_node(n)], prefix="/")
    raise Failed(f"no node '{target}' is running{hint or ' (see `zenroid node list`)'}")


Argument = str | tuple[Any, ...]  # a positional name, or (name or flags..., add_argument keywords)


def add_verb(sub: Any, name: str, help_text: str, *arguments: Argument) -> argparse.ArgumentParser:
    """A sub-command with its ``arguments`` and the connection options every verb takes."""
    parser = sub.add_parser(name, help=help_text)
    for argument in arguments:
        *flags, options = (argument, {}) if isinstance(argument, str) else argument
        parser.add_argument(*flags, **options)
    add_common(parser)
    return parser


def add_list_verb(sub: Any, help_text: str) -> argparse.ArgumentParser:
    """``list [-t]`` of ``service``/``action``/``topic``: endpoints, with their types on ``-t``."""
    return add_verb(sub, "list", help_text,
                    ("-t", "--show-types", {"action": "store_true", "help": "also print each one's type"}))


def offered(entries: Iterable[Any], kind: str) -> dict[str, str]:
    """name -> type of every ``kind`` endpoint (``srv``, ``act``...) that a node (not a CLI verb) offers."""
    return {e.name: e.type_name for e in entries if e.kind == kind and not is_cli_node(e.node)}


def call_failure(node: Node, kind: str, key: str, exc: Exception, missing: str) -> Failed:
    """Why a call to ``key`` failed: ``missing`` and a suggestion when no node offers a ``kind`` endpoint
    there (``srv``, ``act``), else the call's own reason."""
    servers = offered(snapshot(node), kind)
    if key not in servers:
        return Failed(f"{missing}{suggest(key, servers)}")
    return Failed(str(exc))


@contextlib.contextmanager
def calling(args: argparse.Namespace, purpose: str, kind: str, missing: str) -> Iterator[Node]:
    """A short-lived CLI node for calls to the ``kind`` endpoint (``srv``, ``act``) ``args.key``: a failed call
    (``ServiceError``) ends as ``Failed`` with ``missing`` and a hint when nobody offers it, else its reason."""
    node = cli_node(args, purpose)
    try:
        yield node
    except ServiceError as exc:
        raise call_failure(node, kind, key_of(args.key), exc, missing) from None
    finally:
        node.destroy()


def endpoints_at(args: argparse.Namespace, purpose: str, key: str, kinds: tuple[str, ...], missing: str) -> list[Any]:
    """The graph entries of ``kinds`` (``("srv",)``, ``("act", "actc")``) named ``key``; ``Failed`` with
    ``missing`` and a hint among the endpoints of ``kinds[0]`` when there are none."""
    entries = graph_until(args, purpose, lambda es: any(e.kind in kinds and e.name == key for e in es))
    found = [e for e in entries if e.kind in kinds and e.name == key]
    if not found:
        raise Failed(f"{missing}{suggest(key, {e.name for e in entries if e.kind == kinds[0]})}")
    return found


def typed_request(args: argparse.Namespace, kind: type) -> tuple[Any, Any, str]:
    """``KEY TYPE VALUES`` of ``service call`` / ``action send_goal``: the interface (``kind``: ``msgs.Service``
    or ``msgs.Action``), its request or goal built from the YAML, and the key."""
    interface = interface_type(args.type, kind)
    request = message_from_yaml(interface.Request if kind is msgs.Service else interface.Goal, args.values)
    return interface, request, key_of(args.key)


def interface_type(type_name: str, kind: type) -> Any:
    """A service or action type by name (``kind``: ``msgs.Service`` or ``msgs.Action``); else a usage error."""
    found = resolve_type(type_name)
    if not isinstance(found, kind):
        raise UsageError(f"'{type_name}' is not {'a service' if kind is msgs.Service else 'an action'} type")
    return found


def print_endpoints(args: argparse.Namespace, kind: str, purpose: str) -> int:
    """``service list`` / ``action list``: every endpoint of ``kind`` with (``-t``) its type."""
    found = {(e.name, e.type_name) for e in graph_entries(args, purpose) if e.kind == kind}
    for name, type_name in sorted(found):
        print(f"/{name} [{type_name}]" if args.show_types else f"/{name}")
    return 0


def resolve_type(type_name: str) -> Any:
    """A message/service/action type by name, including those the nodes ship (``nodes/*/definitions``, e.g.
    the simulator's ``zenroid_sim_msgs``), which a node registers only when it is imported."""
    from pathlib import Path

    try:
        return msgs.get_type(type_name)
    except (KeyError, msgs.DefinitionError):
        import nodes

        for directory in sorted(Path(nodes.__file__).resolve().parent.glob("*/definitions")):
            msgs.add_search_path(directory)
    try:
        return msgs.get_type(type_name)
    except (KeyError, msgs.DefinitionError) as exc:
        raise UsageError(f"unknown type '{type_name}': {exc}") from None


def message_from_yaml(cls: Any, text: str) -> Any:
    """Build a message from a YAML/flow-map string (``"{name: [a], position: [0.1]}"``), validated."""
    try:
        data = yaml.safe_load(text) if text.strip() else {}
    except yaml.YAMLError as exc:
        raise UsageError(f"invalid YAML: {exc}".replace("\n", " ")) from None
    if data is None:
        data = {}
    try:
        return msgs.from_dict(cls, data)
    except msgs.DecodeError as exc:
        raise UsageError(str(exc)) from None


def key_of(name: str) -> str:
    """ROS users type ``/humanoid/joint_states``; keys have no leading slash."""
    return name.strip().strip("/")


def to_yaml(data: Any) -> str:
    """Block YAML of a message (a scalar prints as itself: no ``...`` document-end line)."""
    text = yaml.safe_dump(_plain(data), sort_keys=False, default_flow_style=None, width=120).rstrip()
    if text.endswith("\n..."):
        text = text[: -len("\n...")].rstrip()
    return text


def write_message(title: str, msg: Any) -> None:
    """``title`` on its own line, then the message as block YAML (``service call``, ``action send_goal``)."""
    write_line(f"{title}\n{to_yaml(msgs.to_dict(msg))}")


def write_line(text: str) -> None:
    """Print from any thread; a closed pipe (``| head``) raises BrokenPipeError for the caller to end on."""
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, bytes):
        return list(value)
    return value
