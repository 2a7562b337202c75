"""CDR payloads of a bag ↔ zenroid messages, driven by ``ros2msg`` schema text (mcap-ros2-support's codec).

Decoding uses the schema stored *in the bag* (so a bag from elsewhere decodes as its writer defined it),
then maps the result onto our definition of the type field by field and validates it; a field our
definition has and the bag's does not is a clear error naming the topic and field.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from mcap.records import Schema
from mcap_ros2._dynamic import serialize_dynamic
from mcap_ros2.decoder import DecoderFactory

import msgs
from msgs.idl import FieldSpec
from msgs.registry import get_spec
from msgs.schema_text import full_definition

_lock = threading.Lock()
_encoders: dict[str, Callable[[Any], bytes]] = {}
_decoders: dict[tuple[str, str], Callable[[bytes], Any]] = {}
_factory = DecoderFactory()


class CdrError(Exception):
    """A payload or schema that cannot be turned into one of our messages."""


def full_type_name(name: str) -> str:
    """``pkg/Name`` (ROS 1 style, some older tools) → ``pkg/msg/Name``."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


def schema_text(type_name: str) -> str:
    """Our ``ros2msg`` text of a type with every nested type: the schema we store."""
    return full_definition(type_name)


def encode(msg: Any) -> bytes:
    type_name = msg._type
    with _lock:
        enc = _encoders.get(type_name)
        if enc is None:
            enc = _encoders[type_name] = serialize_dynamic(type_name, schema_text(type_name))[type_name]
    return enc(msg)


def decode(type_name: str, data: bytes, text: str | None = None) -> Any:
    """A payload of ``type_name`` (schema ``text`` from the bag, else ours) → our validated message class."""
    type_name = full_type_name(type_name)
    try:
        cls = msgs.get_type(type_name)
    except (KeyError, msgs.DefinitionError) as exc:
        raise CdrError(f"type {type_name} is not defined here ({exc})") from None
    if text is None:
        text = schema_text(type_name)
    key = (type_name, text)
    with _lock:
        dec = _decoders.get(key)
        if dec is None:
            schema = Schema(id=len(_decoders) + 1, name=type_name, encoding="ros2msg", data=text.encode())
            try:
                dec = _decoders[key] = _factory.decoder_for("cdr", schema)
            except Exception as exc:  # noqa: BLE001 - the parser raises several kinds on bad text
                raise CdrError(f"schema of {type_name} cannot be parsed ({exc})") from None
    try:
        ros_msg = dec(data)
    except Exception as exc:  # noqa: BLE001 - truncated or foreign payloads fail in many ways
        raise CdrError(f"{type_name} payload is not valid CDR ({type(exc).__name__}: {exc})") from None
    try:
        return msgs.from_dict(cls, _to_plain(type_name, ros_msg))
    except AttributeError as exc:
        raise CdrError(f"the bag's {type_name} lacks a field of ours ({exc})") from None
    except msgs.DecodeError as exc:
        raise CdrError(str(exc)) from None


def _to_plain(spec_type: str, ros_msg: Any) -> dict[str, Any]:
    """The decoder's dynamic object → a plain map following our own definition of the type."""
    return {f.name: _plain_field(f, getattr(ros_msg, f.name)) for f in get_spec(spec_type).fields}


def _plain_field(f: FieldSpec, value: Any) -> Any:
    if f.is_bytes:
        return bytes(value)
    if f.is_primitive:
        return list(value) if f.is_array else value
    if f.is_array:
        return [_to_plain(f.base, v) for v in value]
    return _to_plain(f.base, value)
