"""Bags on disk without processes: ours read by rosbags (the other side), rosbags' read by ours.

rosbags (Ternaris) is an independent pure-Python rosbag2 implementation: its reader checks our
metadata.yaml and MCAP layout, its own CDR deserializer checks our payloads, its RIHS01 code our hashes.
"""

from __future__ import annotations

import math
import os
import queue
import sqlite3
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory as Ros2DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2 import Reader as Rosbag2Reader
from rosbags.rosbag2 import Writer as Rosbag2Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

import msgs
from msgs.registry import get_spec
from msgs.schema_text import full_definition
from msgs.type_hash import rihs01
from nodes.bag.reader import BagError, open_bag, read_bag
from nodes.bag.writer import BagWriter
from nodes.tools.bag import _store
from tests.support.samples import UNDEFINED_TYPE, sample_message, undefined_type_cdr
from tests.unit.test_msgs_properties import ALL, message_strategy

JAZZY = get_typestore(Stores.ROS2_JAZZY)
# Types a bag holds: not service request/response halves (rosbag2 records services as */srv/*_Event,
# which we do not define), nor the action wrappers (FeedbackMessage, SendGoal_Request...), whose nested
# types (pkg/action/X_Feedback) their .msg text cannot name: the recorder reports them as "not recorded".
ACTION_WRAPPERS = ("_FeedbackMessage", "_SendGoal_Request", "_GetResult_Response")
# ...nor types with a `char` field, which rosbags hashes unlike rosidl (tests/unit/test_ros2_wire.py: UPSTREAM_JAZZY),
# or a `wstring` one, which it does not model: the writer records only what the reader will accept.
UNMODELLED = [t for t in ALL if any(f.base in ("char", "wstring") for f in get_spec(t).fields)]
TOPIC_TYPES = [t for t in ALL if "/srv/" not in t and not t.endswith(ACTION_WRAPPERS) and t not in UNMODELLED]
METADATA_KEYS = {"version", "storage_identifier", "duration", "starting_time", "message_count",
                 "topics_with_message_count", "compression_format", "compression_mode", "relative_file_paths",
                 "files", "custom_data", "ros_distro"}
QOS_KEYS = {"history", "depth", "reliability", "durability", "deadline", "lifespan", "liveliness",
            "liveliness_lease_duration", "avoid_ros_namespace_conventions"}


def plain_from_decoded(type_name: str, value: Any) -> dict[str, Any]:
    """A message another implementation decoded (rosbags, mcap-ros2-support) → a plain map following our
    definition (arrays as lists)."""
    out = {}
    for f in get_spec(type_name).fields:
        v = getattr(value, f.name)
        if f.is_bytes:
            out[f.name] = bytes(v)
        elif f.is_primitive:
            out[f.name] = [x.item() if isinstance(x, np.generic) else x for x in v] if f.is_array else (
                v.item() if isinstance(v, np.generic) else v)
            if f.base == "byte" and not f.is_array and out[f.name] < 0:
                out[f.name] += 256   # rosbags reads ROS 2's byte (an octet, 0-255) as ROS 1's int8
        elif f.is_array:
            out[f.name] = [plain_from_decoded(f.base, x) for x in v]
        else:
            out[f.name] = plain_from_decoded(f.base, v)
    return out


def same(a: Any, b: Any) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


def write_bag(path: Path, items: list[tuple[str, Any]], start_ns: int = 1_700_000_000_000_000_000) -> None:
    writer = BagWriter(path)
    for i, (key, msg) in enumerate(items):
        assert writer.write(key, msg, start_ns + i * 1_000_000), msg._type
    writer.close()


