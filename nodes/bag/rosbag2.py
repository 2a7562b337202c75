"""rosbag2's directory layout: ``metadata.yaml`` written as ``ros2 bag record`` (Jazzy) writes it, and read back.

A rosbag2 bag is a directory holding storage files (``NAME_0.mcap``, or ``NAME_0.db3`` for sqlite3) and a
``metadata.yaml`` describing them (format version 9 in Jazzy: QoS policies as names, RIHS01 type hashes,
``ros_distro``). ``ros2 bag info``/``play`` and rosbags' readers start from that file, so the keys, their
order and their meaning follow rosbag2_storage's ``yaml.hpp``/``qos.cpp``. Reading accepts versions 4-9.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

METADATA_FILE = "metadata.yaml"
VERSION = 9  # rosbag2_storage::BagMetadata::version in Jazzy
ROS_DISTRO = "jazzy"  # the format we follow; ros2 bag writes $ROS_DISTRO here

# RMW_DURATION_INFINITE (INT64_MAX ns) as rosbag2 writes it: whole seconds and the nanosecond rest.
INFINITE = {"sec": 9223372036, "nsec": 854775807}
# Topics our nodes publish latched (ROS "transient local"): recorded with that durability, played latched.
LATCHED_SUFFIXES = ("tf_static", "robot_description")


class MetadataError(Exception):
    """A metadata.yaml that cannot be used; the message names the field and the reason."""


def is_latched(topic: str) -> bool:
    return topic.rstrip("/").rsplit("/", 1)[-1] in LATCHED_SUFFIXES


def offered_qos(topic: str) -> list[dict[str, Any]]:
    """The QoS our publishers offer, as one rosbag2 v9 profile: reliable, keep-last 10, no deadlines.

    Zenoh has no per-publisher QoS to discover, so this is what an rclcpp publisher with default QoS offers
    (and transient local for latched topics, so ``ros2 bag play`` republishes those latched too)."""
    return [{
        "history": "keep_last",
        "depth": 1 if is_latched(topic) else 10,
        "reliability": "reliable",
        "durability": "transient_local" if is_latched(topic) else "volatile",
        "deadline": dict(INFINITE),
        "lifespan": dict(INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(INFINITE),
        "avoid_ros_namespace_conventions": False,
    }]


@dataclass
class TopicInfo:
    name: str
    type: str
    count: int = 0
    serialization_format: str = "cdr"
    type_hash: str = ""
    qos: list[dict[str, Any]] = field(default_factory=list)

    @property
    def durability(self) -> str:
        """The first offered profile's durability (v9 names; v8 integers mapped), '' when unknown."""
        if not self.qos:
            return ""
        value = self.qos[0].get("durability", "")
        return {1: "transient_local", 2: "volatile"}.get(value, str(value)) if isinstance(value, int) else value


@dataclass
class FileInfo:
    path: str
    start_ns: int
    duration_ns: int
    count: int


@dataclass
class BagMetadata:
    storage: str
    files: list[str]
    topics: list[TopicInfo]
    start_ns: int = 0
    duration_ns: int = 0
    message_count: int = 0
    file_infos: list[FileInfo] = field(default_factory=list)
    compression_format: str = ""
    compression_mode: str = ""
    custom_data: dict[str, str] = field(default_factory=dict)
    ros_distro: str = ""
    version: int = VERSION


def to_yaml(meta: BagMetadata) -> str:
    """metadata.yaml text: rosbag2's keys in rosbag2's order (yaml-cpp's block layout)."""
    return dump({"rosbag2_bagfile_information": to_dict(meta)})


def to_dict(meta: BagMetadata) -> dict[str, Any]:
    """The bag's metadata as rosbag2's ``BagMetadata`` YAML node (what metadata.yaml holds under its key)."""
    return {
        "version": meta.version,
        "storage_identifier": meta.storage,
        "duration": {"nanoseconds": meta.duration_ns},
        "starting_time": {"nanoseconds_since_epoch": meta.start_ns},
        "message_count": meta.message_count,
        "topics_with_message_count": [{
            "topic_metadata": {
                "name": t.name,
                "type": t.type,
                "serialization_format": t.serialization_format,
                "offered_qos_profiles": t.qos,
                "type_description_hash": t.type_hash,
            },
            "message_count": t.count,
        } for t in meta.topics],
        "compression_format": meta.compression_format,
        "compression_mode": meta.compression_mode,
        "relative_file_paths": list(meta.files),
        "files": [{
            "path": f.path,
            "starting_time": {"nanoseconds_since_epoch": f.start_ns},
            "duration": {"nanoseconds": f.duration_ns},
            "message_count": f.count,
        } for f in meta.file_infos],
        "custom_data": dict(meta.custom_data) or None,
        "ros_distro": meta.ros_distro,
    }


