"""A compatibility suite of ROS 2 Python programs (tests/support/rclpy_programs: ros2/examples, ros2/demos and
the rclpy docs, as written), each run as real processes over real Zenoh, and each also met by zenoh-ros2-sdk
(tests/support/ros2_peer.py, an independent rmw_zenoh client) to show a ROS 2 node would see it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import msgs
from bench.common import child_env
from msgs.type_hash import rihs01
from nodes.core import Node
from tests.conftest import ROOT, wait_until
from tests.support.ros_shim import DEFINITIONS, shim_env

pytestmark = pytest.mark.slow

PROGRAMS = ROOT / "tests" / "support" / "rclpy_programs"
PEER = ROOT / "tests" / "support" / "ros2_peer.py"
STRING_DEF = "string data\n"


@pytest.fixture
def ros_env(tmp_path: Path) -> dict[str, str]:
    env = shim_env(tmp_path / "shim", child_env()["PYTHONPATH"])
    if env:
        msgs.add_search_path(DEFINITIONS)   # this process computes the type hashes the peer announces
    return env


def peer(zenoh_port: int, *args: str, timeout: float = 60) -> list[dict]:
    """Run the zenoh-ros2-sdk peer to the end; its JSON lines."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ZENOH_CONNECT", "ROS_DOMAIN_ID")}
    done = subprocess.run([sys.executable, str(PEER), args[0], str(zenoh_port), *args[1:]], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=PEER.parent)
    assert done.returncode == 0, done.stdout + done.stderr
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def peer_in_background(zenoh_port: int, *args: str) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ZENOH_CONNECT", "ROS_DOMAIN_ID")}
    return subprocess.Popen([sys.executable, str(PEER), args[0], str(zenoh_port), *args[1:]], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=PEER.parent)


def listen_strings(zenoh_port: int, topic: str, seconds: float) -> list[str]:
    return [m["data"] for m in peer(zenoh_port, "listen", topic, "std_msgs/msg/String", STRING_DEF,
                                    rihs01("std_msgs/msg/String"), str(seconds))]


def zenroid(processes, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nodes.tools.cli", *args], capture_output=True, text=True,
                          env=processes.env(), cwd=ROOT, timeout=60)


def test_talker_listener_and_a_ros2_peer(processes, zenoh_port, ros_env) -> None:
    talker = processes.start(str(PROGRAMS / "talker.py"), name="talker", env=ros_env)
    heard = listen_strings(zenoh_port, "/topic", 4)
    assert any(h.startswith("Hello World: ") for h in heard), f"{heard}\n{processes.output(talker)[-1500:]}"
    listener = processes.start(str(PROGRAMS / "listener.py"), name="listener", env=ros_env)
    peer(zenoh_port, "talk", "/topic", "std_msgs/msg/String", STRING_DEF, rihs01("std_msgs/msg/String"),
         json.dumps({"data": "from ROS 2"}), "4")
    wait_until(lambda: 'I heard: "from ROS 2"' in processes.output(listener), timeout=20,
               message="the listener hearing the ROS 2 peer\n" + processes.output(listener)[-1500:])


def test_add_two_ints_sync_async_and_a_ros2_client(processes, zenoh_port, ros_env) -> None:
    server = processes.start(str(PROGRAMS / "add_two_ints_server.py"), name="server", env=ros_env)
    client = processes.start(str(PROGRAMS / "add_two_ints_client_async.py"), "2", "3", name="async", env=ros_env)
    assert client.wait(timeout=60) == 0, processes.output(client)
    assert "Result of add_two_ints: for 2 + 3 = 5" in processes.output(client)
    client = processes.start(str(PROGRAMS / "add_two_ints_client_sync.py"), name="sync", env=ros_env)
    assert client.wait(timeout=60) == 0, processes.output(client)
    assert "Result of add_two_ints: for 41 + 1 = 42" in processes.output(client)
    answer = peer(zenoh_port, "call", "/add_two_ints", "example_interfaces/srv/AddTwoInts", "int64 a\nint64 b\n",
                  "int64 sum\n", rihs01("example_interfaces/srv/AddTwoInts"), json.dumps({"a": 20, "b": 22}))
    assert answer and answer[-1]["sum"] == 42, answer
    assert "Incoming request\na: 20 b: 22" in processes.output(server)