def test_every_topic_type_is_decoded_by_rosbags(tmp_path: Path) -> None:
    """One bag holding a non-default instance of every message type: rosbags decodes each to our values."""
    items = [(f"types/{t.replace('/', '_')}", sample_message(t)) for t in TOPIC_TYPES]
    write_bag(tmp_path / "all", items)
    with AnyReader([tmp_path / "all"]) as reader:
        decoded = [(c.topic, c.msgtype, reader.deserialize(raw, c.msgtype)) for c, _, raw in reader.messages()]
    assert len(decoded) == len(items)
    for (key, msg), (topic, msgtype, value) in zip(items, decoded):
        assert topic == "/" + key and msgtype == msg._type
        assert same(plain_from_decoded(msgtype, value), msgs.to_dict(msg)), msgtype
    # ...and ours reads it back identically.
    assert [m.msg for m in read_bag(tmp_path / "all")] == [m for _, m in items]


def test_types_without_a_ros_schema_are_refused_not_fatal(tmp_path: Path) -> None:
    """Service halves and action wrappers are no topics, and their .msg text cannot name their nested types
    (pkg/action/X_Goal reads as pkg/msg/X_Goal): refused, every other type recorded."""
    writer = BagWriter(tmp_path / "b")
    refused = [t for t in ALL if not writer.write(t.replace("/", "_"), sample_message(t))]
    assert refused == [t for t in ALL if t not in TOPIC_TYPES] and refused
    assert writer.count == len(TOPIC_TYPES)
    writer.close()
    assert open_bag(tmp_path / "b").info()["messages"] == len(TOPIC_TYPES)


@settings(max_examples=25, deadline=None)
@given(st.sampled_from(TOPIC_TYPES).flatmap(message_strategy))
def test_random_messages_survive_rosbags(msg: Any) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        write_bag(Path(tmp) / "bag", [("x/y", msg)])
        with AnyReader([Path(tmp) / "bag"]) as reader:
            [(conn, _, raw)] = list(reader.messages())
            value = reader.deserialize(raw, conn.msgtype)
    assert same(plain_from_decoded(msg._type, value), msgs.to_dict(msg))


def test_type_hashes_are_the_jazzy_ones() -> None:
    """Our definitions of standard types hash (RIHS01) exactly as rosbags' copy of ROS 2 Jazzy's, and every
    topic type, ours included, as rosbags hashes the definition text a bag stores for it."""
    standard = [t for t in TOPIC_TYPES if t in JAZZY.types]
    assert "sensor_msgs/msg/JointState" in standard and len(standard) >= 30
    for t in standard:
        assert rihs01(t) == JAZZY.hash_rihs01(t), t
    for t in TOPIC_TYPES:
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(full_definition(t), t))
        assert rihs01(t) == store.hash_rihs01(t), t


