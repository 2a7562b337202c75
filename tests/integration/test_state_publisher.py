"""The robot state publisher as a real process over real Zenoh (the test is the third-party client)."""

from __future__ import annotations

import math
import threading
from pathlib import Path

import msgpack
import numpy as np
import pytest

import msgs
from nodes.core.latched import fetch_latched
from nodes.core.session import open_peer
from nodes.kinematics import pose_matrix, quaternion_to_matrix
from tests.conftest import wait_until

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
JointState = msgs.get_type("sensor_msgs/msg/JointState")
ModelStates = msgs.get_type("gazebo_msgs/msg/ModelStates")
String = msgs.get_type("std_msgs/msg/String")
TFMessage = msgs.get_type("tf2_msgs/msg/TFMessage")


class TfRecorder:
    """Collects every tf message, decoded with msgpack alone (as any non-zenroid client would)."""

    def __init__(self, session, key: str) -> None:
        self.messages: list[dict] = []
        self._lock = threading.Lock()
        self._sub = session.declare_subscriber(key, self._on)

    def _on(self, sample) -> None:
        with self._lock:
            self.messages.append(msgpack.unpackb(sample.payload.to_bytes(), raw=False))

    def latest(self, child: str) -> dict | None:
        with self._lock:
            for message in reversed(self.messages):
                for t in message["transforms"]:
                    if t["child_frame_id"] == child:
                        return t
        return None

    def count(self) -> int:
        with self._lock:
            return len(self.messages)


def matrix_of(transform: dict) -> np.ndarray:
    tr, rot = transform["transform"]["translation"], transform["transform"]["rotation"]
    return pose_matrix([tr["x"], tr["y"], tr["z"]], [rot["x"], rot["y"], rot["z"], rot["w"]])


def dart_world(urdf: Path, positions: dict[str, float]):
    """Independent reference: DART body world transforms for the given joint values (fixed root)."""
    import dartpy as dart

    loader = dart.utils.DartLoader()
    options = dart.utils.DartLoaderOptions()
    options.mDefaultRootJointType = dart.utils.DartLoaderRootJointType.FIXED
    loader.setOptions(options)
    skeleton = loader.parseSkeleton(str(urdf))
    for name, value in positions.items():
        skeleton.getJoint(name).setPosition(0, value)
    return lambda link: skeleton.getBodyNode(link).getWorldTransform().matrix()


def start_publisher(processes, zenoh_port: int, ns: str, *params: str):
    argv = ["-m", "nodes.state_publisher", "--zenoh-port", str(zenoh_port), "--ns", ns]
    for p in params:
        argv += ["--param", p]
    return processes.start(*argv, name=f"rsp_{ns}")


def send_until(session, key: str, msg, predicate, what: str, timeout: float = 20.0):
    """Publish ``msg`` repeatedly until ``predicate()`` (the first samples may race the subscription)."""
    payload = msgs.encode(msg)

    def attempt():
        session.put(key, payload)
        return predicate()

    return wait_until(attempt, timeout=timeout, interval=0.05, message=what)


