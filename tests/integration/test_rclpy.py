"""ROS 2 Python programs (rclpy) run unchanged on zenroid: real processes over real Zenoh, and each also seen
by zenoh-ros2-sdk (an independent rmw_zenoh client) to show a ROS 2 node would see it."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import ROOT, wait_until
from tests.support.ros_shim import shim_env

PROGRAMS = ROOT / "tests" / "support" / "rclpy_programs"


@pytest.fixture
def ros_env(tmp_path: Path) -> dict[str, str]:
    """Extra environment for the programs: the ROS module names when they are not importable yet."""
    from bench.common import child_env

    return shim_env(tmp_path / "shim", child_env()["PYTHONPATH"])


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl_c", "sigterm"])
def test_talker_and_listener_as_written(processes, ros_env, signum) -> None:
    """The listener spins its one subscription (its spinning thread waits in Zenoh's receive itself) and
    ends cleanly on Ctrl-C and on SIGTERM, at once: a shutdown from the signal handler, which runs inside
    that receive, once waited 5 s for the receive to let go of the subscription."""
    talker = processes.start(str(PROGRAMS / "talker.py"), name="talker", env=ros_env)
    listener = processes.start(str(PROGRAMS / "listener.py"), name="listener", env=ros_env)
    wait_until(lambda: 'I heard: "Hello World: ' in processes.output(listener), timeout=30,
               message="the listener hearing the talker\n" + processes.output(talker)[-2000:])
    first = processes.output(talker).splitlines()[0]
    assert "rclpy (zenroid, no ROS) connected to tcp/127.0.0.1:" in first, first
    sent = time.monotonic()
    listener.send_signal(signum)   # the program ends itself, cleanly
    assert listener.wait(timeout=15) == 0, processes.output(listener)
    assert time.monotonic() - sent < 4.0, f"the listener took {time.monotonic() - sent:.1f} s to end"
    assert "Traceback" not in processes.output(listener), processes.output(listener)


def test_zenroid_run_passes_ros_args(processes, ros_env) -> None:
    """``zenroid run FILE --ros-args -r __node:= -r topic:=`` renames the node and remaps its topic."""
    listener = processes.start("-m", "nodes.tools.cli", "run", str(PROGRAMS / "listener.py"), "--ros-args",
                               "-r", "__node:=renamed", "-r", "topic:=chatter", name="listener", env=ros_env)
    talker = processes.start(str(PROGRAMS / "talker.py"), "--ros-args", "-r", "topic:=/chatter",
                             "--log-level", "warn", name="talker", env=ros_env)
    wait_until(lambda: "[renamed]: I heard" in processes.output(listener), timeout=30,
               message="the renamed listener on the remapped topic\n" + processes.output(listener)[-2000:])
    assert "Publishing" not in processes.output(talker)   # --log-level warn


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl_c", "sigterm"])
def test_no_router_says_so_once_and_a_signal_ends_it(tmp_path, ros_env, signum) -> None:
    """Waiting for its router, a program ends on Ctrl-C and on SIGTERM (what a launcher or `kill` sends)."""
    from bench.common import child_env, free_port

    env = child_env({**ros_env, "ZENOH_CONNECT": f"tcp/127.0.0.1:{free_port()}"})
    log = tmp_path / "talker.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen([sys.executable, str(PROGRAMS / "talker.py")], env=env, stdout=out,
                                stderr=subprocess.STDOUT)
    try:
        wait_until(lambda: "waiting for a Zenoh router" in log.read_text(), timeout=60,
                   message="the waiting line")
        time.sleep(2.0)   # still waiting: said once only
        proc.send_signal(signum)
        status = proc.wait(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
    text = log.read_text()
    assert text.count("waiting for a Zenoh router") == 1, text
    assert "zenroid router" in text, text
    if signum == signal.SIGTERM:
        assert status == 128 + signal.SIGTERM and "Traceback" not in text, (status, text)


def test_keep_last_depth_keeps_the_newest_for_a_slow_callback(processes, ros_env, session) -> None:
    """A KEEP_LAST depth bounds what waits for a slow spinning thread, as rmw_zenoh's queue does: a burst of
    200 to a 50 ms callback with depth 5 delivers the first message (taken at once), then only the newest 5."""
    import msgs
    from nodes.core import Node

    Int32 = msgs.get_type("std_msgs/msg/Int32")
    listener = processes.start(str(PROGRAMS / "slow_listener.py"), "5", name="slow_listener", env=ros_env)
    wait_until(lambda: "ready" in processes.output(listener), timeout=30, message="the slow listener")
    talker = Node("burst_talker", session=session)
    try:
        pub = talker.create_publisher(Int32, "/burst")
        wait_until(lambda: pub.has_subscribers, timeout=15, message="the listener matched")
        time.sleep(0.3)   # its routes settle
        for i in range(200):
            pub.publish(Int32(data=i))
        wait_until(lambda: "took 199" in processes.output(listener), timeout=30,
                   message="the last message taken\n" + processes.output(listener)[-2000:])
        time.sleep(0.5)   # nothing else is on its way
    finally:
        talker.destroy()
    taken = [int(line.split()[1]) for line in processes.output(listener).splitlines() if line.startswith("took ")]
    assert taken[-5:] == [195, 196, 197, 198, 199], taken
    assert len(taken) <= 5 + 3, f"depth 5 should keep the newest 5 behind the callback, took {taken}"


def spin_until(executor, done, timeout: float) -> None:
    """Spin until ``done()`` or ``timeout`` s, then a moment more: whatever else was on its way arrives too."""
    deadline = time.monotonic() + timeout
    while not done() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.2)
    executor.spin_once(timeout_sec=0.3)


def test_transient_local_reaches_a_late_subscription(context, session) -> None:
    import msgs
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile

    String = msgs.get_type("std_msgs/msg/String")
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    talker = rclpy.create_node("latched_talker", context=context)
    talker.create_publisher(String, "/config", latched).publish(String(data="set once"))
    listener = rclpy.create_node("late_listener", context=context)
    got = []
    listener.create_subscription(String, "/config", got.append, latched)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(listener)
    spin_until(executor, lambda: got, 10)
    assert [m.data for m in got] == ["set once"]


@pytest.mark.parametrize("history", ["keep_last", "keep_all"])
def test_transient_local_keeps_its_depth_for_late_joiners_here_and_on_the_ros2_wire(context, session, history) -> None:
    """A TRANSIENT_LOCAL publisher of depth 3 keeps its last 3 messages: a late subscription of depth 3 gets
    them oldest first, one of depth 1 the newest, and rmw_zenoh's way of joining late (zenoh-ext's advanced
    subscriber querying the publisher's cache) gets the same 3 as CDR that rosbags decodes. KEEP_ALL keeps
    the depth too, as rmw_zenoh sizes its publisher cache and its subscriber's history."""
    import zenoh.ext
    from rosbags.typesys import Stores, get_typestore

    import msgs
    import rclpy
    from nodes.core.ros2 import names
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile

    kept = HistoryPolicy.KEEP_ALL if history == "keep_all" else HistoryPolicy.KEEP_LAST
    String = msgs.get_type("std_msgs/msg/String")
    talker = rclpy.create_node("history_talker", context=context)
    publisher = talker.create_publisher(String, "/plan", QoSProfile(depth=3, history=kept,
                                                                    durability=DurabilityPolicy.TRANSIENT_LOCAL))
    for step in range(5):
        publisher.publish(String(data=f"step {step}"))
    listener = rclpy.create_node("late_planner", context=context)
    got: dict[int, list[str]] = {3: [], 1: []}
    for depth, into in got.items():
        listener.create_subscription(String, "/plan", lambda m, into=into: into.append(m.data),
                                     QoSProfile(depth=depth, history=kept, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(listener)
    spin_until(executor, lambda: len(got[3]) >= 3 and got[1], 10)
    assert got == {3: ["step 2", "step 3", "step 4"], 1: ["step 4"]}, got

    cdr: list[bytes] = []
    ros_sub = zenoh.ext.declare_advanced_subscriber(
        session, names.data_key(0, "/plan", "std_msgs/msg/String"), lambda s: cdr.append(s.payload.to_bytes()),
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True))
    try:
        wait_until(lambda: len(cdr) >= 3, timeout=20, message="the 3 cached messages on the ROS 2 wire")
        time.sleep(0.3)
    finally:
        ros_sub.undeclare()
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    assert [jazzy.deserialize_cdr(data, "std_msgs/msg/String").data for data in cdr] == ["step 2", "step 3", "step 4"]


def test_a_late_transient_local_subscription_gets_a_ros2_publishers_cache(context, session) -> None:
    """The other way: a ROS 2 publisher on rmw_zenoh (zenoh-ext's advanced publisher with a cache of its depth,
    its MP liveliness token) published 4 messages before our rclpy subscription existed; a TRANSIENT_LOCAL
    subscription of depth 2 gets the newest 2, as it would from a DDS publisher's history."""
    import zenoh
    import zenoh.ext
    from rosbags.typesys import Stores, get_typestore

    import msgs
    import rclpy
    from nodes.core.ros2 import attachment, names
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile

    type_name = "std_msgs/msg/String"
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    qos = names.Qos(transient_local=True, depth=3)
    token = session.liveliness().declare_token(names.endpoint_token(
        0, str(session.info.zid()), 0, 1, names.PUBLISHER, "/", "ros_talker", "/ros_plan", type_name, qos))
    ros_pub = zenoh.ext.declare_advanced_publisher(
        session, names.data_key(0, "/ros_plan", type_name), encoding=zenoh.Encoding("application/cdr"),
        cache=zenoh.ext.CacheConfig(max_samples=3), publisher_detection=True,
        sample_miss_detection=zenoh.ext.MissDetectionConfig())
    try:
        String = jazzy.types[type_name]
        for step in range(4):
            ros_pub.put(bytes(jazzy.serialize_cdr(String(data=f"ros {step}"), type_name)),
                        attachment=attachment.pack(step + 1, bytes(range(16))))
        listener = rclpy.create_node("late_ros_listener", context=context)
        got: list[str] = []
        listener.create_subscription(msgs.get_type(type_name), "/ros_plan", lambda m: got.append(m.data),
                                     QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(listener)
        spin_until(executor, lambda: len(got) >= 2, 15)
        assert got == ["ros 2", "ros 3"], got
    finally:
        ros_pub.undeclare()
        token.undeclare()


def test_a_raising_callback_ends_spin_and_bad_messages_are_refused_here(context) -> None:
    import msgs
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    JointState = msgs.get_type("sensor_msgs/msg/JointState")
    node = rclpy.create_node("raiser", context=context)
    publisher = node.create_publisher(JointState, "/js", 10)
    with pytest.raises(ValueError, match=r"position\[1\]: not a finite number"):
        publisher.publish(JointState(name=["a", "b"], position=[0.0, float("nan")]))
    with pytest.raises(TypeError, match="expects|expected"):
        publisher.publish(msgs.get_type("std_msgs/msg/String")(data="x"))

    fired = []

    def boom() -> None:
        fired.append(1)
        raise RuntimeError("callback failed")

    guard = node.create_guard_condition(boom)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    guard.trigger()
    with pytest.raises(RuntimeError, match="callback failed"):
        executor.spin()
    assert fired == [1]
    with pytest.raises(NotImplementedError, match=r"Node\.add_waitable .* docs/rclpy\.md"):
        node.add_waitable(None)


def test_names_resolve_as_rcl_does(context) -> None:
    import rclpy

    node = rclpy.create_node("resolver", namespace="/robot", context=context,
                             cli_args=["--ros-args", "-r", "/robot/cmd:=/other/cmd"])
    assert node.get_fully_qualified_name() == "/robot/resolver"
    assert node.resolve_topic_name("state") == "/robot/state"
    assert node.resolve_topic_name("/joint_states") == "/joint_states"
    assert node.resolve_topic_name("~/status") == "/robot/resolver/status"
    assert node.resolve_topic_name("cmd") == "/other/cmd"     # remapped after resolution
    from rclpy.exceptions import ParameterAlreadyDeclaredException

    with pytest.raises(ParameterAlreadyDeclaredException):
        node.declare_parameter("use_sim_time", True)
