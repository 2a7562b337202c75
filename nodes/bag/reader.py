"""Opening a bag on disk, whatever wrote it: a rosbag2 directory (metadata.yaml + MCAP or sqlite3 files,
uncompressed or zstd-compressed per file or per message), a bare ``.mcap`` or ``.db3`` file, or a
directory of ``.mcap`` files without metadata (what older zenroid versions wrote).

Messages come back decoded into our message classes, in log-time order across all storage files.
"""

from __future__ import annotations

import heapq
import tempfile
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zstandard

from nodes.bag import cdr, mcap_file, rosbag2, sqlite3_file
from nodes.bag.mcap_file import RawMessage, StorageError
from nodes.bag.rosbag2 import BagMetadata, MetadataError, TopicInfo

STORAGES = ("mcap", "sqlite3")
_MAGIC = {b"\x89MCAP": "mcap", b"SQLite format 3\x00": "sqlite3"}


class BagError(Exception):
    """A bag that cannot be opened, written or understood; the message says which and why."""


@dataclass
class BagMessage:
    key: str
    type_name: str
    msg: Any
    log_time_ns: int


class Bag:
    """A bag's metadata (as ``ros2 bag info`` shows it) and its messages."""

    def __init__(self, path: Path, meta: BagMetadata, files: list[Path], has_metadata_file: bool) -> None:
        self.path = path
        self.meta = meta
        self.files = files
        self.has_metadata_file = has_metadata_file

    def topic(self, name: str) -> TopicInfo | None:
        return next((t for t in self.meta.topics if t.name == name), None)

    def info(self) -> dict[str, Any]:
        m = self.meta
        return {"path": str(self.path), "files": [f.name for f in self.files],
                "size_bytes": sum(f.stat().st_size for f in self.files), "storage": m.storage,
                "ros_distro": m.ros_distro, "messages": m.message_count, "start_ns": m.start_ns,
                "end_ns": m.start_ns + m.duration_ns, "duration_s": m.duration_ns / 1e9,
                "compression": f"{m.compression_format} ({m.compression_mode})" if m.compression_mode else "",
                "topics": [{"topic": t.name, "type": t.type, "count": t.count,
                            "serialization": t.serialization_format, "type_hash": t.type_hash}
                           for t in m.topics]}

    def messages(self, keys: list[str] | None = None,
                 on_unknown: Callable[[str, str], None] | None = None) -> Iterator[BagMessage]:
        """Decoded messages of ``keys`` (all when None) in log-time order.

        A topic whose type is not defined here (or whose payloads do not decode) is an error, or with
        ``on_unknown`` is reported once as ``on_unknown(topic, reason)`` and skipped."""
        wanted = {"/" + k.strip("/") for k in keys} if keys else None
        skipped: set[str] = set()
        message_zstd = self.meta.compression_mode.lower() == "message"
        unzstd = zstandard.ZstdDecompressor()
        with ExitStack() as stack:
            streams = [self._raw(path, wanted, stack) for path in self.files]
            for raw in heapq.merge(*streams, key=lambda r: r.log_time_ns):
                if raw.topic in skipped:
                    continue
                try:
                    data = unzstd.decompress(raw.data) if message_zstd else raw.data
                    msg = cdr.decode(raw.type_name, data, raw.schema_text)
                except (cdr.CdrError, zstandard.ZstdError) as exc:
                    if on_unknown is None:
                        raise BagError(f"{self.path}: topic {raw.topic}: {exc}") from None
                    skipped.add(raw.topic)
                    on_unknown(raw.topic, str(exc))
                    continue
                yield BagMessage(raw.topic.lstrip("/"), msg._type, msg, raw.log_time_ns)

    def _raw(self, path: Path, wanted: set[str] | None, stack: ExitStack) -> Iterator[RawMessage]:
        try:
            if self.meta.storage == "sqlite3":
                yield from sqlite3_file.messages(self._plain_file(path, stack, ".db3"), wanted)
            else:
                f = stack.enter_context(open(self._plain_file(path, stack, ".mcap"), "rb"))
                yield from mcap_file.messages(f, str(path), wanted)
        except StorageError as exc:
            raise BagError(str(exc)) from None

    def _plain_file(self, path: Path, stack: ExitStack, suffix: str) -> Path:
        """The storage file itself, or (file compression) a decompressed temporary copy of it."""
        if self.meta.compression_mode.lower() != "file":
            return path
        tmp = stack.enter_context(tempfile.TemporaryDirectory(prefix="zenroid_bag_")) + "/" + path.stem
        try:
            with open(path, "rb") as src, open(tmp, "wb") as dst:
                zstandard.ZstdDecompressor().copy_stream(src, dst)
        except zstandard.ZstdError as exc:
            raise BagError(f"{path}: not a zstd-compressed file ({exc})") from None
        return Path(tmp)


