"""Zenoh session setup (docs/architecture.md, Zenoh topology): explicit loopback endpoints, multicast scouting off, always closed."""

from __future__ import annotations

import ipaddress
import json
import os
import socket

import zenoh

DEFAULT_PORT = 7447
ENV_CONNECT = "ZENOH_CONNECT"
ENV_CONFIG = "ZENOH_CONFIG"
RECONNECT = {"period_init_ms": 250, "period_max_ms": 1000, "period_increase_factor": 2}
# The largest message a node decodes (nodes.core.endpoints checks it before decoding and logs what it drops);
# ZENROID_MAX_PAYLOAD_BYTES raises it for a deployment that moves bigger messages.
ENV_MAX_PAYLOAD = "ZENROID_MAX_PAYLOAD_BYTES"
DEFAULT_MAX_PAYLOAD = 4 * 1024 * 1024


def max_payload_bytes() -> int:
    raw = os.environ.get(ENV_MAX_PAYLOAD, "").strip()
    try:
        return max(1024, int(raw)) if raw else DEFAULT_MAX_PAYLOAD
    except ValueError:
        return DEFAULT_MAX_PAYLOAD


def max_transport_message_bytes() -> int:
    """What Zenoh itself accepts from a link (it drops bigger messages without closing the link): a few times
    the decode limit, so an oversized message still reaches the node to be refused with a log line, while a
    56 MB flood is never reassembled in the router's or a node's memory (Zenoh's default is 1 GiB)."""
    return 4 * max_payload_bytes()


def loopback_endpoint(port: int) -> str:
    return f"tcp/127.0.0.1:{int(port)}"


def default_endpoints() -> list[str]:
    """Endpoints a node connects to: ``ZENOH_CONNECT`` (comma separated) or the local router."""
    raw = os.environ.get(ENV_CONNECT, "").strip()
    if raw:
        return [e.strip() for e in raw.split(",") if e.strip()]
    return [loopback_endpoint(DEFAULT_PORT)]


def external_router_configured() -> bool:
    """True when the environment points nodes at a router the launcher must not start itself."""
    return bool(os.environ.get(ENV_CONFIG) or os.environ.get(ENV_CONNECT))


def _base_config() -> zenoh.Config:
    path = os.environ.get(ENV_CONFIG)
    config = zenoh.Config.from_file(path) if path else zenoh.Config()
    # Never discover peers by multicast: only the endpoints we are told about.
    config.insert_json5("scouting/multicast/enabled", "false")
    if not path:   # a user's config file keeps its own transport limits
        _limit_message_size(config)
    return config


def _limit_message_size(config: zenoh.Config) -> None:
    config.insert_json5("transport/link/rx/max_message_size", str(max_transport_message_bytes()))
    # No shared-memory transport: with it, every sender on the host puts payloads over 3 KB in a 16 MiB pool
    # that each receiving node maps (a stranger's pool in our address space, 16 MiB more RSS per sender);
    # our messages are small, and TCP on loopback is what the benches measure.
    config.insert_json5("transport/shared_memory/enabled", "false")


def _local_addresses_toward(endpoints: list[str]) -> list[str]:
    """This host's address on the route to each non-loopback TCP endpoint (a UDP ``connect`` sends nothing)."""
    found: list[str] = []
    for endpoint in endpoints:
        if not endpoint.startswith("tcp/"):
            continue
        host, _, port = endpoint[4:].split("#", 1)[0].rpartition(":")
        host = host.strip("[]")
        try:
            address = ipaddress.ip_address(socket.gethostbyname(host) if not _is_ip(host) else host)
            if address.is_loopback:
                continue
            family = socket.AF_INET6 if address.version == 6 else socket.AF_INET
            with socket.socket(family, socket.SOCK_DGRAM) as probe:
                probe.connect((str(address), int(port)))
                local = probe.getsockname()[0]
        except (OSError, ValueError):
            continue
        entry = f"tcp/[{local}]:0" if ":" in local else f"tcp/{local}:0"
        if entry not in found:
            found.append(entry)
    return found


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
        return True
    except ValueError:
        return False


