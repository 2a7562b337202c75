"""zenroid bag record / info / play with real processes over a real router, checked against rosbags."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader as Rosbag2Reader
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Rosbag2Writer
from rosbags.typesys import Stores, get_typestore

import msgs
from nodes.bag.reader import read_bag
from nodes.core.delivery import Inline
from tests.conftest import ROOT, wait_until
from tests.support.samples import UNDEFINED_TYPE, undefined_type_cdr

JointState = msgs.get_type("sensor_msgs/msg/JointState")
JAZZY = get_typestore(Stores.ROS2_JAZZY)


def zenroid(router: str, *argv: str, timeout: float = 60) -> subprocess.CompletedProcess:
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "nodes.tools", *argv], capture_output=True, text=True, env=env,
                          timeout=timeout, cwd=ROOT)


def record_live(router: str, bag_dir: Path, count: int | None, storage: str = "mcap") -> tuple[list, int]:
    """Run ``zenroid bag record humanoid/** -o bag_dir -s storage --max-messages count`` against a live publisher
    (count None: no limit, stopped by SIGTERM 60 messages after it said it records); returns what the publisher sent and how
    many messages the recorder says it recorded."""
    from nodes.core import Node

    talker = Node("talker", namespace="humanoid", connect=[router])
    pub = talker.create_publisher(JointState, "joint_states")
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    limit = ["--max-messages", str(count)] if count is not None else []
    recorder = subprocess.Popen([sys.executable, "-m", "nodes.tools", "bag", "record", "humanoid/**", "-o",
                                 str(bag_dir), "-s", storage, *limit], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    sent = []
    try:
        ready = recorder.stdout.readline()  # "Recording ... (Ctrl-C to stop)": subscribed, SIGTERM handled
        assert "Recording" in ready, ready + recorder.stderr.read()
        for i in range(400):
            msg = JointState(name=["left_knee", "right_knee"], position=[0.01 * i, -0.01 * i],
                             velocity=[0.5, -0.5])
            msg.header.stamp = msgs.time_from_sec(i * 0.02)
            msg.header.frame_id = "pelvis"
            pub.publish(msg)
            sent.append(msg)
            time.sleep(0.02)
            if recorder.poll() is not None:
                break
            if count is None and i == 60:
                recorder.send_signal(signal.SIGTERM)
                break
        out, err = recorder.communicate(timeout=20)
        out = ready + out
    finally:
        if recorder.poll() is None:
            recorder.kill()
        talker.destroy()
    assert recorder.returncode == 0, err
    match = re.search(r"Recorded (\d+) messages", out)
    assert match, out
    recorded = int(match.group(1))
    assert recorded == count if count is not None else recorded > 10
    return sent, recorded


@pytest.mark.parametrize("storage,suffix", [("mcap", "mcap"), ("sqlite3", "db3")], ids=["mcap", "sqlite3"])
def test_record_info_and_play_round_trip(router, tmp_path, storage: str, suffix: str) -> None:
    bag_dir = tmp_path / "knees"
    sent, _ = record_live(router, bag_dir, 40, storage)

    info = zenroid(router, "bag", "info", str(bag_dir))
    assert info.returncode == 0, info.stderr
    assert "Topic: /humanoid/joint_states | Type: sensor_msgs/msg/JointState | Count: 40" in info.stdout
    assert f"Storage id:        {storage}" in info.stdout and f"Files:             knees.{suffix}" in info.stdout
    recorded = [m.msg for m in read_bag(bag_dir)]
    assert len(recorded) == 40
    first = sent.index(recorded[0])  # the bag holds a contiguous run of what was sent, bit for bit
    assert recorded == sent[first:first + 40]

    played = []
    from nodes.core import Node

    listener = Node("listener", connect=[router])
    listener.create_subscription(JointState, "/humanoid/joint_states", played.append, delivery=Inline())
    try:
        time.sleep(0.3)
        result = zenroid(router, "bag", "play", str(bag_dir), "--rate", "4", "--quiet")
        assert result.returncode == 0, result.stderr
        wait_until(lambda: len(played) >= 40, timeout=10, message="40 played messages")
    finally:
        listener.destroy()
    assert played == recorded


def test_recorded_bag_is_a_rosbag2_bag_for_rosbags(router, tmp_path) -> None:
    """The directory recorded from a live publisher (and stopped by SIGTERM, as a launcher stops it):
    rosbag2's metadata.yaml, and rosbags (its own reader and its own CDR deserializer, nothing of ours)
    decodes every message to what was sent."""
    bag_dir = tmp_path / "walk"
    sent, n = record_live(router, bag_dir, None)
    assert sorted(os.listdir(bag_dir)) == ["metadata.yaml", "walk.mcap"]

    with AnyReader([bag_dir]) as reader:
        assert [(c.topic, c.msgtype) for c in reader.connections] == [("/humanoid/joint_states",
                                                                       "sensor_msgs/msg/JointState")]
        decoded = [(t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    assert len(decoded) == n
    stamps = [(m.header.stamp.sec, m.header.stamp.nanosec) for _, m in decoded]
    first = [(s.header.stamp.sec, s.header.stamp.nanosec) for s in sent].index(stamps[0])
    for (_, theirs), ours in zip(decoded, sent[first:first + n]):
        assert (theirs.header.stamp.sec, theirs.header.stamp.nanosec) == (ours.header.stamp.sec,
                                                                          ours.header.stamp.nanosec)
        assert theirs.header.frame_id == "pelvis" and theirs.name == ["left_knee", "right_knee"]
        assert list(theirs.position) == ours.position and list(theirs.velocity) == [0.5, -0.5]
        assert len(theirs.effort) == 0
    times = [t for t, _ in decoded]

    info = yaml.safe_load((bag_dir / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == ["walk.mcap"] and info["message_count"] == n
    assert info["starting_time"]["nanoseconds_since_epoch"] == times[0]
    assert info["duration"]["nanoseconds"] == times[-1] - times[0]
    assert info["files"][0]["path"] == "walk.mcap" and info["files"][0]["message_count"] == n
    [topic] = info["topics_with_message_count"]
    assert topic["message_count"] == n
    assert topic["topic_metadata"]["name"] == "/humanoid/joint_states"
    assert topic["topic_metadata"]["type"] == "sensor_msgs/msg/JointState"
    assert topic["topic_metadata"]["serialization_format"] == "cdr"
    assert topic["topic_metadata"]["type_description_hash"] == JAZZY.hash_rihs01("sensor_msgs/msg/JointState")
    assert topic["topic_metadata"]["offered_qos_profiles"][0]["reliability"] == "reliable"

    with Rosbag2Reader(bag_dir) as reader:
        assert reader.message_count == n and reader.start_time == times[0]
        [conn] = reader.connections
        assert conn.digest == JAZZY.hash_rihs01("sensor_msgs/msg/JointState") and conn.msgcount == n


def _rosbags_bag(path: Path, storage: StoragePlugin) -> list[tuple[float, object]]:
    """JointStates at irregular times over 3 s, plus a statistics data point (a type zenroid does not define)."""
    js = JAZZY.types["sensor_msgs/msg/JointState"]
    header = JAZZY.types["std_msgs/msg/Header"]
    stamp = JAZZY.types["builtin_interfaces/msg/Time"]
    offsets = [0.0, 0.1, 0.4, 0.5, 1.2, 1.3, 2.0, 2.9, 3.0]
    t0 = time.time_ns()
    sent = []
    with Rosbag2Writer(path, version=9, storage_plugin=storage) as writer:
        conn = writer.add_connection("/humanoid/joint_states", js.__msgtype__, typestore=JAZZY)
        other = writer.add_connection("/humanoid/temperature", UNDEFINED_TYPE, typestore=JAZZY)
        for i, off in enumerate(offsets):
            m = js(header=header(stamp=stamp(sec=100 + i, nanosec=250), frame_id="base"), name=["a", "b"],
                   position=np.array([0.3 * i, -0.2 * i]), velocity=np.array([], dtype=np.float64),
                   effort=np.array([1.5, 2.5]))
            writer.write(conn, t0 + int(off * 1e9), JAZZY.serialize_cdr(m, js.__msgtype__))
            sent.append((off, m))
        writer.write(other, t0 + 5_000_000, undefined_type_cdr())
    return sent


@pytest.mark.parametrize("storage", [StoragePlugin.MCAP, StoragePlugin.SQLITE3], ids=["mcap", "sqlite3"])
def test_plays_bags_written_by_rosbags(router, tmp_path, storage: StoragePlugin) -> None:
    """A rosbag2 directory written by rosbags plays here: every message with its values, in order, with
    the original timing scaled by --rate; the statistics topic (a type we do not define) is skipped, said so."""
    from nodes.core import Node

    rate = 3.0
    bag_dir = tmp_path / "theirs"
    sent = _rosbags_bag(bag_dir, storage)
    info = zenroid(router, "bag", "info", str(bag_dir))
    assert info.returncode == 0, info.stderr
    assert f"Storage id:        {storage.name.lower()}" in info.stdout
    assert "Topic: /humanoid/joint_states | Type: sensor_msgs/msg/JointState | Count: 9" in info.stdout

    received: list[tuple[float, object]] = []
    listener = Node("listener", connect=[router])
    listener.create_subscription(JointState, "/humanoid/joint_states",
                                 lambda m: received.append((time.monotonic(), m)), delivery=Inline())
    try:
        time.sleep(0.3)
        result = zenroid(router, "bag", "play", str(bag_dir), "--rate", str(rate), "--quiet")
        assert result.returncode == 0, result.stderr
        assert "Played 9 messages" in result.stdout
        assert "not played: /humanoid/temperature" in result.stderr and UNDEFINED_TYPE in result.stderr
        wait_until(lambda: len(received) >= len(sent), timeout=10, message="every played message")
    finally:
        listener.destroy()
    assert len(received) == len(sent)
    for (_, ours), (_, theirs) in zip(received, sent):
        assert ours.header.stamp.sec == theirs.header.stamp.sec and ours.header.stamp.nanosec == 250
        assert ours.header.frame_id == "base" and ours.name == ["a", "b"]
        assert ours.position == list(theirs.position) and ours.velocity == [] and ours.effort == [1.5, 2.5]
    # Timing: a message is never published before its scaled time (small slack for delivery jitter of
    # the first one); the whole run takes about 3 s / rate, far from the unscaled 3 s.
    t_first = received[0][0]
    for (t, _), (offset, _) in zip(received, sent):
        assert t - t_first >= offset / rate - 0.1
    assert received[-1][0] - t_first < sent[-1][0] / rate + 1.2


def test_bad_bags_are_clear_errors(router, tmp_path) -> None:
    missing = zenroid(router, "bag", "info", str(tmp_path / "nope"))
    assert missing.returncode == 2 and "no bag at" in missing.stderr
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"\x89MCAP0\r\n" + os.urandom(200))
    result = zenroid(router, "bag", "info", str(garbage))
    assert result.returncode == 2 and "not a readable MCAP bag" in result.stderr
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 9\n")
    result = zenroid(router, "bag", "play", str(broken))
    assert result.returncode == 2 and "metadata key is missing" in result.stderr
    assert "relative_file_paths" in result.stderr
    result = zenroid(router, "bag", "record")
    assert result.returncode == 2 and "name keys to record" in result.stderr
