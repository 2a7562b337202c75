"""``zenroid topic``: list, echo, pub, hz, bw, info, type.

Nothing waits silently: a key nobody publishes gets "waiting for a publisher..." on stderr, a hint when the
name exists under a namespace (``/joint_states`` → ``humanoid/joint_states``), and exit status 1 after
``--wait`` seconds. A latched topic (``robot_description``) echoes its last message at once. A closed
pipe (``| head``) ends every streaming verb quietly.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import threading
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from typing import Any

import msgpack

import msgs
from nodes.core import graph
from nodes.core.delivery import parse_attachment
from nodes.core.latched import latest_sample
from nodes.core.names import check_key, keys_intersect
from nodes.tools.common import (
    add_list_verb,
    add_verb,
    cli_node,
    graph_entries,
    graph_until,
    is_cli_node,
    key_of,
    message_from_yaml,
    resolve_type,
    snapshot,
    snapshot_until,
    suggest,
    to_yaml,
    write_line,
)
from nodes.tools.errors import Failed, UsageError

PUBLISHER_WAIT = 5.0  # s echo/hz/bw wait for a publisher to exist before giving up (--wait)
_WAIT_FOR_PUBLISHER = ("--wait", {"type": float, "default": PUBLISHER_WAIT,
                                  "help": f"seconds to wait for a publisher to appear (default {PUBLISHER_WAIT:g}; "
                                          "0: forever)"})


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    add_list_verb(sub, "topics with publishers or subscribers")
    add_verb(sub, "echo", "print messages on a key (decoded by their schema)", "key",
             ("--once", {"action": "store_true", "help": "print one message and exit"}),
             ("-n", "--count", {"type": int, "default": 0, "help": "exit after N messages"}),
             ("--timeout", {"type": float, "default": 0.0,
                            "help": "give up after S seconds without a message (default: wait while a publisher "
                                    "exists)"}),
             _WAIT_FOR_PUBLISHER,
             ("--field", {"default": "", "help": "print only this field (dotted path, e.g. position or position.0)"}),
             ("--json", {"action": "store_true", "help": "one JSON object per line instead of YAML"}),
             ("--truncate-length", {"type": int, "default": TRUNCATE_LENGTH,
                                    "help": f"arrays and byte strings longer than this print their first N items "
                                            f"and a summary (default {TRUNCATE_LENGTH}; an image's pixels, a "
                                            "cloud's points)"}),
             ("--full-length", {"action": "store_true", "help": "print every item of every array"}))
    add_verb(sub, "pub", "publish a message given as YAML", "key", "type", ("values", {"nargs": "?", "default": "{}"}),
             ("--once", "-1", {"action": "store_true", "help": "publish once and exit"}),
             ("-r", "--rate", {"type": float, "default": 1.0, "help": "Hz (default 1)"}),
             ("-t", "--times", {"type": int, "default": 0, "help": "publish N times and exit"}),
             ("--wait", {"type": float, "default": 2.0,
                         "help": "seconds to wait for a subscriber before sending (default 2; sends as soon as one "
                                 "matches)"}))
    for name, help_text in (("hz", "publishing rate"), ("bw", "bandwidth")):
        add_verb(sub, name, help_text, "key",
                 ("--window", {"type": float, "default": 2.0, "help": "report every S seconds"}),
                 ("--duration", {"type": float, "default": 0.0, "help": "stop after S seconds (0: until Ctrl-C)"}),
                 _WAIT_FOR_PUBLISHER)
    add_verb(sub, "info", "type, publishers and subscribers of a topic", "key",
             ("-v", "--verbose", {"action": "store_true",
                                  "help": "each endpoint's node, type hash, GID and QoS profile (ros2 topic info -v)"}))
    add_verb(sub, "type", "the message type of a topic", "key")


def run(args: argparse.Namespace) -> int:
    key = key_of(args.key) if hasattr(args, "key") else ""
    if hasattr(args, "key"):
        try:
            check_key(key)
        except ValueError as exc:
            raise UsageError(f"invalid key '{args.key}': {exc}") from None
    return {"list": _list, "echo": _echo, "pub": _pub, "hz": _hz, "bw": _hz, "info": _info,
            "type": _type}[args.cmd](args)


def _topics(entries: list[graph.GraphEntry]) -> list[graph.GraphEntry]:
    return [e for e in entries if e.kind in ("pub", "sub")]


def _matches(key: str, name: str) -> bool:
    """Does the graph name ``name`` fall under ``key`` (which may hold wildcards)?"""
    if key == name:
        return True
    if "*" not in key and "$" not in key:
        return False
    return keys_intersect(key, name)


def _hint(key: str, entries: list[graph.GraphEntry], kinds: tuple[str, ...] = ("pub", "sub")) -> str:
    return suggest(key, [e.name for e in entries if e.kind in kinds and not is_cli_node(e.node)])


def _list(args: argparse.Namespace) -> int:
    entries = graph_entries(args, "topic")
    topics: dict[str, str] = {}
    for e in _topics(entries):
        if e.name not in topics or topics[e.name] == "*":
            topics[e.name] = e.type_name
    for name in sorted(topics):
        write_line(f"/{name} [{topics[name]}]" if args.show_types else f"/{name}")
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
        except (KeyError, msgs.DecodeError, msgs.DefinitionError):
            pass
    try:
        return type_name or "?", msgpack.unpackb(payload, raw=False)
    except Exception:  # noqa: BLE001 - not msgpack: show bytes
        return type_name or "?", payload


TRUNCATE_LENGTH = 128


def _truncated(data: Any, limit: int) -> Any:
    """``data`` with every array over ``limit`` items cut to its first ``limit`` and a summary, as ros2 topic
    echo's --truncate-length does (bytes: a summary only: an image's pixels are no reading matter)."""
    if isinstance(data, dict):
        return {key: _truncated(value, limit) for key, value in data.items()}
    if isinstance(data, (bytes, bytearray)):
        if len(data) <= limit:
            return list(data)
        return f"<{len(data)} bytes: {bytes(data[:16]).hex(' ')} ...>"
    if isinstance(data, list):
        if len(data) <= limit:
            return [_truncated(item, limit) for item in data]
        return [_truncated(item, limit) for item in data[:limit]] + [f"... {len(data) - limit} more"]
    return data


def _pick(data: Any, path: str) -> Any:
    for part in path.split("."):
        if isinstance(data, dict) and part in data:
            data = data[part]
        elif isinstance(data, list) and part.isdigit() and int(part) < len(data):
            data = data[int(part)]
        else:
            raise UsageError(f"field '{path}' not found (at '{part}')")
    return data


class _Waiter:
    """Says what a streaming verb is waiting for and decides when to give up on a key nobody publishes."""

    def __init__(self, node: Any, key: str, verb: str, wait: float) -> None:
        self.node, self.key, self.verb, self.wait = node, key, verb, wait
        self.start = time.monotonic()
        self.entries = snapshot_until(node, lambda es: bool(self._publishers(es)), timeout=1.0)
        self.publishers = self._publishers()
        self.announced = False
        self.last_check = self.start

    def _publishers(self, entries: list[graph.GraphEntry] | None = None) -> list[str]:
        return sorted({e.node for e in (self.entries if entries is None else entries)
                       if e.kind == "pub" and _matches(self.key, e.name)})

    def hint(self) -> str:
        return _hint(self.key, self.entries, ("pub",))

    def announce(self) -> None:
        if not self.publishers and not self.announced:
            self.announced = True
            limit = f"up to {self.wait:g} s" if self.wait > 0 else "until Ctrl-C"
            print(f"zenroid topic {self.verb}: no publisher on '{self.key}' yet{self.hint()}\n"
                  f"waiting for a publisher on '{self.key}' ({limit}; --wait S to change)...",
                  file=sys.stderr, flush=True)

    def give_up(self, received: int) -> bool:
        """Call every ~0.1 s: True once nobody has published within ``wait`` s (re-reads the graph each s)."""
        if received or self.publishers or self.wait <= 0:
            return False
        now = time.monotonic()
        if now - self.last_check >= 1.0:
            self.last_check = now
            self.entries = snapshot(self.node)
            self.publishers = self._publishers()
            if self.publishers:
                return False
        if now - self.start < self.wait:
            return False
        raise Failed(f"no publisher on '{self.key}' within {self.wait:g} s{self.hint()}")

    def latched_source(self) -> bool:
        """A latched topic answers a get on its key; services are queryables too, so only ask when the key is
        a published topic and no service of that name exists (a get must never call a service)."""
        if "*" in self.key or "$" in self.key or not self.publishers:
            return False
        return not any(e.kind == "srv" and e.name == self.key for e in self.entries)


@contextlib.contextmanager
def _listening(args: argparse.Namespace, verb: str, on_sample: Callable[[Any], None]) -> Iterator[_Waiter]:
    """A CLI node subscribed to ``args.key`` for the block (Ctrl-C ends the block quietly); the waiter says
    what it waits for and gives up on a key nobody publishes."""
    node = cli_node(args, verb)
    try:
        waiter = _Waiter(node, key_of(args.key), verb, args.wait)
        sub = node.session.declare_subscriber(waiter.key, on_sample)
        try:
            waiter.announce()
            yield waiter
        except KeyboardInterrupt:
            pass
        finally:
            sub.undeclare()
    finally:
        node.destroy()


def _echo(args: argparse.Namespace) -> int:
    import json

    key = key_of(args.key)
    limit = 1 if args.once else args.count
    done = threading.Event()
    count = 0
    lock = threading.Lock()
    problems: list[BaseException] = []

    def show(sample: Any) -> None:
        nonlocal count
        with lock:
            if done.is_set():
                return
            _, data = _decode_any(sample)
            try:
                if args.field:
                    data = _pick(data, args.field)
                if not args.full_length:
                    data = _truncated(data, max(0, args.truncate_length))
                if args.json:
                    write_line(json.dumps(data, default=lambda b: list(b)))
                elif args.field and isinstance(data, str):
                    write_line(data + "\n---")  # a text field as itself (no YAML quoting)
                else:
                    write_line(to_yaml(data) + "\n---")
            except (UsageError, BrokenPipeError) as exc:  # a Zenoh thread: hand it to the main thread
                problems.append(exc)
                done.set()
                return
            count += 1
            if limit and count >= limit:
                done.set()

    with _listening(args, "echo", show) as waiter:
        # A latched topic is asked for its last message for a few seconds (a fresh session may not
        # know the queryable's route yet: an unanswered get is repeated, as fetch_latched does).
        latched_until: float | None = None
        last_count, last_change, quiet_noted = 0, time.monotonic(), False
        while not done.is_set():
            if not count and waiter.latched_source():
                latched_until = latched_until or time.monotonic() + 3.0
                if time.monotonic() < latched_until:
                    sample = latest_sample(waiter.node.session, key, timeout=1.0)
                    if sample is not None:
                        show(sample)
            if done.wait(0.1):
                break
            waiter.give_up(count)
            now = time.monotonic()
            if count != last_count:
                last_count, last_change = count, now
            elif args.timeout and now - last_change > args.timeout:
                raise Failed(f"no message on '{key}' within {args.timeout:g} s")
            elif waiter.publishers and not count and not quiet_noted and now - last_change > 3.0:
                quiet_noted = True
                print(f"zenroid topic echo: no message on '{key}' yet from {', '.join(waiter.publishers)}; "
                      "waiting (Ctrl-C to stop, --timeout S to give up)", file=sys.stderr, flush=True)
    if problems:
        raise problems[0]
    return 0


def _wait_for_subscriber(node: Any, pub: Any, key: str, wait: float) -> bool:
    """True once someone subscribes to ``key`` (Zenoh matching, which also sees non-zenroid subscribers)."""
    deadline = time.monotonic() + max(0.0, wait)
    while True:
        if pub.has_subscribers:
            time.sleep(0.05)  # the route is known; give the subscriber's side a moment to settle
            return True
        if time.monotonic() >= deadline:
            return any(e.kind == "sub" and _matches(e.name, key) for e in snapshot(node))
        time.sleep(0.02)


def _pub(args: argparse.Namespace) -> int:
    cls = resolve_type(args.type)
    if not hasattr(cls, "_type") or "/msg/" not in cls._type:
        raise UsageError(f"'{args.type}' is not a message type")
    msg = message_from_yaml(cls, args.values)
    if not args.rate > 0 or not math.isfinite(args.rate):
        raise UsageError(f"--rate must be a positive number, got {args.rate}")
    key = key_of(args.key)
    times = 1 if args.once else args.times
    node = cli_node(args, "pub")
    heard = True
    try:
        pub = node.create_publisher(cls, "/" + key)
        heard = _wait_for_subscriber(node, pub, key, args.wait)
        if not heard:
            hint = _hint(key, snapshot(node), ("sub",))
            print(f"zenroid topic pub: nobody subscribes to '{key}'{hint}", file=sys.stderr, flush=True)
        sent = 0
        write_line(f"publishing #{sent + 1} on /{key}: {cls._type}")
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
    if times and not heard:
        raise Failed(f"published {times} message(s) on '{key}' but nobody subscribes to it")
    return 0


def _hz(args: argparse.Namespace) -> int:
    if not args.window > 0:
        raise UsageError(f"--window must be positive, got {args.window}")
    stamps: list[float] = []
    sizes: list[int] = []
    last_seq: dict[bytes, int] = {}
    lost: defaultdict[bytes, int] = defaultdict(int)
    lock = threading.Lock()

    def on_sample(sample: Any) -> None:
        now = time.monotonic()
        att = parse_attachment(sample)
        with lock:
            stamps.append(now)
            sizes.append(len(sample.payload.to_bytes()))
            if len(stamps) > 200_000:  # bounded memory on a fast topic left running for hours
                del stamps[:100_000], sizes[:100_000]
            if att:
                seq, src = att
                prev = last_seq.get(src)
                if prev is not None and seq > prev + 1:
                    lost[src] += seq - prev - 1
                last_seq[src] = seq

    with _listening(args, args.cmd, on_sample) as waiter:
        start = time.monotonic()
        next_report = start + min(args.window, args.duration or args.window)
        while not args.duration or time.monotonic() - start < args.duration:
            time.sleep(0.1)
            with lock:
                received = len(stamps)
            waiter.give_up(received)
            if time.monotonic() < next_report:
                continue
            next_report += args.window
            with lock:
                window = [t for t in stamps if t >= time.monotonic() - args.window]
                nbytes = sum(sizes[-len(window):]) if window else 0
                total_lost = sum(lost.values())
            if len(window) < 2:
                write_line("no new messages")
                continue
            span = window[-1] - window[0]
            rate = (len(window) - 1) / span if span > 0 else float("inf")
            if args.cmd == "hz":
                gaps = [b - a for a, b in zip(window, window[1:])]
                write_line(f"average rate: {rate:.3f}\n\tmin: {min(gaps):.4f}s max: {max(gaps):.4f}s "
                           f"window: {len(window)} lost: {total_lost}")
            else:
                write_line(f"{nbytes / args.window / 1024:.2f} KB/s from {len(window)} messages "
                           f"(mean {nbytes / len(window):.0f} B)")
    return 0


def _graph_with_topic(args: argparse.Namespace) -> tuple[str, list[graph.GraphEntry]]:
    """The topic's key and the graph, waited for until some publisher or subscriber of it shows."""
    key = key_of(args.key)
    return key, graph_until(args, "topic", lambda es: any(e.name == key for e in _topics(es)))