def peer_config(connect: list[str] | None = None) -> zenoh.Config:
    """A peer session config that connects to ``connect`` (default: ``default_endpoints()``)."""
    config = _base_config()
    if os.environ.get(ENV_CONFIG) and connect is None:
        # The file decides everything else (mode, credentials, TLS, listeners): a deployment gives each node
        # its own file (its identity, e.g. docker-compose.secure.yml); ZENOH_CONNECT, when also set, names
        # the router, so one file serves every host.
        if os.environ.get(ENV_CONNECT, "").strip():
            config.insert_json5("connect/endpoints", json.dumps(default_endpoints()))
        return config
    endpoints = connect or default_endpoints()
    config.insert_json5("mode", json.dumps("peer"))
    config.insert_json5("connect/endpoints", json.dumps(endpoints))
    # Peers learn each other through the router (gossip) and connect directly. They listen on loopback,
    # and, when the router is on another host, on the one local address that faces it, so peers on other
    # hosts can reach them; never on every interface (zenoh's default).
    config.insert_json5("listen/endpoints", json.dumps(["tcp/127.0.0.1:0", *_local_addresses_toward(endpoints)]))
    # A link lost for longer than the lease (10 s) closes the session's transport; keep redialling the
    # router every second at most (zenoh's default backs off to 4 s) and never give up, so a node heals
    # within a second of the network returning.
    config.insert_json5("connect/exit_on_failure", "false")
    config.insert_json5("connect/retry", json.dumps(RECONNECT))
    return config


def router_config(port: int = DEFAULT_PORT, listen: list[str] | None = None, file: str | None = None) -> zenoh.Config:
    """A router config listening on loopback ``port`` (or the given endpoints).

    ``file``: a zenohd configuration (json5) to start from, e.g. one with ``access_control`` and
    ``transport/auth``; its listeners are kept unless ``listen`` is given."""
    config = zenoh.Config.from_file(file) if file else zenoh.Config()
    config.insert_json5("mode", json.dumps("router"))
    # Without a file's own listeners (zenoh's default is a per-mode map that means every interface): loopback.
    if listen or not listen_endpoints(config):
        config.insert_json5("listen/endpoints", json.dumps(listen or [loopback_endpoint(port)]))
    if not file:
        config.insert_json5("connect/endpoints", "[]")
    config.insert_json5("scouting/multicast/enabled", "false")
    if not file:  # a zenohd file keeps its own transport limits (as for nodes)
        _limit_message_size(config)
    return config


def insert_config_value(config: zenoh.Config, key: str, json5_value: str) -> None:
    config.insert_json5(key, json5_value)


def open_config(config: zenoh.Config) -> zenoh.Session:
    return zenoh.open(config)


def init_zenoh_log(default_level: str = "error") -> None:
    """Zenoh's own log lines on stderr, at ``RUST_LOG``'s level when set (as zenohd)."""
    zenoh.init_log_from_env_or(default_level)


def open_peer(connect: list[str] | None = None) -> zenoh.Session:
    return zenoh.open(peer_config(connect))


def open_router(port: int = DEFAULT_PORT, listen: list[str] | None = None, file: str | None = None) -> zenoh.Session:
    """Open an embedded router (what the launcher hosts); close it with ``.close()``."""
    return zenoh.open(router_config(port, listen, file))


def listen_endpoints(config: zenoh.Config) -> list[str]:
    """The endpoints a config lists explicitly ([] for zenoh's per-mode default)."""
    endpoints = json.loads(config.get_json("listen/endpoints") or "[]")
    return [str(e) for e in endpoints] if isinstance(endpoints, list) else []


def is_connected(session: zenoh.Session) -> bool:
    """True when the session reaches a router or another peer (a session with neither talks to nobody)."""
    return bool(list(session.info.routers_zid()) or list(session.info.peers_zid()))
