"""Action names in the graph (``ros2 action list``)."""

from __future__ import annotations

from typing import Any


def get_action_names_and_types(node: Any) -> list[tuple[str, list[str]]]:
    return node._zr_names_and_types(("act", "actc"))


def get_action_server_names_and_types_by_node(node: Any, remote_node_name: str, remote_node_namespace: str
                                              ) -> list[tuple[str, list[str]]]:
    return node._zr_names_and_types(("act",), node._zr_fq(remote_node_name, remote_node_namespace))


def get_action_client_names_and_types_by_node(node: Any, remote_node_name: str, remote_node_namespace: str
                                              ) -> list[tuple[str, list[str]]]:
    return node._zr_names_and_types(("actc",), node._zr_fq(remote_node_name, remote_node_namespace))
