"""Reading and writing MCAP bags of zenroid messages (no Zenoh here: the CLI verb does the transport).

Messages are stored CDR-encoded with ``ros2msg`` schemas, exactly as ``ros2 bag record -s mcap`` writes
them, so a bag converts losslessly in both directions. Topics are the Zenoh keys with a leading ``/``.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer

import msgs
from msgs.idl import FieldSpec
from msgs.registry import get_spec
from msgs.schema_text import full_definition


class BagError(Exception):
    """A bag that cannot be opened, written or understood; the message says which and why."""


def resolve_bag_path(path: str | Path) -> Path:
    """A bag is an ``.mcap`` file or a ros2-bag-style directory holding one."""
    p = Path(path)
    if p.is_dir():
        files = sorted(p.glob("*.mcap"))
        if not files:
            raise BagError(f"no .mcap file in directory {p}")
        return files[0]
    if not p.is_file():
        raise BagError(f"no bag at {p}")
    return p


class BagWriter:
    def __init__(self, path: str | Path) -> None:
        p = Path(path)
        if p.suffix != ".mcap":
            p.mkdir(parents=True, exist_ok=False)
            p = p / f"{p.name}_0.mcap"
        self.path = p
        self._file = open(p, "wb")
        self._writer = Writer(self._file)
        self._schemas: dict[str, Any] = {}
        self.count = 0
        self.unrecordable: set[str] = set()

    def write(self, key: str, msg: Any, log_time_ns: int | None = None) -> bool:
        """Store ``msg`` under topic ``/key``; False (and remembered) if its type has no ROS schema."""
        type_name = msg._type
        schema = self._schemas.get(type_name)
        if schema is None:
            if type_name in self.unrecordable:
                return False
            try:
                schema = self._writer.register_msgdef(type_name, full_definition(type_name))
                self._schemas[type_name] = schema
            except Exception:  # noqa: BLE001 - a type ROS tools cannot name (action wrappers)
                self.unrecordable.add(type_name)
                return False
        t = log_time_ns if log_time_ns is not None else time.time_ns()
        try:
            self._writer.write_message("/" + key.lstrip("/"), schema, msg, log_time=t, publish_time=t)
        except Exception:  # noqa: BLE001
            self.unrecordable.add(type_name)
            return False
        self.count += 1
        return True

    def close(self) -> None:
        self._writer.finish()
        self._file.close()


@dataclass
class BagMessage:
    key: str
    type_name: str
    msg: Any
    log_time_ns: int


def _to_plain(spec_type: str, ros_msg: Any) -> dict[str, Any]:
    """The decoder's dynamic object → a plain map following our own definition of the type."""
    out: dict[str, Any] = {}
    for f in get_spec(spec_type).fields:
        value = getattr(ros_msg, f.name)
        out[f.name] = _plain_field(f, value)
    return out


def _plain_field(f: FieldSpec, value: Any) -> Any:
    if f.is_bytes:
        return bytes(value)
    if f.is_primitive:
        return list(value) if f.is_array else value
    if f.is_array:
        return [_to_plain(f.base, v) for v in value]
    return _to_plain(f.base, value)


def read_bag(path: str | Path, keys: list[str] | None = None) -> Iterator[BagMessage]:
    """Messages in log-time order, decoded and validated into zenroid message classes."""
    bag = resolve_bag_path(path)
    wanted = {"/" + k.strip("/") for k in keys} if keys else None
    with open(bag, "rb") as f:
        try:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for schema, channel, message, ros_msg in reader.iter_decoded_messages(
                    topics=sorted(wanted) if wanted else None, log_time_order=True):
                type_name = schema.name if "/msg/" in schema.name else _with_kind(schema.name)
                cls = msgs.get_type(type_name)
                yield BagMessage(channel.topic.lstrip("/"), type_name,
                                 msgs.from_dict(cls, _to_plain(type_name, ros_msg)), message.log_time)
        except (msgs.DecodeError, KeyError) as exc:
            raise BagError(f"{bag}: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - mcap raises many kinds on corrupt files
            raise BagError(f"{bag}: not a readable MCAP bag ({type(exc).__name__}: {exc})") from None


def _with_kind(name: str) -> str:
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


def bag_info(path: str | Path) -> dict[str, Any]:
    bag = resolve_bag_path(path)
    with open(bag, "rb") as f:
        try:
            summary = make_reader(f).get_summary()
        except Exception as exc:  # noqa: BLE001
            raise BagError(f"{bag}: not a readable MCAP bag ({type(exc).__name__}: {exc})") from None
    if summary is None or summary.statistics is None:
        raise BagError(f"{bag}: no summary section (was the recording interrupted?)")
    stats = summary.statistics
    topics = []
    for cid, channel in sorted(summary.channels.items(), key=lambda kv: kv[1].topic):
        schema = summary.schemas.get(channel.schema_id)
        topics.append({"topic": channel.topic, "type": schema.name if schema else "?",
                       "count": stats.channel_message_counts.get(cid, 0), "serialization": channel.message_encoding})
    return {"path": str(bag), "size_bytes": bag.stat().st_size, "messages": stats.message_count,
            "start_ns": stats.message_start_time, "end_ns": stats.message_end_time,
            "duration_s": (stats.message_end_time - stats.message_start_time) / 1e9 if stats.message_count else 0.0,
            "topics": topics}
