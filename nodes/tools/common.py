"""What every CLI verb shares: connecting like a node, YAML → message, message → YAML."""

from __future__ import annotations

import argparse
import os
from typing import Any

import yaml

import msgs
from nodes.core import Node, add_connection_arguments, connect_from_args
from nodes.tools.cli import UsageError


def add_common(parser: argparse.ArgumentParser) -> None:
    add_connection_arguments(parser)


def cli_node(args: argparse.Namespace, purpose: str) -> Node:
    """A short-lived node for one CLI command (named so ``node list`` shows what it is)."""
    return Node(f"zenroid_{purpose}_{os.getpid()}", connect=connect_from_args(args), log_level="warn")


def graph_entries(args: argparse.Namespace, purpose: str) -> list[Any]:
    """The live graph as seen by a short-lived CLI node."""
    from nodes.core import graph

    node = cli_node(args, purpose)
    try:
        return graph.snapshot(node.session)
    finally:
        node.destroy()


def print_endpoints(args: argparse.Namespace, kind: str, purpose: str) -> int:
    """``service list`` / ``action list``: every endpoint of ``kind`` with (``-t``) its type."""
    found = {(e.name, e.type_name) for e in graph_entries(args, purpose) if e.kind == kind}
    for name, type_name in sorted(found):
        print(f"/{name} [{type_name}]" if args.show_types else f"/{name}")
    return 0


def resolve_type(type_name: str) -> Any:
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
    return yaml.safe_dump(_plain(data), sort_keys=False, default_flow_style=None, width=120).rstrip()


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, bytes):
        return list(value)
    return value