def test_fibonacci_action_with_feedback_and_cancel(processes, zenoh_port, ros_env) -> None:
    server = processes.start(str(PROGRAMS / "fibonacci_action_server.py"), name="server", env=ros_env)
    watcher = peer_in_background(
        zenoh_port, "listen", "/fibonacci/_action/feedback",
        "action_tutorials_interfaces/action/Fibonacci_FeedbackMessage",
        "unique_identifier_msgs/UUID goal_id\naction_tutorials_interfaces/Fibonacci_Feedback feedback\n"
        "================================================================================\n"
        "MSG: unique_identifier_msgs/UUID\nuint8[16] uuid\n"
        "================================================================================\n"
        "MSG: action_tutorials_interfaces/Fibonacci_Feedback\nint32[] partial_sequence\n",
        rihs01("action_tutorials_interfaces/action/Fibonacci_FeedbackMessage"), "12")
    client = processes.start(str(PROGRAMS / "fibonacci_action_client.py"), name="client", env=ros_env)
    assert client.wait(timeout=60) == 0, processes.output(client) + processes.output(server)[-2000:]
    out = processes.output(client)
    assert "Goal accepted :)" in out and "Received feedback: [0, 1, 1]" in out, out
    assert "Result: [0, 1, 1, 2, 3, 5, 8, 13, 21, 34, 55]" in out, out
    canceling = processes.start(str(PROGRAMS / "fibonacci_action_client.py"), "cancel", name="cancel", env=ros_env)
    assert canceling.wait(timeout=60) == 0, processes.output(canceling)
    out = processes.output(canceling)
    assert "Goal successfully canceled" in out and "Goal canceled, status CANCELED" in out, out
    assert "Goal canceled" in processes.output(server)
    seen, errors = watcher.communicate(timeout=60)
    feedback = [json.loads(line) for line in seen.splitlines() if line.startswith("{")]
    assert any(f["feedback"]["partial_sequence"][:3] == [0, 1, 1] for f in feedback), seen[-1500:] + errors[-1500:]


def test_parameters_with_the_three_callbacks(processes, zenoh_port, ros_env) -> None:
    node = processes.start(str(PROGRAMS / "parameters.py"), "--ros-args", "-p", "gain:=1.5", name="gain",
                           env=ros_env)
    wait_until(lambda: "gain 1.5 mode idle" in processes.output(node), timeout=30,
               message="the override applied\n" + processes.output(node)[-1500:])
    tuner = processes.start(str(PROGRAMS / "parameter_client.py"), "2.5", name="tuner", env=ros_env)
    assert tuner.wait(timeout=60) == 0, processes.output(tuner)
    assert "set gain: successful=True" in processes.output(tuner)
    assert "gain values now [2.5, 5.0]" in processes.output(tuner)   # pre-set callback added gain_doubled
    assert "applied gain = 2.5" in processes.output(node)            # post-set callback
    refused = zenroid(processes, "param", "set", "/gain_node", "gain", "-1.0")
    assert refused.returncode != 0 and "gain must be >= 0" in refused.stdout + refused.stderr, refused
    read_only = zenroid(processes, "param", "set", "/gain_node", "mode", "run")
    assert read_only.returncode != 0 and "read-only" in read_only.stdout + read_only.stderr, read_only
    assert any(h.startswith("gain=2.5 doubled=5.0") for h in listen_strings(zenoh_port, "/gain", 3))


