"""``zenroid topic``: list, echo, pub, hz, bw, info, type."""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from collections import defaultdict
from typing import Any

import msgpack

import msgs
from nodes.core import graph
from nodes.core.endpoints import parse_attachment
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common, cli_node, key_of, message_from_yaml, resolve_type, to_yaml


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list", help="topics with publishers or subscribers")
    p.add_argument("-t", "--show-types", action="store_true")
    add_common(p)
    p = sub.add_parser("echo", help="print messages on a key (decoded by their schema)")
    p.add_argument("key")
    p.add_argument("--once", action="store_true", help="print one message and exit")
    p.add_argument("-n", "--count", type=int, default=0, help="exit after N messages")
    p.add_argument("--timeout", type=float, default=0.0, help="give up after S seconds without a message")
    p.add_argument("--field", default="", help="print only this field (dotted path)")
    p.add_argument("--json", action="store_true", help="one JSON object per line instead of YAML")
    add_common(p)
    p = sub.add_parser("pub", help="publish a message given as YAML")
    p.add_argument("key")
    p.add_argument("type")
    p.add_argument("values", nargs="?", default="{}")
    p.add_argument("--once", "-1", action="store_true", help="publish once and exit")
    p.add_argument("-r", "--rate", type=float, default=1.0, help="Hz (default 1)")
    p.add_argument("-t", "--times", type=int, default=0, help="publish N times and exit")
    p.add_argument("--wait", type=float, default=0.5, help="seconds to wait for subscribers before sending")
    add_common(p)
    for name, help_text in (("hz", "publishing rate"), ("bw", "bandwidth")):
        p = sub.add_parser(name, help=help_text)
        p.add_argument("key")
        p.add_argument("--window", type=float, default=2.0, help="report every S seconds")
        p.add_argument("--duration", type=float, default=0.0, help="stop after S seconds (0: until Ctrl-C)")
        add_common(p)
    p = sub.add_parser("info", help="type, publishers and subscribers of a topic")
    p.add_argument("key")
    add_common(p)
    p = sub.add_parser("type", help="the message type of a topic")
    p.add_argument("key")
    add_common(p)


def run(args: argparse.Namespace) -> int:
    return {"list": _list, "echo": _echo, "pub": _pub, "hz": _hz, "bw": _hz, "info": _info, "type": _type}[args.cmd](args)


def _endpoints(node: Any) -> list[graph.GraphEntry]:
    return [e for e in graph.snapshot(node.session) if e.kind in ("pub", "sub")]


def _list(args: argparse.Namespace) -> int:
    node = cli_node(args, "topic")
    try:
        topics: dict[str, str] = {}
        for e in _endpoints(node):
            if e.name not in topics or topics[e.name] == "*":
                topics[e.name] = e.type_name
        for name in sorted(topics):
            print(f"/{name} [{topics[name]}]" if args.show_types else f"/{name}")
    finally:
        node.destroy()
    return 0


def _schema(sample: Any) -> str:
    schema = sample.encoding.schema if hasattr(sample.encoding, "schema") else None
    if schema:
        return str(schema)
    text = str(sample.encoding)
    return text.split(";", 1)[1] if ";" in text else ""


def _decode_any(sample: Any) -> tuple[str, Any]:
    """(type name, plain data) of a sample: validated by its schema when the type is known."""
    payload = sample.payload.to_bytes()
    type_name = _schema(sample)
    if type_name:
        try:
            return type_name, msgs.to_dict(msgs.decode(msgs.get_type(type_name), payload))
        except (KeyError, msgs.DecodeError):
            pass
    try:
        return type_name or "?", msgpack.unpackb(payload, raw=False)
    except Exception:  # noqa: BLE001 - not msgpack: show bytes
        return type_name or "?", payload


def _pick(data: Any, path: str) -> Any:
    for part in path.split("."):
        if isinstance(data, dict) and part in data:
            data = data[part]
        elif isinstance(data, list) and part.isdigit() and int(part) < len(data):
            data = data[int(part)]
        else:
            raise UsageError(f"field '{path}' not found (at '{part}')")
    return data


