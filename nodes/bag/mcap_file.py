"""One MCAP storage file, as rosbag2's MCAP storage plugin (Jazzy) writes and reads it.

Profile ``ros2``; one ``ros2msg`` schema per type, named ``pkg/msg/Name``; one ``cdr`` channel per topic
whose metadata holds ``offered_qos_profiles`` (YAML text) and ``topic_type_hash`` (RIHS01); and a
metadata record named ``rosbag2`` whose ``serialized_metadata`` is the bag's metadata, so ``ros2 bag info``
on the bare file shows the same as on the directory. Payloads are bytes here: nodes/bag/cdr.py encodes.
"""

from __future__ import annotations

import importlib.metadata
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import yaml
from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from nodes.bag.rosbag2 import TopicInfo


class StorageError(Exception):
    """A storage file that cannot be read or written; the message says which and why."""


def _library() -> str:
    try:
        return f"zenroid {importlib.metadata.version('zenroid')}; mcap {importlib.metadata.version('mcap')}"
    except importlib.metadata.PackageNotFoundError:
        return "zenroid"


class McapStorageWriter:
    def __init__(self, path: Path) -> None:
        self.path = path
        self._file = open(path, "xb")  # never overwrite a bag
        # Chunks are zstd-compressed inside the file (transparent to every MCAP reader, and not what
        # rosbag2 calls "compression", which stays empty in metadata.yaml).
        self._writer = McapWriter(self._file, chunk_size=1 << 20, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library=_library())
        self._schemas: dict[str, int] = {}

    def add_topic(self, topic: str, type_name: str, schema_text: str, qos_yaml: str, type_hash: str) -> int:
        schema_id = self._schemas.get(type_name)
        if schema_id is None:
            schema_id = self._schemas[type_name] = self._writer.register_schema(
                type_name, "ros2msg", schema_text.encode())
        return self._writer.register_channel(topic, "cdr", schema_id,
                                             {"offered_qos_profiles": qos_yaml, "topic_type_hash": type_hash})

    def write(self, channel_id: int, log_time_ns: int, data: bytes) -> None:
        self._writer.add_message(channel_id, log_time=log_time_ns, data=data, publish_time=log_time_ns)

    def close(self, serialized_metadata: str | None = None) -> None:
        if serialized_metadata is not None:
            self._writer.add_metadata("rosbag2", {"serialized_metadata": serialized_metadata})
        self._writer.finish()
        self._file.close()


@dataclass
class RawMessage:
    topic: str
    type_name: str
    schema_text: str | None
    log_time_ns: int
    data: bytes


def _reader(f: IO[bytes], where: str) -> Any:
    try:
        return make_reader(f)
    except Exception as exc:  # noqa: BLE001 - mcap raises many kinds on corrupt files
        raise StorageError(f"{where}: not a readable MCAP bag ({type(exc).__name__}: {exc})") from None


def summary(f: IO[bytes], where: str) -> tuple[list[TopicInfo], int, int, int, str]:
    """(topics, message count, first and last log time in ns, ros_distro) from the file's summary."""
    reader = _reader(f, where)
    try:
        summ = reader.get_summary()
    except Exception as exc:  # noqa: BLE001
        raise StorageError(f"{where}: not a readable MCAP bag ({type(exc).__name__}: {exc})") from None
    if summ is None or summ.statistics is None:
        raise StorageError(f"{where}: no summary section (was the recording interrupted?)")
    stats = summ.statistics
    topics = []
    for cid, channel in sorted(summ.channels.items(), key=lambda kv: kv[1].topic):
        schema = summ.schemas.get(channel.schema_id)
        topics.append(TopicInfo(name=channel.topic, type=schema.name if schema else "?",
                                count=stats.channel_message_counts.get(cid, 0),
                                serialization_format=channel.message_encoding,
                                type_hash=channel.metadata.get("topic_type_hash", "")))
    distro = ""
    try:
        for record in reader.iter_metadata():
            if record.name == "rosbag2":
                distro = record.metadata.get("ROS_DISTRO", distro)
                doc = yaml.safe_load(record.metadata.get("serialized_metadata") or "null")
                if isinstance(doc, dict) and doc.get("ros_distro"):
                    distro = str(doc["ros_distro"])
    except Exception:  # noqa: BLE001 - metadata records are optional; a bad one only hides the distro
        pass
    return topics, stats.message_count, stats.message_start_time, stats.message_end_time, distro


def messages(f: IO[bytes], where: str, topics: set[str] | None) -> Iterator[RawMessage]:
    """Every message of the file in log-time order (payloads as stored)."""
    reader = _reader(f, where)
    try:
        for schema, channel, message in reader.iter_messages(
                topics=sorted(topics) if topics is not None else None, log_time_order=True):
            if schema is None:
                raise StorageError(f"{where}: channel {channel.topic} has no schema")
            if channel.message_encoding != "cdr":
                raise StorageError(f"{where}: topic {channel.topic} is encoded as "
                                   f"'{channel.message_encoding}', only cdr is supported")
            text = schema.data.decode() if schema.encoding == "ros2msg" and schema.data else None
            yield RawMessage(channel.topic, schema.name, text, message.log_time, message.data)
    except StorageError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise StorageError(f"{where}: not a readable MCAP bag ({type(exc).__name__}: {exc})") from None