def open_bag(path: str | Path) -> Bag:
    p = Path(path)
    if p.is_file() and p.name == rosbag2.METADATA_FILE:
        p = p.parent
    if p.is_dir():
        return _open_directory(p)
    if not p.is_file():
        raise BagError(f"no bag at {p}")
    return _from_storage_files(p, [p], _storage_of(p), has_metadata_file=False)


def read_bag(path: str | Path, keys: list[str] | None = None) -> Iterator[BagMessage]:
    """Messages in log-time order, decoded and validated into zenroid message classes."""
    return open_bag(path).messages(keys)


def _storage_of(p: Path) -> str:
    with open(p, "rb") as f:
        head = f.read(16)
    for magic, storage in _MAGIC.items():
        if head.startswith(magic):
            return storage
    if p.suffix == ".zstd":
        raise BagError(f"{p}: a zstd-compressed storage file; open the bag directory (its metadata.yaml says "
                       "how it is compressed)")
    raise BagError(f"{p}: not a readable MCAP bag or rosbag2 sqlite3 file (unknown file format)")


def _open_directory(d: Path) -> Bag:
    if not (d / rosbag2.METADATA_FILE).is_file():
        files = sorted(d.glob("*.mcap")) or sorted(d.glob("*.db3"))
        if not files:
            raise BagError(f"no metadata.yaml and no .mcap or .db3 file in directory {d}")
        return _from_storage_files(d, files, _storage_of(files[0]), has_metadata_file=False)
    try:
        meta = rosbag2.read(d)
    except MetadataError as exc:
        raise BagError(str(exc)) from None
    where = d / rosbag2.METADATA_FILE
    if meta.storage not in STORAGES:
        raise BagError(f"{where}: storage_identifier: '{meta.storage}' is not supported "
                       f"(supported: {', '.join(STORAGES)})")
    mode = meta.compression_mode.lower()
    if mode not in ("", "none", "file", "message"):
        raise BagError(f"{where}: compression_mode: '{meta.compression_mode}' is not file, message or empty")
    if mode in ("file", "message") and meta.compression_format.lower() != "zstd":
        raise BagError(f"{where}: compression_format: '{meta.compression_format}' is not supported (zstd only)")
    files = []
    for name in meta.files:
        candidate = d / name
        if not candidate.is_file():  # rosbag2 before Foxy stored paths with the bag's directory in front
            candidate = d / Path(name).name
        if not candidate.is_file():
            raise BagError(f"{where}: relative_file_paths: '{name}' does not exist in {d}")
        files.append(candidate)
    return Bag(d, meta, files, has_metadata_file=True)


def _from_storage_files(path: Path, files: list[Path], storage: str, has_metadata_file: bool) -> Bag:
    """Metadata gathered from the storage files themselves (what ``ros2 bag reindex`` would write)."""
    topics: dict[tuple[str, str], TopicInfo] = {}
    count, start, end, distro = 0, None, 0, ""
    for f in files:
        try:
            if storage == "sqlite3":
                t_list, n, first, last = sqlite3_file.summary(f)
            else:
                with open(f, "rb") as fh:
                    t_list, n, first, last, distro = mcap_file.summary(fh, str(f))
        except StorageError as exc:
            raise BagError(str(exc)) from None
        for t in t_list:
            key = (t.name, t.type)
            if key in topics:
                topics[key].count += t.count
            else:
                topics[key] = t
        if n:
            count += n
            start = first if start is None else min(start, first)
            end = max(end, last)
    start = start or 0
    meta = BagMetadata(storage=storage, files=[f.name for f in files], topics=list(topics.values()),
                       start_ns=start, duration_ns=end - start if count else 0, message_count=count,
                       ros_distro=distro)
    return Bag(path, meta, files, has_metadata_file)

