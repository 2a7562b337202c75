"""``zenroid bag``: record, play and info — rosbag2 bags (``ros2 bag`` and rosbags open ours, we open theirs)."""

from __future__ import annotations

import argparse
import datetime
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import msgs
from nodes.bag.qos import is_latched
from nodes.bag.reader import Bag, BagError, open_bag
from nodes.bag.writer import STORAGES, BagWriter
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common, cli_node, key_of


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("record", help="record keys into a rosbag2 bag (metadata.yaml + MCAP or sqlite3)")
    p.add_argument("keys", nargs="*", help="keys (wildcards allowed, e.g. 'humanoid/**')")
    p.add_argument("-a", "--all", action="store_true", help="record every key")
    p.add_argument("-o", "--output", default="", help="bag directory (or FILE.mcap); default rosbag2_<date>")
    p.add_argument("-s", "--storage", default="mcap", choices=sorted(STORAGES),
                   help="storage format, as ros2 bag record -s (default mcap)")
    p.add_argument("-d", "--duration", type=float, default=0.0, help="stop after S seconds")
    p.add_argument("--max-messages", type=int, default=0, help="stop after N messages")
    p.add_argument("--quiet", action="store_true", help="no live progress display")
    add_common(p)
    p = sub.add_parser("play", help="publish a bag's messages with their original timing")
    p.add_argument("bag", help="bag directory (rosbag2: metadata.yaml + .mcap/.db3) or .mcap/.db3 file")
    p.add_argument("-r", "--rate", type=float, default=1.0, help="playback speed factor")
    p.add_argument("-l", "--loop", action="store_true")
    p.add_argument("--topics", nargs="*", default=None, help="only these topics/keys")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_common(p)
    p = sub.add_parser("info", help="files, duration, message counts and types (like ros2 bag info)")
    p.add_argument("bag")


def run(args: argparse.Namespace) -> int:
    try:
        return {"record": _record, "play": _play, "info": _info}[args.cmd](args)
    except BagError as exc:
        raise UsageError(str(exc)) from None


def _stamp(ns: int) -> str:
    """``Nov 22 2026 10:00:00.123456789 (1795...123456789)`` as ros2 bag info prints times (local time)."""
    sec, frac = divmod(ns, 1_000_000_000)
    local = datetime.datetime.fromtimestamp(sec)
    return f"{local.strftime('%b %e %Y %H:%M:%S')}.{frac:09d} ({sec}.{frac:09d})"


def _size(n: int) -> str:
    size, unit = float(n), 0
    units = ("B", "KiB", "MiB", "GiB", "TiB")
    while size >= 1024 and unit < len(units) - 1:
        size, unit = size / 1024, unit + 1
    return f"{size:.0f} B" if unit == 0 else f"{size:.1f} {units[unit]}"


def _info(args: argparse.Namespace) -> int:
    with open_bag(args.bag) as bag:
        info = bag.info()
    sep = "\n" + " " * 19  # continuation lines line up under the first value, as in ros2 bag info
    print(f"Files:             {sep.join(info['files'])}")
    print(f"Bag size:          {_size(info['size_bytes'])}")
    print(f"Storage id:        {info['storage']}")
    print(f"ROS Distro:        {info['ros_distro'] or 'unknown'}")
    if info["compression"]:
        print(f"Compression:       {info['compression']}")
    duration_ns = info["end_ns"] - info["start_ns"]
    print(f"Duration:          {duration_ns // 1_000_000_000}.{duration_ns % 1_000_000_000:09d}s")
    print(f"Start:             {_stamp(info['start_ns'])}")
    print(f"End:               {_stamp(info['end_ns'])}")
    print(f"Messages:          {info['messages']}")
    lines = [f"Topic: {t['topic']} | Type: {t['type']} | Count: {t['count']} | Serialization Format: "
             f"{t['serialization']}" for t in info["topics"]]
    print(f"Topic information: {sep.join(lines)}")
    return 0


def _schema_type(sample: Any) -> str:
    text = str(sample.encoding)
    return text.split(";", 1)[1] if ";" in text else ""


def _record(args: argparse.Namespace) -> int:
    keys = ["**"] if args.all else [key_of(k) for k in args.keys]
    if not keys:
        raise UsageError("name keys to record, or -a for all")
    output = args.output or datetime.datetime.now().strftime("rosbag2_%Y_%m_%d-%H_%M_%S")
    node = cli_node(args, "bag_record")  # first: no router, no empty bag left behind
    try:
        writer = BagWriter(output, storage=args.storage)
    except FileExistsError:
        node.destroy()
        raise UsageError(f"output '{output}' already exists") from None
    except ValueError as exc:
        node.destroy()
        raise UsageError(str(exc)) from None
    except BaseException:
        node.destroy()
        raise
    done = threading.Event()
    skipped: dict[str, str] = {}
    arrived: queue.SimpleQueue[tuple[str, Any, int]] = queue.SimpleQueue()

    def on_sample(sample: Any) -> None:
        key = str(sample.key_expr)
        type_name = _schema_type(sample)
        try:
            msg = msgs.decode(msgs.get_type(type_name), sample.payload.to_bytes())
        except (KeyError, msgs.DecodeError, msgs.DefinitionError) as exc:
            skipped.setdefault(key, f"{type_name or 'no schema'}: {exc}")
            return
        if not done.is_set():
            arrived.put((key, msg, time.time_ns()))

    def store_arrived() -> None:
        """Write what arrived, from this thread: rosbags' sqlite3 storage is bound to the thread that opened it."""
        if _store(arrived, writer, skipped, args.max_messages):
            done.set()

    # SIGTERM (a launcher or `kill` stopping us) ends the recording cleanly, like Ctrl-C: the bag is
    # only complete (MCAP summary, metadata.yaml) once the writer is closed.
    previous = signal.signal(signal.SIGTERM, lambda *_: done.set())
    subs = [node.session.declare_subscriber(k, on_sample) for k in keys]
    print(f"Recording {', '.join('/' + k for k in keys)} to {writer.path} (Ctrl-C to stop)", flush=True)
    try:
        _wait_recording(args, writer, store_arrived, done)
    except KeyboardInterrupt:
        pass
    finally:
        done.set()
        for s in subs:
            s.undeclare()
        store_arrived()
        writer.close()
        node.destroy()
        signal.signal(signal.SIGTERM, previous)
    for key, reason in sorted(skipped.items()):
        print(f"  not recorded: /{key} ({reason})", file=sys.stderr)
    print(f"Recorded {writer.count} messages to {writer.path}")
    return 0


