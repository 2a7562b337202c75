"""``zenroid router``: a standalone Zenoh router (a stand-in for ``zenohd`` on a machine without it).

Listens on loopback by default; give ``--listen tcp/<address>:<port>`` to serve other machines, then point
their launchers and nodes at it with ``ZENOH_CONNECT=tcp/<address>:<port>``. Takes zenohd's own options for
what it does (``--config FILE`` with a zenohd json5 configuration, e.g. access control and user/password
authentication; ``--listen``; ``--no-multicast-scouting``, always the case here), so a zenohd command line
(docker-compose.yml) runs unchanged. ``RUST_LOG`` sets Zenoh's log level, as for zenohd.
"""

from __future__ import annotations

import argparse
import signal
import threading

from nodes.core.session import (
    DEFAULT_PORT,
    init_zenoh_log,
    insert_config_value,
    listen_endpoints,
    loopback_endpoint,
    open_config,
    router_config,
)
from nodes.tools.cli import UsageError

ENDPOINT_PROTOCOLS = ("tcp/", "udp/", "quic/", "tls/", "unixsock-stream/")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--listen", "-l", action="append", default=[], metavar="ENDPOINT",
                        help=f"endpoint to listen on (repeatable); default {loopback_endpoint(DEFAULT_PORT)}, "
                             "or the --config file's listeners")
    parser.add_argument("--zenoh-port", type=int, default=DEFAULT_PORT, help="loopback port when no --listen")
    parser.add_argument("--config", "-c", metavar="FILE",
                        help="zenohd configuration (json5): access control, authentication, listeners, ...")
    parser.add_argument("--cfg", action="append", default=[], metavar="KEY:VALUE",
                        help="set one configuration value, as zenohd: a config path and a json5 value, "
                             "e.g. 'transport/link/rx/max_message_size:16777216'")
    parser.add_argument("--no-multicast-scouting", action="store_true",
                        help="accepted for zenohd compatibility: multicast scouting is always off here")


def run(args: argparse.Namespace) -> int:
    for endpoint in args.listen:
        if not endpoint.startswith(ENDPOINT_PROTOCOLS):
            raise UsageError(f"bad endpoint '{endpoint}': expected e.g. tcp/127.0.0.1:7447")
    init_zenoh_log()
    try:
        config = router_config(args.zenoh_port, args.listen or None, args.config)
    except Exception as exc:  # noqa: BLE001 - zenoh reports an unreadable or invalid file as a generic error
        raise UsageError(f"cannot use the configuration {args.config}: {exc}") from None
    for item in args.cfg:
        key, sep, value = item.partition(":")
        if not sep or not key.strip():
            raise UsageError(f"--cfg takes KEY:VALUE (a config path and a json5 value), got '{item}'")
        try:
            insert_config_value(config, key.strip(), value)
        except Exception as exc:  # noqa: BLE001 - zenoh names the bad key or value in a generic error
            raise UsageError(f"--cfg {item}: {exc}") from None
    listen = listen_endpoints(config)
    try:
        session = open_config(config)
    except Exception as exc:  # noqa: BLE001 - zenoh reports a busy port or bad address as a generic error
        raise UsageError(f"cannot listen on {', '.join(listen)}: {exc}") from None
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    extras = " with " + args.config if args.config else ""
    print(f"zenoh router {session.info.zid()} listening on {', '.join(listen)}{extras} (multicast scouting off)",
          flush=True)
    try:
        stop.wait()
    finally:
        session.close()
    return 0
