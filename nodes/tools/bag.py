"""``zenroid bag``: record, play and info — MCAP bags with ROS 2 encoding (``ros2 bag`` compatible)."""

from __future__ import annotations

import argparse
import datetime
import sys
import threading
import time
from typing import Any

import msgs
from nodes.bag.mcap_file import BagError, BagWriter, bag_info, read_bag
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common, cli_node, key_of


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("record", help="record keys into an MCAP bag")
    p.add_argument("keys", nargs="*", help="keys (wildcards allowed, e.g. 'humanoid/**')")
    p.add_argument("-a", "--all", action="store_true", help="record every key")
    p.add_argument("-o", "--output", default="", help="bag directory (or FILE.mcap); default rosbag2_<date>")
    p.add_argument("-d", "--duration", type=float, default=0.0, help="stop after S seconds")
    p.add_argument("--max-messages", type=int, default=0, help="stop after N messages")
    add_common(p)
    p = sub.add_parser("play", help="publish a bag's messages with their original timing")
    p.add_argument("bag")
    p.add_argument("-r", "--rate", type=float, default=1.0, help="playback speed factor")
    p.add_argument("-l", "--loop", action="store_true")
    p.add_argument("--topics", nargs="*", default=None, help="only these keys")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_common(p)
    p = sub.add_parser("info", help="duration, message counts and types")
    p.add_argument("bag")


def run(args: argparse.Namespace) -> int:
    try:
        return {"record": _record, "play": _play, "info": _info}[args.cmd](args)
    except BagError as exc:
        raise UsageError(str(exc)) from None


def _info(args: argparse.Namespace) -> int:
    info = bag_info(args.bag)
    start = datetime.datetime.fromtimestamp(info["start_ns"] / 1e9) if info["messages"] else None
    print(f"Files:             {info['path']}")
    print(f"Bag size:          {info['size_bytes'] / 1024:.1f} KiB")
    print("Storage id:        mcap")
    print(f"Duration:          {info['duration_s']:.3f}s")
    print(f"Start:             {start}")
    print(f"Messages:          {info['messages']}")
    print("Topic information:")
    for t in info["topics"]:
        print(f"  Topic: {t['topic']} | Type: {t['type']} | Count: {t['count']} | Serialization Format: "
              f"{t['serialization']}")
    return 0


def _schema_type(sample: Any) -> str:
    text = str(sample.encoding)
    return text.split(";", 1)[1] if ";" in text else ""


def _record(args: argparse.Namespace) -> int:
    keys = ["**"] if args.all else [key_of(k) for k in args.keys]
    if not keys:
        raise UsageError("name keys to record, or -a for all")
    output = args.output or datetime.datetime.now().strftime("rosbag2_%Y_%m_%d-%H_%M_%S")
    try:
        writer = BagWriter(output)
    except FileExistsError:
        raise UsageError(f"output '{output}' already exists") from None
    node = cli_node(args, "bag_record")
    lock = threading.Lock()
    done = threading.Event()
    skipped: dict[str, str] = {}

    def on_sample(sample: Any) -> None:
        key = str(sample.key_expr)
        type_name = _schema_type(sample)
        try:
            msg = msgs.decode(msgs.get_type(type_name), sample.payload.to_bytes())
        except (KeyError, msgs.DecodeError, msgs.DefinitionError) as exc:
            skipped.setdefault(key, f"{type_name or 'no schema'}: {exc}")
            return
        with lock:
            if done.is_set():
                return
            if not writer.write(key, msg, time.time_ns()):
                skipped.setdefault(key, f"{type_name} has no ROS 2 schema name")
            if args.max_messages and writer.count >= args.max_messages:
                done.set()

    subs = [node.session.declare_subscriber(k, on_sample) for k in keys]
    print(f"Recording {', '.join('/' + k for k in keys)} to {writer.path} (Ctrl-C to stop)", flush=True)
    start = time.monotonic()
    last_report = start
    try:
        while not done.wait(0.1):
            now = time.monotonic()
            if args.duration and now - start >= args.duration:
                break
            if now - last_report >= 2.0:
                last_report = now
                print(f"  {writer.count} messages, {now - start:.0f} s", flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        done.set()
        for s in subs:
            s.undeclare()
        with lock:
            writer.close()
        node.destroy()
    for key, reason in sorted(skipped.items()):
        print(f"  not recorded: /{key} ({reason})", file=sys.stderr)
    print(f"Recorded {writer.count} messages to {writer.path}")
    return 0


def _play(args: argparse.Namespace) -> int:
    if not args.rate > 0:
        raise UsageError(f"--rate must be positive, got {args.rate}")
    info = bag_info(args.bag)  # fails early, with a clear message, on a bad bag
    total = sum(t["count"] for t in info["topics"]
                if args.topics is None or t["topic"].lstrip("/") in {k.strip("/") for k in args.topics})
    node = cli_node(args, "bag_play")
    publishers: dict[str, Any] = {}
    try:
        time.sleep(0.5)  # let subscribers' routes form before the first message
        while True:
            played = _play_once(args, node, publishers, total)
            if not args.loop or played == 0:
                break
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy()
    return 0


def _play_once(args: argparse.Namespace, node: Any, publishers: dict[str, Any], total: int) -> int:
    from rich.progress import Progress

    played = 0
    wall_start = time.monotonic()
    bag_start: int | None = None
    with Progress(disable=args.quiet or not sys.stdout.isatty()) as progress:
        task = progress.add_task("playing", total=total)
        for item in read_bag(args.bag, args.topics):
            if bag_start is None:
                bag_start = item.log_time_ns
            due = wall_start + (item.log_time_ns - bag_start) / 1e9 / args.rate
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            pub = publishers.get(item.key)
            if pub is None:
                pub = publishers[item.key] = node.create_publisher(type(item.msg), "/" + item.key)
            pub.publish(item.msg)
            played += 1
            progress.update(task, advance=1)
    if args.quiet or not sys.stdout.isatty():
        print(f"Played {played} messages", flush=True)
    return played