def test_tf_matches_fk_late_joiner_gets_description_and_tf_static(
        processes, zenoh_port, router, session) -> None:
    urdf = ROOT / "robots" / "lab_robot.urdf"
    proc = start_publisher(processes, zenoh_port, "lab_robot", f"robot_description_file:={urdf}",
                           "publish_frequency:=200.0")
    tf = TfRecorder(session, "lab_robot/tf")

    # A session opened after the node published is a late joiner: the queryable answers it.
    description = wait_until(lambda: fetch_latched(session, String, "lab_robot/robot_description", timeout=0.5),
                             timeout=30, message="robot_description from the state publisher")
    late = open_peer([router])
    try:
        again = fetch_latched(late, String, "lab_robot/robot_description", timeout=5.0)
        static = fetch_latched(late, TFMessage, "lab_robot/tf_static", timeout=5.0)
    finally:
        late.close()
    assert again is not None and again.data == description.data == urdf.read_text()

    # tf_static: exactly the fixed joints, with their URDF origins.
    assert static is not None
    fixed = {(t.header.frame_id, t.child_frame_id): t for t in static.transforms}
    assert set(fixed) == {("base_link", "stand"), ("stand", "torso")}
    assert fixed[("stand", "torso")].transform.translation.z == pytest.approx(0.6)
    assert fixed[("base_link", "stand")].transform.translation.z == pytest.approx(0.05)

    positions = {"left_arm_joint": 0.7, "right_arm_joint": -1.2, "left_leg_joint": 0.4, "right_leg_joint": -0.3}
    js = JointState(name=list(positions), position=list(positions.values()))
    js.header.stamp = msgs.time_from_sec(42.5)
    send_until(session, "lab_robot/joint_states", js,
               lambda: (t := tf.latest("right_leg")) and t["header"]["stamp"]["sec"] == 42,
               "tf for the published joint state")
    reference = dart_world(urdf, positions)
    for child in ("left_arm", "right_arm", "left_leg", "right_leg"):
        t = tf.latest(child)
        assert t["header"]["frame_id"] == "torso"
        assert t["header"]["stamp"] == {"sec": 42, "nanosec": 500_000_000}
        expected = np.linalg.inv(reference("torso")) @ reference(child)
        assert np.allclose(matrix_of(t), expected, atol=1e-9), child

    # A message naming one joint only: the others keep their last value.
    partial = JointState(name=["left_arm_joint"], position=[-0.5])
    partial.header.stamp = msgs.time_from_sec(43.0)
    send_until(session, "lab_robot/joint_states", partial,
               lambda: (t := tf.latest("left_arm")) and t["header"]["stamp"]["sec"] == 43,
               "tf after a partial joint state")
    right = quaternion_to_matrix([tf.latest("right_arm")["transform"]["rotation"][k] for k in "xyzw"])
    assert math.atan2(right[0, 2], right[0, 0]) == pytest.approx(-1.2, abs=1e-9)
    left = quaternion_to_matrix([tf.latest("left_arm")["transform"]["rotation"][k] for k in "xyzw"])
    assert math.atan2(left[0, 2], left[0, 0]) == pytest.approx(-0.5, abs=1e-9)

    # Bad input: mismatched arrays and unknown joints are reported; the node keeps its state and runs on.
    session.put("lab_robot/joint_states", msgpack.packb(
        {"header": {"stamp": {"sec": 44, "nanosec": 0}, "frame_id": ""}, "name": ["left_arm_joint", "right_arm_joint"],
         "position": [0.1], "velocity": [], "effort": []}))
    unknown = JointState(name=["left_arm_joint", "tail_joint"], position=[-0.5, 1.0])
    unknown.header.stamp = msgs.time_from_sec(45.0)
    send_until(session, "lab_robot/joint_states", unknown,
               lambda: (t := tf.latest("left_arm")) and t["header"]["stamp"]["sec"] == 45,
               "tf after an unknown-joint message")
    wait_until(lambda: "tail_joint" in processes.output(proc), message="unknown joint warning")
    log = processes.output(proc)
    assert "position: has 1 entries but name has 2" in log
    assert log.count("tail_joint") == 1  # warned once
    assert proc.poll() is None

    # Time going backwards (bag replay loops): republished at once, logged once.
    back = JointState(name=["left_arm_joint"], position=[0.2])
    back.header.stamp = msgs.time_from_sec(10.0)
    send_until(session, "lab_robot/joint_states", back,
               lambda: (t := tf.latest("left_arm")) and t["header"]["stamp"]["sec"] == 10,
               "tf republished after time moved backwards")
    wait_until(lambda: "moved backwards" in processes.output(proc), message="time-backwards log line")
    assert processes.output(proc).count("moved backwards") == 1