def _info(args: argparse.Namespace) -> int:
    key, everything = _graph_with_topic(args)
    entries = [e for e in _topics(everything) if e.name == key]
    if not entries:
        raise Failed(f"no publisher or subscriber on '{key}'{_hint(key, everything)}")
    types = sorted({e.type_name for e in entries if e.type_name != "*"})
    if getattr(args, "verbose", False):
        return _info_verbose(args, key, types)
    pubs = sorted(e.node for e in entries if e.kind == "pub")
    subs = sorted(e.node for e in entries if e.kind == "sub")
    write_line(f"Type: {', '.join(types) or '(any: raw subscribers only)'}")
    write_line(f"Publisher count: {len(pubs)}")
    for n in pubs:
        write_line(f"  {n}")
    write_line(f"Subscription count: {len(subs)}")
    for n in subs:
        write_line(f"  {n}")
    return 0


def _info_verbose(args: argparse.Namespace, key: str, types: list[str]) -> int:
    """``ros2 topic info -v``'s layout: each endpoint with its node, type hash, GID and QoS profile, from the
    ROS 2 wire's tokens (real ROS 2 nodes' too) and our graph."""
    from nodes.core import ros2
    from nodes.core.ros2.endpoint_info import endpoints_of

    try:
        domain = ros2.domain_id() if ros2.enabled() else None
    except ValueError as exc:
        raise Failed(str(exc)) from None
    node = cli_node(args, "topic_info")
    try:
        found = {kind: endpoints_of(node.session, key, kind == "pub", domain=domain) for kind in ("pub", "sub")}
    finally:
        node.destroy()
    write_line(f"Type: {', '.join(types) or '(any: raw subscribers only)'}\n")
    for kind, title in (("pub", "Publisher"), ("sub", "Subscription")):
        write_line(f"{title} count: {len(found[kind])}\n")
        for info in found[kind]:
            write_line(_endpoint_text(info) + "\n")
    return 0


