"""Opening a bag on disk, whatever wrote it: a rosbag2 directory (metadata.yaml + MCAP or sqlite3 files,
uncompressed or zstd-compressed per file or per message), a bare ``.mcap`` or ``.db3`` file, or a
directory of ``.mcap``/``.db3`` files without metadata (what older zenroid versions and a killed ``ros2 bag
record`` leave). rosbags reads the storage; messages come back decoded into our message classes, in
log-time order across all storage files.

A payload decodes with msgs.cdr when the bag's definition of its type is ours (same RIHS01 hash: every bag
we write, and standard types from Iron on), else with rosbags following the definition stored in the bag,
mapped field by field onto ours: a field of ours the bag's type lacks is a clear error.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from itertools import groupby
from pathlib import Path
from typing import Any

from rosbags.interfaces import Connection, MessageDefinitionFormat, Qos
from rosbags.rosbag2 import Reader, ReaderError

import msgs
from msgs import cdr
from msgs.registry import get_spec
from msgs.type_hash import rihs01
from nodes.bag.qos import offered_latched

METADATA_FILE = "metadata.yaml"
_SUFFIXES = {".mcap": "mcap", ".db3": "sqlite3"}
_MAGIC = {b"\x89MCAP": ".mcap", b"SQLite format 3\x00": ".db3"}


class BagError(Exception):
    """A bag that cannot be opened or understood; the message says which and why."""


@dataclass
class BagMessage:
    key: str
    type_name: str
    msg: Any
    log_time_ns: int


@dataclass
class TopicInfo:
    name: str
    type: str
    count: int
    serialization_format: str
    type_hash: str
    qos: list[Qos]

    @property
    def latched(self) -> bool:
        return offered_latched(self.qos, self.name)


class Bag:
    """A bag's summary (what ``ros2 bag info`` shows) and its messages; ``close()`` or use ``with``."""

    def __init__(self, path: Path, readers: list[Reader], files: list[Path], storage: str,
                 has_metadata_file: bool) -> None:
        self.path = path
        self.files = files
        self.storage = storage
        self.has_metadata_file = has_metadata_file
        self._readers = readers
        # One line per topic and type, over storage files (and QoS variants rosbag2 keeps apart).
        self.topics: list[TopicInfo] = []
        conns = sorted((c for r in readers for c in r.connections), key=lambda c: (c.topic, c.msgtype))
        for (topic, msgtype), same in groupby(conns, key=lambda c: (c.topic, c.msgtype)):
            group = list(same)
            first_conn = group[0]
            self.topics.append(TopicInfo(topic, msgtype, sum(c.msgcount for c in group),
                                         first_conn.ext.serialization_format, first_conn.digest,
                                         list(first_conn.ext.offered_qos_profiles)))
        counted = [r for r in readers if r.message_count]
        self.message_count = sum(r.message_count for r in readers)
        self.start_ns = min((r.start_time for r in counted), default=0)
        self.end_ns = max((r.end_time - 1 for r in counted), default=self.start_ns)  # rosbags' end is exclusive
        self.ros_distro = next((r.ros_distro for r in readers if r.ros_distro), "") or ""
        first = readers[0]
        self.compression = f"{first.compression_format} ({first.compression_mode})" if first.compression_mode else ""

    def __enter__(self) -> Bag:
        return self

    def __exit__(self, *_: Any) -> None:
        self.close()

    def close(self) -> None:
        for reader in self._readers:
            if reader.is_open:
                reader.close()

    def topic(self, name: str) -> TopicInfo | None:
        return next((t for t in self.topics if t.name == name), None)

    def info(self) -> dict[str, Any]:
        return {"path": str(self.path), "files": [f.name for f in self.files],
                "size_bytes": sum(f.stat().st_size for f in self.files), "storage": self.storage,
                "ros_distro": self.ros_distro, "messages": self.message_count, "start_ns": self.start_ns,
                "end_ns": self.end_ns, "duration_s": (self.end_ns - self.start_ns) / 1e9,
                "compression": self.compression,
                "topics": [{"topic": t.name, "type": t.type, "count": t.count,
                            "serialization": t.serialization_format, "type_hash": t.type_hash}
                           for t in self.topics]}

    def messages(self, keys: list[str] | None = None,
                 on_unknown: Callable[[str, str], None] | None = None) -> Iterator[BagMessage]:
        """Decoded messages of ``keys`` (all when None) in log-time order.

        A topic whose type is not defined here (or whose payloads do not decode) is an error, or with
        ``on_unknown`` is reported once as ``on_unknown(topic, reason)`` and skipped."""
        wanted = {"/" + k.strip("/") for k in keys} if keys else None
        streams = []
        for reader in self._readers:
            conns = [c for c in reader.connections if wanted is None or c.topic in wanted]
            if conns:  # (none would mean all to rosbags)
                streams.append(reader.messages(conns))
        decoders: dict[tuple[str, str, str, str], Callable[[bytes], Any]] = {}
        skipped: set[str] = set()
        try:
            for conn, timestamp, data in heapq.merge(*streams, key=lambda m: m[1]):
                if conn.topic in skipped:
                    continue
                key = (conn.topic, conn.msgtype, conn.msgdef.data, conn.digest)
                try:
                    decode = decoders.get(key) or decoders.setdefault(key, _decoder(conn))
                    msg = decode(data)
                except (cdr.CdrError, msgs.DecodeError) as exc:
                    if on_unknown is None:
                        raise BagError(f"{self.path}: topic {conn.topic}: {exc}") from None
                    skipped.add(conn.topic)
                    on_unknown(conn.topic, str(exc))
                    continue
                yield BagMessage(conn.topic.lstrip("/"), msg._type, msg, timestamp)
        except ReaderError as exc:
            raise BagError(f"{self.path}: {exc}") from None


