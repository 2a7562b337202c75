"""Recording a bag: a rosbag2 directory (``metadata.yaml`` + ``NAME_0.mcap``) or, for ``*.mcap``, one file.

The directory is exactly what ``ros2 bag record -s mcap -o NAME`` leaves behind in Jazzy, so ``ros2 bag
info/play NAME`` and rosbags' readers open it. Topics are the Zenoh keys with a leading ``/`` (our keys
are ROS names), types are ``pkg/msg/Name``, each with its RIHS01 hash when one can be computed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nodes.bag import cdr, rosbag2
from nodes.bag.mcap_file import McapStorageWriter
from nodes.bag.type_hash import rihs01


@dataclass
class _Topic:
    info: rosbag2.TopicInfo
    channel: int


class BagWriter:
    def __init__(self, path: str | Path) -> None:
        p = Path(path)
        if p.suffix == ".mcap":
            self.directory: Path | None = None
            if p.exists():
                raise FileExistsError(p)
            storage = p
        else:
            p.mkdir(parents=True, exist_ok=False)
            self.directory = p
            storage = p / f"{p.name}_0.mcap"
        self.path = p
        self.storage_path = storage
        self._storage = McapStorageWriter(storage)
        self._topics: dict[tuple[str, str], _Topic] = {}
        self.unrecordable: set[str] = set()
        self.count = 0
        self.bytes = 0
        self.start_ns: int | None = None
        self.end_ns = 0

    def write(self, key: str, msg: Any, log_time_ns: int | None = None) -> bool:
        """Store ``msg`` under topic ``/key``; False (and remembered) if its type has no ROS schema."""
        type_name = msg._type
        if type_name in self.unrecordable:
            return False
        topic_name = "/" + key.strip("/")
        topic = self._topics.get((topic_name, type_name))
        try:
            data = cdr.encode(msg)
            if topic is None:
                qos = rosbag2.offered_qos(topic_name)
                info = rosbag2.TopicInfo(name=topic_name, type=type_name, type_hash=rihs01(type_name), qos=qos)
                channel = self._storage.add_topic(topic_name, type_name, cdr.schema_text(type_name),
                                                  rosbag2.qos_yaml(qos), info.type_hash)
                topic = self._topics[(topic_name, type_name)] = _Topic(info, channel)
        except Exception:  # noqa: BLE001 - a type ROS tools cannot name (action wrappers)
            self.unrecordable.add(type_name)
            return False
        t = log_time_ns if log_time_ns is not None else time.time_ns()
        self._storage.write(topic.channel, t, data)
        topic.info.count += 1
        self.count += 1
        self.bytes += len(data)
        self.start_ns = t if self.start_ns is None else min(self.start_ns, t)
        self.end_ns = max(self.end_ns, t)
        return True

    def topic_counts(self) -> dict[str, int]:
        return {t.info.name: t.info.count for t in self._topics.values()}

    def metadata(self) -> rosbag2.BagMetadata:
        start = self.start_ns or 0
        duration = self.end_ns - start if self.count else 0
        name = self.storage_path.name
        return rosbag2.BagMetadata(
            storage="mcap", files=[name], topics=[t.info for t in self._topics.values()],
            start_ns=start, duration_ns=duration, message_count=self.count,
            file_infos=[rosbag2.FileInfo(name, start, duration, self.count)],
            custom_data={"recorded_by": "zenroid bag record"}, ros_distro=rosbag2.ROS_DISTRO)

    def close(self) -> None:
        meta = self.metadata()
        # The MCAP record holds the metadata without its top-level key, as rosbag2's plugin writes it.
        self._storage.close(rosbag2.dump(rosbag2.to_dict(meta)))
        if self.directory is not None:
            rosbag2.write(self.directory, meta)