def test_metadata_yaml_follows_rosbag2(tmp_path: Path) -> None:
    js = msgs.get_type("sensor_msgs/msg/JointState")
    tf = msgs.get_type("tf2_msgs/msg/TFMessage")
    items = [("humanoid/joint_states", js(name=["a"], position=[float(i)])) for i in range(3)]
    write_bag(tmp_path / "b", [("tf_static", tf()), *items], start_ns=5_000_000_000)
    assert sorted(os.listdir(tmp_path / "b")) == ["b.mcap", "metadata.yaml"]
    doc = yaml.safe_load((tmp_path / "b" / "metadata.yaml").read_text())
    info = doc["rosbag2_bagfile_information"]
    assert list(doc) == ["rosbag2_bagfile_information"] and set(info) == METADATA_KEYS
    assert info["version"] == 9 and info["storage_identifier"] == "mcap" and info["ros_distro"] == "rosbags"
    assert info["duration"] == {"nanoseconds": 3_000_000} and info["message_count"] == 4
    assert info["starting_time"] == {"nanoseconds_since_epoch": 5_000_000_000}
    assert info["compression_format"] == "" and info["compression_mode"] == ""
    assert info["relative_file_paths"] == ["b.mcap"]
    assert info["files"] == [{"path": "b.mcap", "starting_time": {"nanoseconds_since_epoch": 5_000_000_000},
                              "duration": {"nanoseconds": 3_000_000}, "message_count": 4}]
    assert info["custom_data"] == {"recorded_by": "zenroid bag record"}
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert set(topics) == {"/tf_static", "/humanoid/joint_states"}
    js_meta = topics["/humanoid/joint_states"]
    assert set(js_meta) == {"topic_metadata", "message_count"} and js_meta["message_count"] == 3
    tm = js_meta["topic_metadata"]
    assert set(tm) == {"name", "type", "serialization_format", "offered_qos_profiles", "type_description_hash"}
    assert tm["type"] == "sensor_msgs/msg/JointState" and tm["serialization_format"] == "cdr"
    assert tm["type_description_hash"] == JAZZY.hash_rihs01("sensor_msgs/msg/JointState")
    [qos] = tm["offered_qos_profiles"]
    assert set(qos) == QOS_KEYS and qos["reliability"] == "reliable" and qos["durability"] == "volatile"
    assert qos["history"] == "keep_last" and qos["depth"] == 10
    assert qos["deadline"] == {"sec": 9223372036, "nsec": 854775807}
    [latched] = topics["/tf_static"]["topic_metadata"]["offered_qos_profiles"]
    assert latched["durability"] == "transient_local" and latched["depth"] == 1
    with Rosbag2Reader(tmp_path / "b") as reader:
        assert reader.message_count == 4 and reader.ros_distro == "rosbags"
        conns = {c.topic: c for c in reader.connections}
        assert conns["/humanoid/joint_states"].digest == tm["type_description_hash"]
        assert conns["/tf_static"].ext.offered_qos_profiles[0].durability.name == "TRANSIENT_LOCAL"
        assert len(list(reader.messages())) == 4


def test_mcap_bag_read_by_the_mcap_libraries(tmp_path: Path) -> None:
    """A second implementation besides rosbags (which writes our bags): Foxglove's mcap reader and
    mcap-ros2-support's CDR decoder, working from the schema the file stores, get every type's values back."""
    items = [(f"types/{t.replace('/', '_')}", sample_message(t)) for t in TOPIC_TYPES]
    items.append(("tf_static", msgs.get_type("tf2_msgs/msg/TFMessage")()))
    write_bag(tmp_path / "all", items)
    with open(tmp_path / "all" / "all.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[Ros2DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == len(items)
        assert all(s.encoding == "ros2msg" for s in summary.schemas.values())
        channels = {c.topic: c for c in summary.channels.values()}
        assert all(c.message_encoding == "cdr" for c in channels.values())
        [qos] = yaml.safe_load(channels["/tf_static"].metadata["offered_qos_profiles"])
        assert qos["durability"] == "transient_local" and qos["reliability"] == "reliable"
        [record] = [m for m in reader.iter_metadata() if m.name == "rosbag2"]  # what ros2 bag info reads
        assert yaml.safe_load(record.metadata["serialized_metadata"])["message_count"] == len(items)
        decoded = [(channel.topic, schema.name, value, message.log_time)
                   for schema, channel, message, value in reader.iter_decoded_messages(log_time_order=True)]
    assert [(topic, name) for topic, name, _, _ in decoded] == [("/" + k, m._type) for k, m in items]
    for (_, msg), (_, name, value, _) in zip(items, decoded):
        assert same(plain_from_decoded(name, value), msgs.to_dict(msg)), name


def test_sqlite3_bag_read_with_plain_sqlite(tmp_path: Path) -> None:
    """``-s sqlite3`` bags hold rosbag2's tables: read with Python's sqlite3 (no rosbags reader), each
    payload decoded by rosbags' CDR from the definition the file stores, to the values written."""
    items = [(f"types/{t.replace('/', '_')}", sample_message(t)) for t in TOPIC_TYPES]
    writer = BagWriter(tmp_path / "db", storage="sqlite3")
    for i, (key, msg) in enumerate(items):
        assert writer.write(key, msg, 1_000 + i)
    writer.close()
    assert sorted(os.listdir(tmp_path / "db")) == ["db.db3", "metadata.yaml"]
    with sqlite3.connect(tmp_path / "db" / "db.db3") as db:
        topics = {row[0]: row[1:] for row in db.execute(
            "SELECT id, name, type, serialization_format, offered_qos_profiles, type_description_hash FROM topics")}
        definitions = {row[0]: row[1:] for row in db.execute(
            "SELECT topic_type, encoding, encoded_message_definition, type_description_hash "
            "FROM message_definitions")}
        rows = db.execute("SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp").fetchall()
    assert len(rows) == len(items)
    for i, ((key, msg), (topic_id, timestamp, data)) in enumerate(zip(items, rows)):
        name, type_name, fmt, qos, type_hash = topics[topic_id]
        assert timestamp == 1_000 + i
        assert (name, type_name, fmt) == ("/" + key, msg._type, "cdr") and type_hash == rihs01(msg._type)
        assert yaml.safe_load(qos)[0]["reliability"] == "reliable"
        encoding, definition, _ = definitions[type_name]
        assert encoding == "ros2msg"
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(definition, type_name))
        value = store.deserialize_cdr(bytes(data), type_name)
        assert same(plain_from_decoded(type_name, value), msgs.to_dict(msg)), type_name
    assert [m.msg for m in read_bag(tmp_path / "db")] == [m for _, m in items]
    assert open_bag(tmp_path / "db").info()["storage"] == "sqlite3"