def _echo(args: argparse.Namespace) -> int:
    import json

    node = cli_node(args, "echo")
    limit = 1 if args.once else args.count
    done = threading.Event()
    count = 0
    lock = threading.Lock()
    errors: list[str] = []

    def on_sample(sample: Any) -> None:
        nonlocal count
        with lock:
            if done.is_set():
                return
            _, data = _decode_any(sample)
            try:
                if args.field:
                    data = _pick(data, args.field)
            except UsageError as exc:
                errors.append(str(exc))
                done.set()
                return
            if args.json:
                print(json.dumps(data, default=lambda b: list(b)), flush=True)
            else:
                print(to_yaml(data) + "\n---", flush=True)
            count += 1
            if limit and count >= limit:
                done.set()

    sub = node.session.declare_subscriber(key_of(args.key), on_sample)
    try:
        last_count, last_change = 0, time.monotonic()
        while not done.wait(0.05):
            if args.timeout:
                if count != last_count:
                    last_count, last_change = count, time.monotonic()
                elif time.monotonic() - last_change > args.timeout:
                    print(f"zenroid topic echo: no message on '{key_of(args.key)}' within {args.timeout:g} s",
                          file=sys.stderr)
                    return 1
    except KeyboardInterrupt:
        pass
    finally:
        sub.undeclare()
        node.destroy()
    if errors:
        raise UsageError(errors[0])
    return 0


def _pub(args: argparse.Namespace) -> int:
    cls = resolve_type(args.type)
    if not hasattr(cls, "_type") or "/msg/" not in cls._type:
        raise UsageError(f"'{args.type}' is not a message type")
    msg = message_from_yaml(cls, args.values)
    if not args.rate > 0 or not math.isfinite(args.rate):
        raise UsageError(f"--rate must be a positive number, got {args.rate}")
    node = cli_node(args, "pub")
    try:
        pub = node.create_publisher(cls, "/" + key_of(args.key))
        time.sleep(max(0.0, args.wait))  # let subscribers' routes form, as `ros2 topic pub` waits for matching
        times = 1 if args.once else args.times
        sent = 0
        print(f"publishing #{sent + 1} on /{key_of(args.key)}: {cls._type}", flush=True)
        while True:
            pub.publish(msg)
            sent += 1
            if times and sent >= times:
                break
            time.sleep(1.0 / args.rate)
        time.sleep(0.1)  # let the last message leave before the session closes
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy()
    return 0


def _hz(args: argparse.Namespace) -> int:
    node = cli_node(args, args.cmd)
    stamps: list[float] = []
    sizes: list[int] = []
    last_seq: dict[bytes, int] = {}
    lost = defaultdict(int)
    lock = threading.Lock()

    def on_sample(sample: Any) -> None:
        now = time.monotonic()
        att = parse_attachment(sample)
        with lock:
            stamps.append(now)
            sizes.append(len(sample.payload.to_bytes()))
            if att:
                seq, src = att
                prev = last_seq.get(src)
                if prev is not None and seq > prev + 1:
                    lost[src] += seq - prev - 1
                last_seq[src] = seq

    sub = node.session.declare_subscriber(key_of(args.key), on_sample)
    start = time.monotonic()
    try:
        while not args.duration or time.monotonic() - start < args.duration:
            time.sleep(min(args.window, args.duration or args.window))
            with lock:
                window = [t for t in stamps if t >= time.monotonic() - args.window]
                nbytes = sum(sizes[-len(window):]) if window else 0
                total_lost = sum(lost.values())
            if len(window) < 2:
                print("no new messages", flush=True)
                continue
            span = window[-1] - window[0]
            rate = (len(window) - 1) / span if span > 0 else float("inf")
            if args.cmd == "hz":
                gaps = [b - a for a, b in zip(window, window[1:])]
                print(f"average rate: {rate:.3f}\n\tmin: {min(gaps):.4f}s max: {max(gaps):.4f}s "
                      f"window: {len(window)} lost: {total_lost}", flush=True)
            else:
                print(f"{nbytes / args.window / 1024:.2f} KB/s from {len(window)} messages "
                      f"(mean {nbytes / len(window):.0f} B)", flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        sub.undeclare()
        node.destroy()
    return 0


def _info(args: argparse.Namespace) -> int:
    node = cli_node(args, "topic")
    key = key_of(args.key)
    try:
        entries = [e for e in _endpoints(node) if e.name == key]
    finally:
        node.destroy()
    types = sorted({e.type_name for e in entries if e.type_name != "*"})
    pubs = sorted(e.node for e in entries if e.kind == "pub")
    subs = sorted(e.node for e in entries if e.kind == "sub")
    print(f"Type: {', '.join(types) or 'unknown'}")
    print(f"Publisher count: {len(pubs)}")
    for n in pubs:
        print(f"  {n}")
    print(f"Subscription count: {len(subs)}")
    for n in subs:
        print(f"  {n}")
    return 0


def _type(args: argparse.Namespace) -> int:
    node = cli_node(args, "topic")
    key = key_of(args.key)
    try:
        types = sorted({e.type_name for e in _endpoints(node) if e.name == key and e.type_name != "*"})
    finally:
        node.destroy()
    if not types:
        print(f"zenroid topic type: no publisher or subscriber on '/{key}'", file=sys.stderr)
        return 1
    print("\n".join(types))
    return 0