def test_lifecycle_talker_driven_by_zenroid_lifecycle(processes, zenoh_port, ros_env) -> None:
    talker = processes.start(str(PROGRAMS / "lifecycle_talker.py"), name="lc_talker", env=ros_env)
    wait_until(lambda: "lc_talker" in zenroid(processes, "lifecycle", "nodes").stdout, timeout=30,
               message="the lifecycle node listed")
    for transition in ("configure", "activate"):
        done = zenroid(processes, "lifecycle", "set", "/lc_talker", transition)
        assert done.returncode == 0, done.stdout + done.stderr + processes.output(talker)[-1500:]
    assert "Lifecycle publisher is active" in processes.output(talker) or wait_until(
        lambda: "Lifecycle publisher is active" in processes.output(talker), timeout=10)
    heard = listen_strings(zenoh_port, "/lifecycle_chatter", 3)
    assert any(h.startswith("Lifecycle HelloWorld #") for h in heard), heard
    assert zenroid(processes, "lifecycle", "set", "/lc_talker", "deactivate").returncode == 0
    wait_until(lambda: "Lifecycle publisher is inactive" in processes.output(talker).rsplit("on_deactivate", 1)[-1],
               timeout=10, message="inactive after deactivate")
    assert not listen_strings(zenoh_port, "/lifecycle_chatter", 2)


def test_executors_with_callback_groups(processes, zenoh_port, ros_env) -> None:
    node = processes.start(str(PROGRAMS / "callback_groups.py"), name="groups", env=ros_env)
    wait_until(lambda: "answers=5 " in processes.output(node), timeout=60,
               message="a timer's service call answered five times\n" + processes.output(node)[-1500:])
    last = [line for line in processes.output(node).splitlines() if "answers=" in line][-1]
    assert "overlap=0" in last, last                       # an exclusive group never overlaps
    assert "reentrant_threads=1" not in last, last         # a reentrant group runs on several threads
    heard = listen_strings(zenoh_port, "/results", 3)
    assert any(h.startswith("answers=") for h in heard), heard


def test_use_sim_time_follows_the_clock(processes, router, zenoh_port, ros_env) -> None:
    import re

    Clock = msgs.get_type("rosgraph_msgs/msg/Clock")
    clock_node = Node("test_clock", connect=[router])
    publisher = clock_node.create_publisher(Clock, "/sim/clock")
    try:
        node = processes.start(str(PROGRAMS / "sim_time.py"), "--ros-args", "-p", "use_sim_time:=true",
                               name="sim_time", env=ros_env)
        wait_until(lambda: "connected to" in processes.output(node), timeout=60, message="the program started")
        sim = 100.0

        def ticked() -> list[float]:
            nonlocal sim
            sim += 0.05
            publisher.publish(Clock(clock=msgs.time_from_sec(sim)))
            return [float(t) for t in re.findall(r"sim now ([0-9.]+)", processes.output(node))]

        stamps = wait_until(ticked, timeout=60, interval=0.01, message="the node's timer on sim time")
        assert all(100.0 <= t <= sim + 1e-6 for t in stamps), (stamps, sim)   # sim time, not the wall clock
        assert "use_sim_time=True" in processes.output(node)
        heard = listen_strings(zenoh_port, "/sim_now", 0.5)
        assert all(h.startswith("sim now 1") for h in heard), heard
    finally:
        clock_node.destroy()


def test_fibonacci_with_coroutine_goal_and_cancel_callbacks(processes, ros_env) -> None:
    """``async def`` goal and cancel callbacks: each awaits a future before it answers; the goal is accepted
    and, while its execute callback blocks one thread, the cancel is decided on another."""
    server = processes.start(str(PROGRAMS / "fibonacci_async_callbacks_server.py"), name="server", env=ros_env)
    client = processes.start(str(PROGRAMS / "fibonacci_action_client.py"), "cancel", name="cancel", env=ros_env)
    assert client.wait(timeout=60) == 0, processes.output(client) + processes.output(server)[-2000:]
    out, served = processes.output(client), processes.output(server)
    assert "Goal accepted :)" in out and "Goal successfully canceled" in out, out
    assert "Goal canceled, status CANCELED" in out, out
    assert "Goal approved" in served and "Cancel approved" in served and "Goal canceled" in served, served
