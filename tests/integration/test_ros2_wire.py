"""The ROS 2 wire (rmw_zenoh) over real Zenoh: our nodes seen and driven by independent ROS 2 clients.

The ROS 2 side is played by zenoh-ros2-sdk (its CLI and the example client, in their own processes), by
rosbags (CDR) and by plain Zenoh sessions declaring rmw_zenoh tokens; never by our own decoder alone.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

import msgs
from bench.common import MAIN_JOB_CONTROLLERS, Launch, child_env
from msgs import cdr
from msgs.type_hash import rihs01
from nodes.core.delivery import Inline
from nodes.core.node import Node
from nodes.core.ros2 import attachment, names
from tests.conftest import wait_until

ROOT = Path(__file__).resolve().parents[2]
JAZZY = get_typestore(Stores.ROS2_JAZZY)
JS = "sensor_msgs/msg/JointState"
JT = "trajectory_msgs/msg/JointTrajectory"


def ros_endpoint_token(session: zenoh.Session, topic: str, type_name: str, kind: str = names.SUBSCRIPTION,
                       domain: int = 0):
    """What a ROS 2 subscription (or publisher) announces, as rmw_zenoh / zenoh-ros2-sdk would, from a
    non-zenroid session."""
    zid = str(session.info.zid())
    return session.liveliness().declare_token(names.endpoint_token(
        domain, zid, 0, 1, kind, "/", "ros_node", topic, type_name, names.DEFAULT_QOS))


def ros_tokens(session: zenoh.Session, pattern: str = "@ros2_lv/**") -> list[str]:
    return [str(r.ok.key_expr) for r in session.liveliness().get(pattern, timeout=1.0) if r.ok is not None]


# joint_states on rmw_zenoh's wire, whatever the type hash (a recorder or z_sub would subscribe like this)
JS_WILDCARD_KEY = "0/humanoid/joint_states/sensor_msgs::msg::dds_::JointState_/*"


def open_plain_session(endpoint: str) -> zenoh.Session:
    """A bare zenoh-python client, nothing of ours: it declares no liveliness token, ROS 2 or zenroid."""
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(config)


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
        token = ros_endpoint_token(session, "/humanoid/joint_states", JS)
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


def test_any_zenoh_subscriber_switches_cdr_on_and_nothing_is_encoded_without_one(router, monkeypatch):
    """Laziness follows Zenoh's matching status: a plain subscriber with no liveliness token (a recorder, a
    bridge, z_sub) gets CDR; with only zenroid subscribers not one message is encoded."""
    from nodes.core.ros2 import mirror

    encodes = [0]
    encode = mirror._to_cdr

    def counted(type_name: str, payload: bytes) -> bytes:
        encodes[0] += 1
        return encode(type_name, payload)

    monkeypatch.setattr(mirror, "_to_cdr", counted)
    talker = Node("talker", namespace="humanoid", connect=[router])
    listener = Node("listener", namespace="humanoid", connect=[router])
    heard: list = []
    try:
        pub = talker.create_publisher(msgs.get_type(JS), "joint_states")
        heard_sub = listener.create_subscription(msgs.get_type(JS), "joint_states", heard.append,
                                                 delivery=Inline())
        wait_until(lambda: (pub.publish(msgs.get_type(JS)(name=["a"], position=[0.0])), heard)[1],
                   timeout=10, interval=0.1, message="the zenroid listener hears the talker")
        for _ in range(200):
            pub.publish(msgs.get_type(JS)(name=["a"], position=[0.0]))
        wait_until(lambda: len(heard) > 200, message="all 200 messages at the zenroid listener")
        assert encodes[0] == 0 and not pub._mirror.active, "no foreign subscriber: nothing may be encoded"

        plain = open_plain_session(router)   # no zenroid runtime, no liveliness token
        try:
            received: list = []
            sub = plain.declare_subscriber(JS_WILDCARD_KEY, received.append)
            wait_until(lambda: pub._mirror.active, message="mirror active for a plain Zenoh subscriber")
            wait_until(lambda: (pub.publish(msgs.get_type(JS)(name=["left_knee"], position=[0.5])), received)[1],
                       timeout=10, interval=0.05, message="CDR at the plain subscriber")
            decoded = JAZZY.deserialize_cdr(received[-1].payload.to_bytes(), JS)
            assert list(decoded.name) == ["left_knee"] and decoded.position.tolist() == [0.5]
            assert not ros_tokens(plain, f"@ros2_lv/*/{plain.info.zid()}/**"), "the plain session declared no token"
            sub.undeclare()
            wait_until(lambda: not pub._mirror.active, message="mirror lazy again once the subscriber left")
            settled = encodes[0]
            for _ in range(200):
                pub.publish(msgs.get_type(JS)(name=["a"], position=[0.0]))
            assert encodes[0] == settled, "the subscriber left: encoding must stop"

            # A ROS 2 publisher on the same topic: the listener's mirror now subscribes to the data key, which
            # Zenoh's matching cannot tell from a foreign subscriber; a ROS 2 subscription token is needed then.
            ros_pub_token = ros_endpoint_token(plain, "/humanoid/joint_states", JS, names.PUBLISHER)
            wait_until(lambda: heard_sub._mirror.listening, message="the listener's mirror on the data key")
            for _ in range(200):
                pub.publish(msgs.get_type(JS)(name=["a"], position=[0.0]))
            assert encodes[0] == settled and not pub._mirror.active, "our own mirror must not switch CDR on"
            ros_sub_token = ros_endpoint_token(plain, "/humanoid/joint_states", JS)
            wait_until(lambda: pub._mirror.active, message="mirror active for a ROS 2 subscription token")
            ros_sub_token.undeclare()
            ros_pub_token.undeclare()
            wait_until(lambda: not (pub._mirror.active or heard_sub._mirror.listening), message="all lazy again")
        finally:
            plain.close()
    finally:
        listener.destroy()
        talker.destroy()


def test_ros2_publisher_drives_our_subscription_once(router, session):
    commander = Node("commander", namespace="humanoid", connect=[router])
    controller = Node("controller", namespace="humanoid", connect=[router])
    got: list = []
    try:
        pub = commander.create_publisher(msgs.get_type(JT), "jtc/joint_trajectory")
        sub = controller.create_subscription(msgs.get_type(JT), "jtc/joint_trajectory", got.append,
                                             delivery=Inline())
        key = names.data_key(0, "/humanoid/jtc/joint_trajectory", JT)
        assert not sub._mirror.listening, "no ROS 2 publisher yet: our subscription mirror stays off the data key"
        # A ROS 2 publisher announces itself (MP token): the controller's mirror now listens on the data key;
        # with a ROS 2 subscription too, the commander's CDR twin is on, so each of our messages reaches the
        # controller twice (our key, CDR) and must be taken once.
        ros_pub_token = ros_endpoint_token(session, "/humanoid/jtc/joint_trajectory", JT, names.PUBLISHER)
        wait_until(lambda: sub._mirror.listening, message="subscription mirror listening")
        ros_sub_token = ros_endpoint_token(session, "/humanoid/jtc/joint_trajectory", JT)
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
        ros_pub = session.declare_publisher(key)
        wait_until(lambda: (ros_pub.put(raw, attachment=attachment.pack(1, bytes(range(16)))),
                            any(m.joint_names == ["from_ros"] for m in got))[1],
                   timeout=10, interval=0.2, message="the ROS 2 message in our callback")
        ros_pub_token.undeclare()
        wait_until(lambda: not sub._mirror.listening, message="subscription mirror off once the publisher left")
        wait_until(lambda: not pub._mirror.active, message="commander mirror lazy again (nobody subscribes)")
        ros_sub_token.undeclare()
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
        assert not any("hardware" in t or "zenroid_msgs" in t for t in tokens), tokens
        # get_parameters on the ROS 2 wire is rcl_interfaces' (zenroid's YAML one stays on our key)
        assert any("%sim%get_parameters/rcl_interfaces::srv::dds_::GetParameters_/" in t for t in tokens), tokens
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


_CLEAN_ENV = {k: v for k, v in child_env().items() if k != "ROS_DOMAIN_ID"}


@pytest.fixture(scope="module")
def main_job(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[int, subprocess.Popen, Path]]:
    """The main job (lockstep, no viewer, no commander) on a free port, shared by the tests below;
    yields (port, launcher, its output file). It must end cleanly on SIGINT."""
    launch = Launch("humanoid.yaml", "mode:=lockstep", "commander:=none", env=_CLEAN_ENV,
                    log_dir=tmp_path_factory.mktemp("main_job"))
    try:
        yield launch.port, launch.proc, launch.out_path
    finally:
        status = launch.close()
    assert status == 0, launch.output()


@pytest.mark.slow
def test_main_job_joint_states_reach_a_plain_zenoh_subscriber(main_job) -> None:
    """A bare zenoh-python subscriber on rmw_zenoh's joint_states key, no liveliness token declared (a Zenoh
    recorder, a bridge, z_sub): CDR arrives, and rosbags decodes it."""
    zenoh_port, launcher, out_path = main_job

    def opened() -> zenoh.Session | None:
        assert launcher.poll() is None, out_path.read_text(errors="replace")
        try:
            return open_plain_session(f"tcp/127.0.0.1:{zenoh_port}")
        except zenoh.ZError:
            return None  # the job's router is not listening yet

    plain = wait_until(opened, timeout=60, interval=0.5, message="the main job's router")
    try:
        received: list[zenoh.Sample] = []
        sub = plain.declare_subscriber(JS_WILDCARD_KEY, received.append)

        def flowing() -> bool:
            assert launcher.poll() is None, out_path.read_text(errors="replace")
            return len(received) >= 50

        wait_until(flowing, timeout=120, interval=0.5, message="joint_states CDR at the plain subscriber")
        sub.undeclare()
        assert not ros_tokens(plain, f"@ros2_lv/*/{plain.info.zid()}/**"), "the plain session declared no token"
        sample = received[-1]
        assert str(sample.key_expr) == names.data_key(0, "/humanoid/joint_states", JS)
        assert str(sample.encoding).startswith("application/cdr")
        decoded = JAZZY.deserialize_cdr(sample.payload.to_bytes(), JS)
        assert len(decoded.name) == 22 and "left_knee" in list(decoded.name), list(decoded.name)
        assert len(decoded.position) == 22 and all(abs(p) < 4.0 for p in decoded.position)
        att = attachment.unpack(sample.attachment.to_bytes())
        assert att is not None and att.sequence >= 50 and len(att.gid) == 16
    finally:
        plain.close()


@pytest.mark.slow
def test_main_job_camera_images_and_scans_reach_a_plain_zenoh_subscriber_as_cdr(main_job) -> None:
    """The renderer's streams on rmw_zenoh's keys: a subscriber there alone makes the renderer draw them (the
    wire twin counts as a subscriber), and rosbags decodes the CDR as Jazzy's Image and LaserScan."""
    zenoh_port, launcher, out_path = main_job
    plain = wait_until(lambda: open_plain_session(f"tcp/127.0.0.1:{zenoh_port}"), timeout=60, interval=0.5,
                       message="the main job's router")
    try:
        received: dict[str, list[zenoh.Sample]] = {"sensor_msgs/msg/Image": [], "sensor_msgs/msg/LaserScan": []}
        subs = [plain.declare_subscriber(names.data_key(0, topic, type_name), received[type_name].append)
                for topic, type_name in (("/humanoid/camera/rgb", "sensor_msgs/msg/Image"),
                                         ("/humanoid/scan", "sensor_msgs/msg/LaserScan"))]

        def flowing() -> bool:
            assert launcher.poll() is None, out_path.read_text(errors="replace")
            return all(len(samples) >= 5 for samples in received.values())

        wait_until(flowing, timeout=120, interval=0.5, message="images and scans as CDR at the plain subscriber")
        for sub in subs:
            sub.undeclare()
        image = JAZZY.deserialize_cdr(received["sensor_msgs/msg/Image"][-1].payload.to_bytes(), "sensor_msgs/msg/Image")
        assert (image.width, image.height, image.encoding, image.step) == (320, 240, "rgb8", 960)
        assert len(image.data) == 320 * 240 * 3 and image.header.frame_id == "camera_optical_frame"
        scan = JAZZY.deserialize_cdr(received["sensor_msgs/msg/LaserScan"][-1].payload.to_bytes(),
                                     "sensor_msgs/msg/LaserScan")
        assert len(scan.ranges) == 720 and scan.header.frame_id == "laser_link" and scan.range_max == 10.0
    finally:
        plain.close()


@pytest.mark.slow
def test_main_job_seen_and_driven_by_ros2_clients(main_job) -> None:
    zenoh_port, launcher, out_path = main_job
    env = _CLEAN_ENV
    tmp_path = out_path.parent
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
    assert report["controllers"] == dict.fromkeys(MAIN_JOB_CONTROLLERS, "active")
    assert report["topic_command_reached"]
    assert report["goal_status"] == "SUCCEEDED" and report["error_code"] == 0
    assert report["feedback_messages"] > 0
    assert all(abs(v) < 0.1 for v in report["knees_after_goal"].values()), report


def test_type_hash_of_a_user_message_is_stable():
    """User packages get hashes too (ROS 2 tools list them even without the package installed)."""
    assert rihs01("humanoid_msgs/msg/HumanoidState").startswith("RIHS01_")
    assert names.data_key(3, "/humanoid/humanoid_state", "humanoid_msgs/msg/HumanoidState").startswith(
        "3/humanoid/humanoid_state/humanoid_msgs::msg::dds_::HumanoidState_/RIHS01_")

