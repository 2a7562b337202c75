"""The rmw_zenoh attachment and the source GIDs we put in it.

Every rmw_zenoh sample, query and reply carries ``int64 sequence number, int64 source timestamp (ns),
GID`` serialised with zenoh-ext's serializer (little endian; the 16-byte GID as a sequence: a LEB128
length byte, then the bytes). Services correlate a reply with its request through the sequence number
and the client's GID echoed back.

Our GIDs are *tagged*: 12 bytes of a hash of the endpoint's liveliness key, then 4 bytes of a keyed hash
of those 12. A subscription mirror uses the tag to drop CDR samples that a zenroid publisher mirrored
(the same message already arrived on our own key) without any shared state; ROS 2 treats a GID as opaque.
"""

from __future__ import annotations

import hashlib
import struct
import time
from dataclasses import dataclass

_HEAD = struct.Struct("<qqB")
_TAG_KEY = b"zenroid"
GID_SIZE = 16


@dataclass(frozen=True)
class Attachment:
    sequence: int
    timestamp_ns: int
    gid: bytes


def pack(sequence: int, gid: bytes, timestamp_ns: int | None = None) -> bytes:
    stamp = time.time_ns() if timestamp_ns is None else timestamp_ns
    return _HEAD.pack(sequence, stamp, len(gid)) + gid


def unpack(raw: bytes | None) -> Attachment | None:
    """The attachment of a sample/query, or None when absent or malformed."""
    if raw is None or len(raw) < _HEAD.size:
        return None
    sequence, stamp, size = _HEAD.unpack_from(raw)
    gid = bytes(raw[_HEAD.size:_HEAD.size + size])
    if size >= 0x80 or len(gid) != size:  # a longer GID would need a multi-byte length
        return None
    return Attachment(sequence, stamp, gid)


def make_gid(liveliness_key: str) -> bytes:
    head = hashlib.blake2b(liveliness_key.encode(), digest_size=12).digest()
    return head + hashlib.blake2b(head, key=_TAG_KEY, digest_size=4).digest()


def is_ours(gid: bytes) -> bool:
    return len(gid) == GID_SIZE and hashlib.blake2b(gid[:12], key=_TAG_KEY, digest_size=4).digest() == gid[12:]