def open_bag(path: str | Path) -> Bag:
    p = Path(path)
    if p.is_file() and p.name == METADATA_FILE:
        p = p.parent
    if p.is_dir() and (p / METADATA_FILE).is_file():
        reader = _open(p, p / METADATA_FILE)
        storage = reader.storage.storages[0]
        names = [Path(f["path"]).name for f in reader.storage.files] or [storage.path.name]
        return Bag(p, [reader], [p / n for n in names], _SUFFIXES.get(storage.path.suffix, "mcap"), True)
    if p.is_dir():
        files = sorted(p.glob("*.mcap")) or sorted(p.glob("*.db3"))
        if not files:
            raise BagError(f"no metadata.yaml and no .mcap or .db3 file in directory {p}")
    elif p.is_file():
        files = [p]
    else:
        raise BagError(f"no bag at {p}")
    suffix = _suffix_of(files[0])
    return Bag(p, [_open(f, f) for f in files], files, _SUFFIXES[suffix], False)


def read_bag(path: str | Path, keys: list[str] | None = None) -> Iterator[BagMessage]:
    """Messages in log-time order, decoded and validated into zenroid message classes."""
    with open_bag(path) as bag:
        yield from bag.messages(keys)


def _suffix_of(p: Path) -> str:
    with open(p, "rb") as f:
        head = f.read(16)
    for magic, suffix in _MAGIC.items():
        if head.startswith(magic):
            if p.suffix != suffix:  # rosbags tells storages by their suffix
                raise BagError(f"{p}: a {_SUFFIXES[suffix]} storage file; name it *{suffix} to open it")
            return suffix
    if p.suffix == ".zstd":
        raise BagError(f"{p}: a zstd-compressed storage file; open the bag directory (its metadata.yaml says "
                       "how it is compressed)")
    raise BagError(f"{p}: not a readable MCAP bag or rosbag2 sqlite3 file (unknown file format)")


def _open(p: Path, where: Path) -> Reader:
    reader = Reader(p)
    try:
        reader.open()
    except ReaderError as exc:
        raise BagError(f"{where}: {_what(p)} ({exc})") from None
    except Exception as exc:  # noqa: BLE001 - the storage libraries raise many kinds on corrupt files
        raise BagError(f"{where}: {_what(p)} ({type(exc).__name__}: {exc})") from None
    if not all(type(v) is int for v in (reader.message_count, reader.start_time, reader.end_time)):
        reader.close()  # rosbags takes these from metadata.yaml as they are
        raise BagError(f"{where}: message_count, starting_time, duration: expected integers")
    return reader


def _what(p: Path) -> str:
    if p.is_dir():
        return "not a readable rosbag2 bag"
    return "not a readable rosbag2 sqlite3 file" if p.suffix == ".db3" else "not a readable MCAP bag"


def _decoder(conn: Connection) -> Callable[[bytes], Any]:
    """Payload → our message for one connection of the bag (cdr.CdrError when it cannot be)."""
    type_name = conn.msgtype if conn.msgtype.count("/") == 2 else conn.msgtype.replace("/", "/msg/", 1)
    if conn.ext.serialization_format != "cdr":
        raise cdr.CdrError(f"encoded as '{conn.ext.serialization_format}', only cdr is supported")
    try:
        cls = msgs.get_type(type_name)
        ours = rihs01(type_name)
    except (KeyError, msgs.DefinitionError) as exc:
        raise cdr.CdrError(f"type {type_name} is not defined here ({exc})") from None
    store = _bag_typestore(conn, type_name, ours)
    if store is None:
        return lambda data: msgs.from_dict(cls, cdr.decode(type_name, data))

    def foreign(data: bytes) -> Any:
        try:
            value = store.deserialize_cdr(data, type_name)
        except Exception as exc:  # noqa: BLE001 - truncated or foreign payloads fail in many ways
            raise cdr.CdrError(f"{type_name} payload is not valid CDR ({type(exc).__name__}: {exc})") from None
        try:
            return msgs.from_dict(cls, _plain(type_name, value))
        except AttributeError as exc:
            raise cdr.CdrError(f"the bag's {type_name} lacks a field of ours ({exc})") from None

    return foreign


def _bag_typestore(conn: Connection, type_name: str, ours: str) -> Any:
    """A typestore of the bag's own definition when it differs from ours, else None (decode as ours).

    No stored definition (Humble sqlite3) or one rosbags cannot parse: ours it is."""
    if conn.digest == ours or conn.msgdef.format != MessageDefinitionFormat.MSG:
        return None
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # only here: 15 ms of import

    store = get_typestore(Stores.EMPTY)
    try:
        store.register(get_types_from_msg(conn.msgdef.data, type_name))
        if store.hash_rihs01(type_name) == ours:
            return None
    except Exception as exc:  # noqa: BLE001 - the parser raises several kinds on bad text
        raise cdr.CdrError(f"schema of {type_name} cannot be parsed ({exc})") from None
    return store


def _plain(type_name: str, value: Any) -> dict[str, Any]:
    """A message rosbags decoded → a plain map following our own definition of the type."""
    out: dict[str, Any] = {}
    for f in get_spec(type_name).fields:
        v = getattr(value, f.name)
        if f.is_bytes:
            out[f.name] = bytes(v)
        elif f.is_primitive:
            out[f.name] = v.tolist() if hasattr(v, "tolist") else list(v) if f.is_array else v  # numpy → plain
        elif f.is_array:
            out[f.name] = [_plain(f.base, x) for x in v]
        else:
            out[f.name] = _plain(f.base, v)
    return out