def test_single_mcap_file_stays_a_single_file(tmp_path: Path) -> None:
    js = msgs.get_type("sensor_msgs/msg/JointState")
    write_bag(tmp_path / "one.mcap", [("j", js(name=["a"], position=[1.0]))])
    assert os.listdir(tmp_path) == ["one.mcap"]
    with AnyReader([tmp_path / "one.mcap"]) as reader:
        [(conn, _, raw)] = list(reader.messages())
        assert list(reader.deserialize(raw, conn.msgtype).position) == [1.0]
    assert open_bag(tmp_path / "one.mcap").info()["messages"] == 1
    with pytest.raises(FileExistsError):
        BagWriter(tmp_path / "one.mcap")
    with pytest.raises(ValueError, match="storage: a .mcap file is MCAP storage, not sqlite3"):
        BagWriter(tmp_path / "two.mcap", storage="sqlite3")


def test_directory_without_metadata_still_opens(tmp_path: Path) -> None:
    """What zenroid wrote before rosbag2 metadata (and what a killed ros2 bag record leaves)."""
    js = msgs.get_type("sensor_msgs/msg/JointState")
    write_bag(tmp_path / "old", [("j", js(name=["a"], position=[float(i)])) for i in range(4)])
    (tmp_path / "old" / "metadata.yaml").unlink()
    bag = open_bag(tmp_path / "old")
    assert not bag.has_metadata_file and bag.info()["messages"] == 4
    assert [m.msg.position for m in bag.messages()] == [[0.0], [1.0], [2.0], [3.0]]


def rosbags_bag(path: Path, storage: StoragePlugin, compression: CompressionMode | None = None) -> list[Any]:
    """A bag written by rosbags: JointStates on two topics plus a statistics data point (a type zenroid does not define)."""
    js = JAZZY.types["sensor_msgs/msg/JointState"]
    header = JAZZY.types["std_msgs/msg/Header"]
    stamp = JAZZY.types["builtin_interfaces/msg/Time"]
    writer = Rosbag2Writer(path, version=9, storage_plugin=storage)
    if compression is not None:
        writer.set_compression(compression, CompressionFormat.ZSTD)
    sent = []
    with writer:
        a = writer.add_connection("/humanoid/joint_states", js.__msgtype__, typestore=JAZZY)
        b = writer.add_connection("/other/joint_states", js.__msgtype__, typestore=JAZZY)
        other = writer.add_connection("/temperature", UNDEFINED_TYPE, typestore=JAZZY)
        for i in range(6):
            m = js(header=header(stamp=stamp(sec=i, nanosec=7), frame_id="base"), name=["l", "r"],
                   position=np.array([0.1 * i, -0.1 * i]), velocity=np.array([1.0, 2.0]),
                   effort=np.array([], dtype=np.float64))
            conn = a if i % 2 == 0 else b
            t = 10**18 + i * 50_000_000
            writer.write(conn, t, JAZZY.serialize_cdr(m, js.__msgtype__))
            sent.append((conn.topic, t, m))
        writer.write(other, 10**18, undefined_type_cdr())
    return sent