def test_floating_base_follows_model_states_with_frame_prefix_and_rate_limit(
        processes, zenoh_port, session) -> None:
    urdf = ROOT / "robots" / "humanoid.urdf"
    start_publisher(processes, zenoh_port, "humanoid", f"robot_description_file:={urdf}", "frame_prefix:=h1/",
                    "publish_frequency:=5.0")
    tf = TfRecorder(session, "humanoid/tf")
    wait_until(lambda: fetch_latched(session, String, "humanoid/robot_description", timeout=0.5), timeout=30,
               message="robot_description")
    states = msgs.from_dict(ModelStates, {
        "name": ["ground_plane", "humanoid"],
        "pose": [{}, {"position": {"x": 1.0, "y": -2.0, "z": 0.9},
                      "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(0.3), "w": math.cos(0.3)}}],
        "twist": [{}, {}],
    })
    send_until(session, "sim/model_states", states, lambda: tf.latest("h1/pelvis"),
               "world -> pelvis from sim/model_states")
    base = tf.latest("h1/pelvis")
    assert base["header"]["frame_id"] == "world"
    assert np.allclose(matrix_of(base), pose_matrix([1.0, -2.0, 0.9], [0, 0, math.sin(0.3), math.cos(0.3)]))

    # A burst of 100 joint states in well under a second, limited to 5 Hz: only a few tf messages result.
    before = tf.count()
    js = JointState(name=["left_knee"], position=[0.4])
    for i in range(100):
        js.header.stamp = msgs.time_from_sec(100.0 + i * 0.001)
        session.put("humanoid/joint_states", msgs.encode(js))
    wait_until(lambda: (t := tf.latest("h1/left_shin")) and t["header"]["stamp"]["sec"] == 100,
               message="tf for the knee")
    knee = tf.latest("h1/left_shin")
    assert knee["header"]["frame_id"] == "h1/left_thigh"
    assert tf.count() - before < 30  # the burst was rate-limited (100 inputs)


def test_broken_description_exits_2_with_the_reason(processes, zenoh_port) -> None:
    proc = start_publisher(processes, zenoh_port, "broken",
                           f"robot_description_file:={ROOT / 'tests/data/urdf_broken/limits_inverted.urdf'}")
    assert proc.wait(timeout=60) == 2
    assert "lower limit 1.5 > upper limit -1.5" in processes.output(proc)
    hostile = start_publisher(processes, zenoh_port, "hostile",
                              f"robot_description_file:={ROOT / 'tests/data/urdf_broken/billion_laughs.urdf'}")
    assert hostile.wait(timeout=60) == 2
    assert "declares entities" in processes.output(hostile)


def test_description_change_republishes_and_a_bad_one_is_refused(processes, zenoh_port, session) -> None:
    from nodes.core.endpoints import call_raw

    start_publisher(processes, zenoh_port, "arm", f"robot_description_file:={ROOT / 'robots/simple_2dof_arm.urdf'}")
    wait_until(lambda: fetch_latched(session, String, "arm/robot_description", timeout=0.5), timeout=30,
               message="robot_description")
    SetParameters = msgs.get_type("zenroid_msgs/srv/SetParameters")

    def set_file(path: Path):
        request = SetParameters.Request(names=["robot_description_file"], values_yaml=[str(path)])
        raw = call_raw(session, "arm/robot_state_publisher/set_parameters", msgs.encode(request), timeout=10.0)
        return msgs.decode(SetParameters.Response, raw)

    refused = set_file(ROOT / "tests/data/urdf_broken/missing_child_link.urdf")
    assert refused.successful == [False] and "child link 'ghost' does not exist" in refused.reasons[0]
    assert "simple_2dof_arm" in fetch_latched(session, String, "arm/robot_description", timeout=5.0).data

    new = ROOT / "robots" / "lab_robot.urdf"
    assert set_file(new).successful == [True]
    assert fetch_latched(session, String, "arm/robot_description", timeout=5.0).data == new.read_text()
    static = fetch_latched(session, TFMessage, "arm/tf_static", timeout=5.0)
    assert {t.child_frame_id for t in static.transforms} == {"stand", "torso"}
