"""zenroid bag record / info / play with real processes over a real router."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import msgs
from nodes.bag.mcap_file import read_bag
from tests.conftest import ROOT, wait_until

JointState = msgs.get_type("sensor_msgs/msg/JointState")


def zenroid(router: str, *argv: str, timeout: float = 60) -> subprocess.CompletedProcess:
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "nodes.tools", *argv], capture_output=True, text=True, env=env,
                          timeout=timeout, cwd=ROOT)


def test_record_info_and_play_round_trip(router, session, tmp_path) -> None:
    from nodes.core import Node

    talker = Node("talker", namespace="humanoid", connect=[router])
    pub = talker.create_publisher(JointState, "joint_states")
    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    bag_dir = tmp_path / "knees"
    recorder = subprocess.Popen([sys.executable, "-m", "nodes.tools", "bag", "record", "humanoid/**", "-o",
                                 str(bag_dir), "--max-messages", "40"], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    sent = []
    try:
        for i in range(400):
            msg = JointState(name=["left_knee", "right_knee"], position=[0.01 * i, -0.01 * i])
            msg.header.stamp = msgs.time_from_sec(i * 0.02)
            pub.publish(msg)
            sent.append(msg)
            time.sleep(0.02)
            if recorder.poll() is not None:
                break
        out, err = recorder.communicate(timeout=20)
    finally:
        if recorder.poll() is None:
            recorder.kill()
        talker.destroy()
    assert recorder.returncode == 0, err
    assert "Recorded 40 messages" in out

    info = zenroid(router, "bag", "info", str(bag_dir))
    assert info.returncode == 0, info.stderr
    assert "Topic: /humanoid/joint_states | Type: sensor_msgs/msg/JointState | Count: 40" in info.stdout
    recorded = [m.msg for m in read_bag(bag_dir)]
    assert len(recorded) == 40
    first = sent.index(recorded[0])  # the bag holds a contiguous run of what was sent, bit for bit
    assert recorded == sent[first:first + 40]

    played = []
    from nodes.core import Node as _Node

    listener = _Node("listener", connect=[router])
    listener.create_subscription(JointState, "/humanoid/joint_states", played.append, inline=True)
    try:
        time.sleep(0.3)
        result = zenroid(router, "bag", "play", str(bag_dir), "--rate", "4", "--quiet")
        assert result.returncode == 0, result.stderr
        wait_until(lambda: len(played) >= 40, timeout=10, message="40 played messages")
    finally:
        listener.destroy()
    assert played == recorded


def test_bad_bags_are_clear_errors(router, tmp_path) -> None:
    missing = zenroid(router, "bag", "info", str(tmp_path / "nope"))
    assert missing.returncode == 2 and "no bag at" in missing.stderr
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"\x89MCAP0\r\n" + os.urandom(200))
    result = zenroid(router, "bag", "info", str(garbage))
    assert result.returncode == 2 and "not a readable MCAP bag" in result.stderr
    result = zenroid(router, "bag", "record")
    assert result.returncode == 2 and "name keys to record" in result.stderr
