"""Recording a bag: a rosbag2 directory (``metadata.yaml`` + ``NAME.mcap`` or ``NAME.db3``) or one ``.mcap`` file.

rosbags writes the storage and metadata.yaml (format version 9, as Jazzy's ``ros2 bag record``), so ``ros2
bag info/play`` opens it. Topics are the Zenoh keys with a leading ``/`` (our keys are ROS names), types are
``pkg/msg/Name`` with our ``ros2msg`` definition as schema and its RIHS01 hash; payloads are msgs.cdr.
MCAP chunks are zstd-compressed inside the file (transparent to every MCAP reader, and not what rosbag2
calls "compression", which stays empty in metadata.yaml).
"""

from __future__ import annotations

import functools
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from rosbags.interfaces import Connection
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

import msgs
from msgs import cdr
from msgs.schema_text import full_definition
from msgs.type_hash import rihs01
from nodes.bag.qos import offered_qos

STORAGES = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}


class BagWriter:
    def __init__(self, path: str | Path, storage: str = "mcap") -> None:
        """A new bag at ``path`` (a directory, or ``FILE.mcap`` for one MCAP file); FileExistsError if taken."""
        if storage not in STORAGES:
            raise ValueError(f"storage: '{storage}' is not one of {', '.join(STORAGES)}")
        p = Path(path)
        if p.exists():
            raise FileExistsError(p)
        self.path = p
        self._staging: Path | None = None
        directory = p
        if p.suffix == ".mcap":
            if storage != "mcap":
                raise ValueError(f"storage: a .mcap file is MCAP storage, not {storage}")
            # rosbags writes directories: record into a hidden one beside the file, then move the file out.
            p.parent.mkdir(parents=True, exist_ok=True)
            self._staging = Path(tempfile.mkdtemp(prefix=f".{p.stem}.", dir=p.parent))
            directory = self._staging / p.stem
        self._writer = Writer(directory, version=9, storage_plugin=STORAGES[storage])
        if storage == "mcap":
            self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self._writer.set_custom_data("recorded_by", "zenroid bag record")
        self._writer.open()
        self._connections: dict[tuple[str, str], Connection] = {}
        self._counts: dict[str, int] = {}
        self.unrecordable: set[str] = set()
        self.count = 0
        self.bytes = 0

    def write(self, key: str, msg: Any, log_time_ns: int | None = None) -> bool:
        """Store ``msg`` under topic ``/key``; False (and remembered) if its type has no ROS definition."""
        type_name = msg._type
        if type_name in self.unrecordable:
            return False
        topic = "/" + key.strip("/")
        connection = self._connections.get((topic, type_name))
        if connection is None:
            described = _described(type_name)
            if described is None:
                self.unrecordable.add(type_name)
                return False
            definition, type_hash = described
            connection = self._connections[(topic, type_name)] = self._writer.add_connection(
                topic, type_name, msgdef=definition, rihs01=type_hash, offered_qos_profiles=offered_qos(topic))
        data = cdr.encode(type_name, msgs.to_dict(msg))
        self._writer.write(connection, log_time_ns if log_time_ns is not None else time.time_ns(), data)
        self._counts[topic] = self._counts.get(topic, 0) + 1
        self.count += 1
        self.bytes += len(data)
        return True

    def topic_counts(self) -> dict[str, int]:
        return dict(self._counts)

    def close(self) -> None:
        self._writer.close()
        if self._staging is not None:
            (self._staging / self.path.stem / f"{self.path.stem}.mcap").replace(self.path)
            shutil.rmtree(self._staging)


@functools.cache
def _described(type_name: str) -> tuple[str, str] | None:
    """(``ros2msg`` definition, RIHS01 hash) of a type a bag can hold, else None.

    A reader rebuilds the type from the stored definition and checks it against the stored hash, so the
    two must agree: the ``.msg`` text cannot say that an action's parts nest ``pkg/action/X_Goal`` (it reads
    ``pkg/msg/X_Goal``), nor name a service's request (``pkg/srv/X_Request``), which are not topics anyway."""
    try:
        definition, ours = full_definition(type_name), rihs01(type_name)
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(definition, type_name))
        return (definition, ours) if store.hash_rihs01(type_name) == ours else None
    except Exception:  # noqa: BLE001 - rosbags' parser and hasher raise several kinds on what they cannot model
        return None