def qos_yaml(profiles: list[dict[str, Any]]) -> str:
    """The ``offered_qos_profiles`` string rosbag2's MCAP plugin puts in each channel's metadata."""
    return dump(profiles).rstrip("\n")


class _Dumper(yaml.SafeDumper):
    """Indented sequences, ``""`` for empty strings and ``~`` for null, as yaml-cpp writes them."""

    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        super().increase_indent(flow, False)


def _str(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style='"' if value == "" else None)


def _none(dumper: yaml.SafeDumper, _value: None) -> yaml.Node:
    return dumper.represent_scalar("tag:yaml.org,2002:null", "~")


_Dumper.add_representer(str, _str)
_Dumper.add_representer(type(None), _none)


def dump(data: Any) -> str:
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=False, width=1 << 16)


def write(directory: Path, meta: BagMetadata) -> None:
    """Write atomically, so a crash never leaves a half-written metadata.yaml next to good data."""
    tmp = directory / (METADATA_FILE + ".tmp")
    tmp.write_text(to_yaml(meta), encoding="utf-8")
    tmp.replace(directory / METADATA_FILE)


def read(directory: Path) -> BagMetadata:
    path = directory / METADATA_FILE
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise MetadataError(f"{path}: not readable YAML ({exc})".replace("\n", " ")) from None
    return parse(doc, str(path))


def parse(doc: Any, where: str) -> BagMetadata:
    """A parsed metadata document → BagMetadata; every problem names the field."""
    info = _get(doc, "rosbag2_bagfile_information", dict, where)
    version = _get(info, "version", int, where)
    if not 4 <= version <= VERSION:
        raise MetadataError(f"{where}: version: {version} is not a rosbag2 format this reader knows (4-{VERSION})")
    storage = _get(info, "storage_identifier", str, where)
    topics = []
    for i, entry in enumerate(_get(info, "topics_with_message_count", list, where, default=[])):
        at = f"{where}: topics_with_message_count[{i}]"
        tm = _get(entry, "topic_metadata", dict, at)
        qos = tm.get("offered_qos_profiles") or []
        if isinstance(qos, str):  # versions 4-8: a YAML document inside a string
            try:
                qos = yaml.safe_load(qos) or []
            except yaml.YAMLError:
                raise MetadataError(f"{at}.topic_metadata.offered_qos_profiles: not YAML") from None
        if not isinstance(qos, list) or not all(isinstance(q, dict) for q in qos):
            raise MetadataError(f"{at}.topic_metadata.offered_qos_profiles: expected a list of profiles")
        topics.append(TopicInfo(
            name=_get(tm, "name", str, at), type=_get(tm, "type", str, at),
            count=_get(entry, "message_count", int, at, default=0),
            serialization_format=_get(tm, "serialization_format", str, at, default="cdr"),
            type_hash=_get(tm, "type_description_hash", str, at, default="") or "", qos=qos))
    files = _get(info, "relative_file_paths", list, where)
    if not files or not all(isinstance(f, str) and f for f in files):
        raise MetadataError(f"{where}: relative_file_paths: expected a non-empty list of file names")
    custom = info.get("custom_data") or {}
    if not isinstance(custom, dict):
        raise MetadataError(f"{where}: custom_data: expected a map of strings")
    return BagMetadata(
        storage=storage, files=files, topics=topics,
        start_ns=_get(_get(info, "starting_time", dict, where, default={}), "nanoseconds_since_epoch", int, where,
                      default=0),
        duration_ns=_get(_get(info, "duration", dict, where, default={}), "nanoseconds", int, where, default=0),
        message_count=_get(info, "message_count", int, where, default=sum(t.count for t in topics)),
        compression_format=_get(info, "compression_format", str, where, default="") or "",
        compression_mode=_get(info, "compression_mode", str, where, default="") or "",
        custom_data={str(k): str(v) for k, v in custom.items()},
        ros_distro=str(info.get("ros_distro") or ""), version=version)


_MISSING = object()


def _get(mapping: Any, key: str, kind: type, where: str, default: Any = _MISSING) -> Any:
    if not isinstance(mapping, dict):
        raise MetadataError(f"{where}: expected a map holding '{key}'")
    value = mapping.get(key, _MISSING)
    if value is _MISSING or (value is None and default is not _MISSING):
        if default is _MISSING:
            raise MetadataError(f"{where}: {key}: missing")
        return default
    if kind is int and isinstance(value, bool) or not isinstance(value, kind):
        raise MetadataError(f"{where}: {key}: expected {kind.__name__}, got {type(value).__name__}")
    return value
