"""``zenroid doctor``: check the installation (libraries, robots) and the connection to the router."""

from __future__ import annotations

import argparse
import importlib
import os
import socket

from nodes.core import graph
from nodes.core.runner import connect_from_args
from nodes.core.session import default_endpoints
from nodes.tools.common import add_common

_LIBRARIES = ("zenoh", "msgpack", "yaml", "numpy", "dartpy", "yourdfpy", "xacro", "rerun", "lxml")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_common(parser)


def _version(module: object) -> str:
    return str(getattr(module, "__version__", "") or getattr(module, "version", "") or "ok")


def run(args: argparse.Namespace) -> int:
    problems = 0
    for name in _LIBRARIES:
        try:
            module = importlib.import_module(name)
            print(f"[ok]   {name} {_version(module)}")
        except Exception as exc:  # noqa: BLE001 - report every broken import, keep checking
            problems += 1
            print(f"[FAIL] {name}: {type(exc).__name__}: {exc}")
    from nodes.share import ROBOTS_DIR, robot_names

    robots = robot_names()
    print(f"[{'ok' if robots else 'FAIL'}]   robots in {ROBOTS_DIR}: {', '.join(robots) or 'none'}")
    problems += not robots
    endpoints = connect_from_args(args) or default_endpoints()
    print(f"[info] ZENOH_CONNECT={os.environ.get('ZENOH_CONNECT', '')!r} ZENOH_CONFIG="
          f"{os.environ.get('ZENOH_CONFIG', '')!r} -> {', '.join(endpoints)}")
    reachable = False
    for ep in endpoints:
        if ep.startswith("tcp/"):
            host, _, port = ep[4:].rpartition(":")
            try:
                with socket.create_connection((host.strip("[]"), int(port)), timeout=1.0):
                    reachable = True
            except (OSError, ValueError):
                pass
    if not reachable:
        print("[warn] no router answers there: start one with `python -m launch humanoid.yaml` "
              "(or pass --zenoh-port)")
        return 1 if problems else 0
    from nodes.core.session import open_peer

    session = open_peer(endpoints)
    try:
        nodes = graph.node_names(session, 1.0)
    finally:
        session.close()
    print(f"[ok]   router reachable; {len(nodes)} node(s): {', '.join(nodes) or '-'}")
    return 1 if problems else 0