def _store(arrived: queue.SimpleQueue[tuple[str, Any, int]], writer: BagWriter, skipped: dict[str, str],
           max_messages: int) -> bool:
    """Write the messages queued at the call, no more: when topics arrive faster than the disk takes them,
    the caller still gets back to its duration and Ctrl-C checks. True once ``max_messages`` are written."""
    for _ in range(arrived.qsize()):
        if max_messages and writer.count >= max_messages:
            return True
        key, msg, stamp = arrived.get_nowait()
        if not writer.write(key, msg, stamp):
            skipped.setdefault(key, f"{msg._type} has no ROS 2 definition a bag can hold")
    return bool(max_messages and writer.count >= max_messages)


def _wait_recording(args: argparse.Namespace, writer: BagWriter, store_arrived: Callable[[], None],
                    done: threading.Event) -> None:
    """Until done, the duration or Ctrl-C, storing what arrived: a live table on a terminal, a line every
    2 s otherwise."""
    start = time.monotonic()
    if args.quiet or not sys.stdout.isatty():
        last_report = start
        while not done.wait(0.1):
            store_arrived()
            now = time.monotonic()
            if args.duration and now - start >= args.duration:
                return
            if not args.quiet and now - last_report >= 2.0:
                last_report = now
                print(f"  {writer.count} messages, {now - start:.0f} s", flush=True)
        return
    from rich.live import Live

    with Live(_progress_table(writer, 0.0, {}), refresh_per_second=4, transient=False) as live:
        rates: dict[str, tuple[float, int]] = {}
        while not done.wait(0.25):
            store_arrived()
            elapsed = time.monotonic() - start
            if args.duration and elapsed >= args.duration:
                break
            live.update(_progress_table(writer, elapsed, rates))
        live.update(_progress_table(writer, time.monotonic() - start, rates))


def _progress_table(writer: BagWriter, elapsed: float, rates: dict[str, tuple[float, int]]) -> Any:
    """Per topic: count and rate (over the last ~second); totals with size and elapsed time in the title."""
    from rich.table import Table

    counts = writer.topic_counts()
    total, size = writer.count, writer.bytes
    table = Table(title=f"{total} messages, {size / 1024:.1f} KiB payload, {elapsed:.1f} s", title_justify="left")
    table.add_column("topic")
    table.add_column("count", justify="right")
    table.add_column("Hz", justify="right")
    now = time.monotonic()
    for topic, count in sorted(counts.items()):
        t0, c0 = rates.get(topic, (now, count))
        hz = (count - c0) / (now - t0) if now - t0 > 0 else 0.0
        if now - t0 >= 1.0 or topic not in rates:
            rates[topic] = (now, count)
        table.add_row(topic, str(count), f"{hz:.1f}" if now - t0 > 0 else "")
    return table


def _play(args: argparse.Namespace) -> int:
    if not args.rate > 0:
        raise UsageError(f"--rate must be positive, got {args.rate}")
    bag = open_bag(args.bag)  # fails early, with a clear message, on a bad bag
    wanted = {"/" + k.strip("/") for k in args.topics} if args.topics is not None else None
    total = sum(t.count for t in bag.topics if wanted is None or t.name in wanted)
    node = cli_node(args, "bag_play")
    publishers: dict[str, Any] = {}
    try:
        time.sleep(0.5)  # let subscribers' routes form before the first message
        while True:
            played = _play_once(args, bag, node, publishers, total)
            if not args.loop or played == 0:
                break
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy()
        bag.close()
    return 0


def _report_unknown(topic: str, reason: str) -> None:
    print(f"  not played: {topic} ({reason})", file=sys.stderr, flush=True)


def _play_once(args: argparse.Namespace, bag: Bag, node: Any, publishers: dict[str, Any], total: int) -> int:
    from rich.progress import Progress

    played = 0
    wall_start = time.monotonic()
    bag_start: int | None = None
    with Progress(disable=args.quiet or not sys.stdout.isatty()) as progress:
        task = progress.add_task("playing", total=total)
        for item in bag.messages(args.topics, on_unknown=_report_unknown):
            if bag_start is None:
                bag_start = item.log_time_ns
            due = wall_start + (item.log_time_ns - bag_start) / 1e9 / args.rate
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            pub = publishers.get(item.key)
            if pub is None:
                pub = publishers[item.key] = node.create_publisher(
                    type(item.msg), "/" + item.key, latched=_latched(bag, "/" + item.key))
            pub.publish(item.msg)
            played += 1
            progress.update(task, advance=1)
    if args.quiet or not sys.stdout.isatty():
        print(f"Played {played} messages", flush=True)
    return played


def _latched(bag: Bag, topic: str) -> bool:
    """Transient-local topics (tf_static, robot_description) are republished latched, as ros2 bag play does."""
    info = bag.topic(topic)
    return info.latched if info else is_latched(topic)
