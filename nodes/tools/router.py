"""``zenroid router``: a standalone Zenoh router (a stand-in for ``zenohd`` on a machine without it).

Listens on loopback by default; give ``--listen tcp/<address>:<port>`` to serve other machines, then point
their launchers and nodes at it with ``ZENOH_CONNECT=tcp/<address>:<port>``.
"""

from __future__ import annotations

import argparse
import signal
import threading

from nodes.core.session import DEFAULT_PORT, loopback_endpoint, open_router
from nodes.tools.cli import UsageError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                        help=f"endpoint to listen on (repeatable); default {loopback_endpoint(DEFAULT_PORT)}")
    parser.add_argument("--zenoh-port", type=int, default=DEFAULT_PORT, help="loopback port when no --listen")


def run(args: argparse.Namespace) -> int:
    listen = args.listen or [loopback_endpoint(args.zenoh_port)]
    for endpoint in listen:
        if not endpoint.startswith(("tcp/", "udp/", "quic/", "tls/", "unixsock-stream/")):
            raise UsageError(f"bad endpoint '{endpoint}': expected e.g. tcp/127.0.0.1:7447")
    try:
        session = open_router(listen=listen)
    except Exception as exc:  # noqa: BLE001 - zenoh reports a busy port or bad address as a generic error
        raise UsageError(f"cannot listen on {', '.join(listen)}: {exc}") from None
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    print(f"zenoh router {session.info.zid()} listening on {', '.join(listen)} (multicast scouting off)", flush=True)
    try:
        stop.wait()
    finally:
        session.close()
    return 0