@pytest.mark.parametrize("storage,compression", [
    (StoragePlugin.MCAP, None), (StoragePlugin.SQLITE3, None), (StoragePlugin.MCAP, CompressionMode.FILE),
    (StoragePlugin.MCAP, CompressionMode.MESSAGE), (StoragePlugin.SQLITE3, CompressionMode.FILE),
    (StoragePlugin.SQLITE3, CompressionMode.MESSAGE)], ids=lambda v: getattr(v, "name", "none"))
def test_reads_bags_written_by_rosbags(tmp_path: Path, storage: StoragePlugin,
                                       compression: CompressionMode | None) -> None:
    sent = rosbags_bag(tmp_path / "theirs", storage, compression)
    bag = open_bag(tmp_path / "theirs")
    info = bag.info()
    assert info["storage"] == storage.name.lower() and info["messages"] == 7
    assert {t["topic"]: t["count"] for t in info["topics"]} == {"/humanoid/joint_states": 3,
                                                                "/other/joint_states": 3, "/temperature": 1}
    unknown: list[tuple[str, str]] = []
    got = list(bag.messages(on_unknown=lambda topic, reason: unknown.append((topic, reason))))
    assert [u[0] for u in unknown] == ["/temperature"] and UNDEFINED_TYPE in unknown[0][1]
    assert [("/" + m.key, m.log_time_ns) for m in got] == [(topic, t) for topic, t, _ in sent]
    for item, (_, _, m) in zip(got, sent):
        assert item.msg.header.stamp.sec == m.header.stamp.sec and item.msg.header.stamp.nanosec == 7
        assert item.msg.header.frame_id == "base" and item.msg.name == ["l", "r"]
        assert item.msg.position == list(m.position) and item.msg.velocity == [1.0, 2.0] and item.msg.effort == []
    only = [m.key for m in bag.messages(["humanoid/joint_states"])]
    assert only == ["humanoid/joint_states"] * 3
    with pytest.raises(BagError, match="/temperature.*" + UNDEFINED_TYPE):
        list(bag.messages())


@pytest.mark.parametrize("mutate,expected", [
    (lambda d: d.pop("rosbag2_bagfile_information"), "metadata key is missing.*rosbag2_bagfile_information"),
    (lambda d: d["rosbag2_bagfile_information"].update(version=12), "version 12 not supported"),
    (lambda d: d["rosbag2_bagfile_information"].update(storage_identifier="rosbag_v1"),
     "Storage plugin 'rosbag_v1' not supported"),
    (lambda d: d["rosbag2_bagfile_information"].update(relative_file_paths=["gone.mcap"]),
     "files are missing.*gone.mcap"),
    (lambda d: d["rosbag2_bagfile_information"].update(compression_mode="file", compression_format="lz4"),
     "Compression format 'lz4' is not supported"),
    (lambda d: d["rosbag2_bagfile_information"]["topics_with_message_count"][0]["topic_metadata"].pop("type"),
     "metadata key is missing.*'type'"),
    (lambda d: d["rosbag2_bagfile_information"].update(message_count="many"),
     "message_count, starting_time, duration: expected integers"),
])
def test_bad_metadata_is_a_clear_error(tmp_path: Path, mutate: Any, expected: str) -> None:
    js = msgs.get_type("sensor_msgs/msg/JointState")
    write_bag(tmp_path / "b", [("j", js())])
    path = tmp_path / "b" / "metadata.yaml"
    doc = yaml.safe_load(path.read_text())
    mutate(doc)
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(BagError, match=expected):
        open_bag(tmp_path / "b")