def _endpoint_text(info: Any) -> str:
    def duration(ns: int) -> str:
        return f"{ns} nanoseconds" if ns > 0 else "Infinite"

    qos = info.qos
    lines = [f"Node name: {info.node}", f"Node namespace: {info.namespace}", f"Topic type: {info.type_name}",
             f"Topic type hash: {info.type_hash or 'INVALID'}",
             f"Endpoint type: {'PUBLISHER' if info.kind == 'MP' else 'SUBSCRIPTION'}",
             f"GID: {'.'.join(format(b, '02x') for b in info.gid)}", "QoS profile:"]
    if qos is None:   # only our graph knows it (off the ROS 2 wire)
        return "\n".join([*lines, *(f"  {name}: UNKNOWN" for name in (
            "Reliability", "History (Depth)", "Durability", "Lifespan", "Deadline", "Liveliness",
            "Liveliness lease duration"))])
    return "\n".join([
        *lines,
        f"  Reliability: {'RELIABLE' if qos.reliable else 'BEST_EFFORT'}",
        f"  History (Depth): {'KEEP_ALL' if qos.keep_all else f'KEEP_LAST ({qos.depth})'}",
        f"  Durability: {'TRANSIENT_LOCAL' if qos.transient_local else 'VOLATILE'}",
        f"  Lifespan: {duration(qos.lifespan_ns)}",
        f"  Deadline: {duration(qos.deadline_ns)}",
        f"  Liveliness: {'MANUAL_BY_TOPIC' if qos.liveliness == 3 else 'AUTOMATIC'}",
        f"  Liveliness lease duration: {duration(qos.lease_ns)}",
    ])


def _type(args: argparse.Namespace) -> int:
    key, everything = _graph_with_topic(args)
    types = sorted({e.type_name for e in _topics(everything) if e.name == key and e.type_name != "*"})
    if not types:
        raise Failed(f"no publisher or subscriber on '{key}'{_hint(key, everything)}")
    write_line("\n".join(types))
    return 0
