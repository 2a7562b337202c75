"""The ROS 2 wire (rmw_zenoh) over real Zenoh: our nodes seen and driven by independent ROS 2 clients.

The ROS 2 side is played by zenoh-ros2-sdk (its CLI and the example client, in their own processes), by
rosbags (CDR) and by plain Zenoh sessions declaring rmw_zenoh tokens; never by our own decoder alone.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

import msgs
from msgs import cdr
from msgs.type_hash import rihs01
from nodes.core.node import Node
from nodes.core.ros2 import attachment, names
from tests.conftest import wait_until

ROOT = Path(__file__).resolve().parents[2]
JAZZY = get_typestore(Stores.ROS2_JAZZY)
JS = "sensor_msgs/msg/JointState"
JT = "trajectory_msgs/msg/JointTrajectory"


def ros_subscription_token(session: zenoh.Session, topic: str, type_name: str, domain: int = 0):
    """What a ROS 2 subscription announces (as rmw_zenoh / zenoh-ros2-sdk would), from a non-zenroid session."""
    zid = str(session.info.zid())
    return session.liveliness().declare_token(names.endpoint_token(
        domain, zid, 0, 1, names.SUBSCRIPTION, "/", "ros_listener", topic, type_name, names.DEFAULT_QOS))


def ros_tokens(session: zenoh.Session, pattern: str = "@ros2_lv/**") -> list[str]:
    return [str(r.ok.key_expr) for r in session.liveliness().get(pattern, timeout=1.0) if r.ok is not None]


def test_lazy_mirror_follows_foreign_subscribers_only(router, session):
    talker = Node("talker", namespace="humanoid", connect=[router])
    listener = Node("listener", namespace="humanoid", connect=[router])
    try:
        pub = talker.create_publisher(msgs.get_type(JS), "joint_states")
        listener.create_subscription(msgs.get_type(JS), "joint_states", lambda m: None)
        key = names.data_key(0, "/humanoid/joint_states", JS)
        wait_until(lambda: any("/MS/" in t and "joint_states" in t for t in ros_tokens(session)),
                   message="the listener's own MS token")
        time.sleep(0.3)
        assert not pub._mirror.active, "a zenroid subscriber must not switch CDR encoding on"
        received = []
        ros_sub = session.declare_subscriber(key, lambda s: received.append(s))  # kept: dropping undeclares
        token = ros_subscription_token(session, "/humanoid/joint_states", JS)
        wait_until(lambda: pub._mirror.active, message="mirror active with a ROS 2 subscriber")

        def sent() -> bool:
            pub.publish(msgs.get_type(JS)(name=["left_knee"], position=[0.25]))
            return bool(received)

        wait_until(sent, timeout=10, interval=0.1, message="CDR on the rmw_zenoh key")
        sample = received[0]
        decoded = JAZZY.deserialize_cdr(sample.payload.to_bytes(), JS)
        assert list(decoded.name) == ["left_knee"] and decoded.position.tolist() == [0.25]
        assert str(sample.encoding).startswith("application/cdr")
        att = attachment.unpack(sample.attachment.to_bytes())
        assert att is not None and att.sequence >= 1 and len(att.gid) == 16
        assert abs(att.timestamp_ns - time.time_ns()) < 60e9
        token.undeclare()
        ros_sub.undeclare()
        wait_until(lambda: not pub._mirror.active, message="mirror inactive once the ROS 2 subscriber left")
    finally:
        listener.destroy()
        talker.destroy()


def test_ros2_publisher_drives_our_subscription_once(router, session):
    commander = Node("commander", namespace="humanoid", connect=[router])
    controller = Node("controller", namespace="humanoid", connect=[router])
    got: list = []
    try:
        pub = commander.create_publisher(msgs.get_type(JT), "jtc/joint_trajectory")
        controller.create_subscription(msgs.get_type(JT), "jtc/joint_trajectory", got.append, inline=True)
        token = ros_subscription_token(session, "/humanoid/jtc/joint_trajectory", JT)  # CDR twins are on
        wait_until(lambda: pub._mirror.active, message="commander mirror active")
        time.sleep(0.3)
        wait_until(lambda: (pub.publish(msgs.get_type(JT)(joint_names=["a"])), got)[1], timeout=10, interval=0.2,
                   message="our own message")
        time.sleep(0.5)
        got.clear()
        pub.publish(msgs.get_type(JT)(joint_names=["ours"]))
        time.sleep(1.0)
        assert [m.joint_names for m in got] == [["ours"]], "our message must arrive once, not again as CDR"
        # A ROS 2 publisher: CDR (rosbags) with a foreign GID on the data key.
        Traj = JAZZY.types[JT]
        Header, Time = JAZZY.types["std_msgs/msg/Header"], JAZZY.types["builtin_interfaces/msg/Time"]
        raw = bytes(JAZZY.serialize_cdr(Traj(header=Header(stamp=Time(sec=0, nanosec=0), frame_id=""),
                                             joint_names=["from_ros"], points=[]), JT))
        ros_pub = session.declare_publisher(names.data_key(0, "/humanoid/jtc/joint_trajectory", JT))
        wait_until(lambda: (ros_pub.put(raw, attachment=attachment.pack(1, bytes(range(16)))),
                            any(m.joint_names == ["from_ros"] for m in got))[1],
                   timeout=10, interval=0.2, message="the ROS 2 message in our callback")
        token.undeclare()
    finally:
        controller.destroy()
        commander.destroy()


def test_service_answers_rmw_zenoh_queries_with_correlation(router, session):
    server = Node("server", connect=[router])
    trigger = msgs.get_type("std_srvs/srv/SetBool")
    try:
        server.create_service(trigger, "toggle", lambda req: trigger.Response(success=req.data, message="done"))
        threading.Thread(target=server.spin, daemon=True).start()  # handlers run on the node's executor
        key = names.data_key(0, "/toggle", "std_srvs/srv/SetBool")
        request = cdr.encode("std_srvs/srv/SetBool_Request", {"data": True})
        gid = bytes(range(16))

        def ask():
            for reply in session.get(key, payload=request, attachment=attachment.pack(41, gid),
                                     target=zenoh.QueryTarget.ALL_COMPLETE, timeout=2.0):
                return reply
            return None

        reply = wait_until(ask, timeout=10, interval=0.1, message="a reply on the service's data key")
        assert reply.ok is not None, reply.err.payload.to_bytes()
        assert cdr.decode("std_srvs/srv/SetBool_Response", reply.ok.payload.to_bytes()) == {"success": True, "message": "done"}
        att = attachment.unpack(reply.ok.attachment.to_bytes())
        assert (att.sequence, att.gid) == (41, gid)
        bad = list(session.get(key, payload=b"\x00\x01\x00\x00", attachment=attachment.pack(42, gid), timeout=2.0))
        assert bad and bad[0].err is not None and b"SetBool_Request" in bad[0].err.payload.to_bytes()
    finally:
        server.destroy()


def test_latched_topic_reaches_a_late_transient_local_subscriber(router, session):
    node = Node("robot_state_publisher", namespace="humanoid", connect=[router])
    try:
        pub = node.create_publisher(msgs.get_type("std_msgs/msg/String"), "robot_description", latched=True)
        pub.publish(msgs.get_type("std_msgs/msg/String")(data="<robot name='r'/>"))
        # A fresh session sees the graph in pieces: ask until the token shows.
        wait_until(lambda: any("robot_description" in t and t.endswith(names.LATCHED_QOS.token())
                               for t in ros_tokens(session, "@ros2_lv/0/*/*/*/MP/**")),
                   timeout=15, interval=0.2, message="a transient local MP token for robot_description")
        got: list[bytes] = []
        key = names.data_key(0, "/humanoid/robot_description", "std_msgs/msg/String")
        ros_sub = zenoh.ext.declare_advanced_subscriber(session, key, lambda s: got.append(s.payload.to_bytes()),
                                              history=zenoh.ext.HistoryConfig(detect_late_publishers=True))
        wait_until(lambda: got, timeout=20, message="the cached robot_description")
        ros_sub.undeclare()
        assert JAZZY.deserialize_cdr(got[0], "std_msgs/msg/String").data == "<robot name='r'/>"
    finally:
        node.destroy()


def test_ros2_wire_off_and_internal_keys(router, session, monkeypatch):
    node = Node("sim", connect=[router])
    try:
        node.create_publisher(msgs.get_type("zenroid_msgs/msg/HardwareState"), "humanoid/hardware/state")
        node.create_publisher(msgs.get_type(JS), "humanoid/joint_states")
        wait_until(lambda: any("joint_states" in t for t in ros_tokens(session)), timeout=15, interval=0.2,
                   message="the joint_states MP token")
        time.sleep(0.5)
        tokens = ros_tokens(session)
        assert not any("hardware" in t or "get_parameters" in t for t in tokens), tokens
    finally:
        node.destroy()
    monkeypatch.setenv("ZENROID_ROS2", "0")
    quiet = Node("quiet", connect=[router])
    try:
        quiet.create_publisher(msgs.get_type(JS), "joint_states")
        time.sleep(0.5)
        assert not any("quiet" in t for t in ros_tokens(session))
    finally:
        quiet.destroy()
    monkeypatch.setenv("ZENROID_ROS2", "1")
    monkeypatch.setenv("ROS_DOMAIN_ID", "7")
    other = Node("domain7", connect=[router])
    try:
        wait_until(lambda: any(t.startswith("@ros2_lv/7/") and t.endswith("/NN/%/%/domain7")
                               for t in ros_tokens(session)), timeout=15, interval=0.2, message="a domain 7 NN token")
    finally:
        other.destroy()


# ---------------------------------------------------------------- the main job, from outside


def _zenoh_ros2(port: int, *args: str) -> str:
    done = subprocess.run(["zenoh-ros2", "--router", f"127.0.0.1:{port}", "--no-daemon", "--timeout", "2", *args],
                          capture_output=True, text=True, timeout=60, cwd=ROOT)
    return done.stdout


@pytest.mark.slow
def test_main_job_seen_and_driven_by_ros2_clients(zenoh_port: int, tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("ZENOH_CONNECT", "ZENOH_CONFIG", "ROS_DOMAIN_ID")}
    out_path = tmp_path / "launch.out"
    with open(out_path, "wb") as out:
        launcher = subprocess.Popen(
            [sys.executable, "-m", "launch", "humanoid.yaml", "gui:=false", "mode:=lockstep", "commander:=none",
             f"zenoh_port:={zenoh_port}", "--log-dir", str(tmp_path / "logs")],
            cwd=ROOT, stdout=out, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    try:
        expected_topics = {
            "/humanoid/joint_states [sensor_msgs/msg/JointState]",
            "/humanoid/joint_trajectory_controller/controller_state [control_msgs/msg/JointTrajectoryControllerState]",
            "/humanoid/tf [tf2_msgs/msg/TFMessage]", "/clock [rosgraph_msgs/msg/Clock]",
            "/rosout [rcl_interfaces/msg/Log]", "/humanoid/robot_description [std_msgs/msg/String]",
        }
        listed: set[str] = set()

        def topics_listed() -> bool:
            assert launcher.poll() is None, out_path.read_text(errors="replace")
            listed.update(_zenoh_ros2(zenoh_port, "topic", "list", "-t").splitlines())
            return expected_topics <= listed  # a fresh session sees the graph in pieces: ask again

        wait_until(topics_listed, timeout=120, interval=1.0, message=f"ROS 2 topics; listed so far {sorted(listed)}")
        assert not any("hardware" in t for t in listed), listed
        services: set[str] = set()

        def services_listed() -> bool:
            services.update(_zenoh_ros2(zenoh_port, "service", "list", "-t").splitlines())
            return {"/humanoid/controller_manager/list_controllers [controller_manager_msgs/srv/ListControllers]",
                    "/humanoid/joint_trajectory_controller/follow_joint_trajectory/_action/send_goal "
                    "[control_msgs/action/FollowJointTrajectory_SendGoal]"} <= services

        wait_until(services_listed, timeout=60, interval=1.0, message=f"ROS 2 services; listed {sorted(services)}")

        # The outside client (imports nothing of ours): joint_states, /clock, list_controllers, a
        # JointTrajectory that bends the knees, a FollowJointTrajectory goal that straightens them.
        client = subprocess.run([sys.executable, str(ROOT / "examples" / "ros2_client.py"),
                                 "--router", f"127.0.0.1:{zenoh_port}", "--timeout", "60"],
                                capture_output=True, text=True, timeout=400, cwd=tmp_path,
                                env={k: v for k, v in env.items() if k != "PYTHONPATH"})
        assert client.returncode == 0, client.stdout + client.stderr + out_path.read_text(errors="replace")
        report = json.loads(client.stdout.strip().splitlines()[-1])
        assert report["joints"] == 22
        assert report["clock_advances"]
        assert report["controllers"] == {"joint_state_broadcaster": "active", "joint_trajectory_controller": "active"}
        assert report["topic_command_reached"]
        assert report["goal_status"] == "SUCCEEDED" and report["error_code"] == 0
        assert report["feedback_messages"] > 0
        assert all(abs(v) < 0.1 for v in report["knees_after_goal"].values()), report
    finally:
        if launcher.poll() is None:
            launcher.send_signal(signal.SIGINT)
        try:
            launcher.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(launcher.pid, signal.SIGKILL)
            launcher.wait(timeout=10)
    assert launcher.returncode == 0, out_path.read_text(errors="replace")


def test_type_hash_of_a_user_message_is_stable():
    """User packages get hashes too (ROS 2 tools list them even without the package installed)."""
    assert rihs01("humanoid_msgs/msg/HumanoidState").startswith("RIHS01_")
    assert names.data_key(3, "/humanoid/humanoid_state", "humanoid_msgs/msg/HumanoidState").startswith(
        "3/humanoid/humanoid_state/humanoid_msgs::msg::dds_::HumanoidState_/RIHS01_")