def test_garbage_is_a_clear_error(tmp_path: Path) -> None:
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "metadata.yaml").write_text("rosbag2_bagfile_information: [unclosed")
    with pytest.raises(BagError, match="Could not load YAML"):
        open_bag(tmp_path / "b")
    (tmp_path / "x.db3").write_bytes(b"SQLite format 3\x00" + os.urandom(100))
    with pytest.raises(BagError, match="not a readable rosbag2 sqlite3 file"):
        open_bag(tmp_path / "x.db3")
    (tmp_path / "x.txt").write_text("hello")
    with pytest.raises(BagError, match="unknown file format"):
        open_bag(tmp_path / "x.txt")


def test_a_bags_own_definition_decodes_its_payloads(tmp_path: Path) -> None:
    """A type the bag defines otherwise than we do (another distro's): its payloads decode by the bag's
    definition and map onto ours field by field; a field of ours the bag's type lacks is a clear error."""
    js = "sensor_msgs/msg/JointState"
    ours = full_definition(js)
    assert "string[] name\n" in ours.split("=" * 80)[0] and "float64[] effort\n" in ours.split("=" * 80)[0]
    wider = ours.replace("string[] name\n", "string[] name\nuint32 extra\n", 1)  # read as ours: garbage
    narrower = ours.replace("float64[] effort\n", "", 1)
    for name, definition, fields in (("wider", wider, {"effort": np.array([3.0]), "extra": 7}),
                                     ("narrower", narrower, {})):
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(definition, js))
        stamp = store.types["builtin_interfaces/msg/Time"](sec=4, nanosec=5)
        value = store.types[js](header=store.types["std_msgs/msg/Header"](stamp=stamp, frame_id="f"),
                                name=["a"], position=np.array([1.0]), velocity=np.array([2.0]), **fields)
        with Rosbag2Writer(tmp_path / name, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            conn = writer.add_connection("/j", js, msgdef=definition, rihs01=store.hash_rihs01(js))
            writer.write(conn, 10, store.serialize_cdr(value, js))
    [got] = list(open_bag(tmp_path / "wider").messages())
    assert got.key == "j" and got.msg.header.stamp.sec == 4 and got.msg.header.frame_id == "f"
    assert (got.msg.name, got.msg.position, got.msg.velocity, got.msg.effort) == (["a"], [1.0], [2.0], [3.0])
    with pytest.raises(BagError, match="topic /j: the bag's sensor_msgs/msg/JointState lacks a field.*effort"):
        list(open_bag(tmp_path / "narrower").messages())


def test_storing_takes_only_what_was_queued_so_a_fast_stream_cannot_hold_the_recorder(tmp_path: Path) -> None:
    """Messages arriving while the recorder writes wait for its next round: otherwise a stream faster
    than the disk keeps it writing forever and past its duration and Ctrl-C checks."""
    arrived: queue.SimpleQueue[tuple[str, Any, int]] = queue.SimpleQueue()
    msg = sample_message("std_msgs/msg/String")
    for stamp in range(5):
        arrived.put(("chatter", msg, stamp))
    writer = BagWriter(tmp_path / "bag")
    write = writer.write

    def write_while_more_arrive(key: str, message: Any, stamp: int) -> bool:
        arrived.put((key, message, stamp + 100))
        return write(key, message, stamp)

    writer.write = write_while_more_arrive  # type: ignore[method-assign]
    assert not _store(arrived, writer, {}, max_messages=0)
    assert writer.count == 5 and arrived.qsize() == 5
    assert _store(arrived, writer, {}, max_messages=8)
    assert writer.count == 8
    writer.close()
