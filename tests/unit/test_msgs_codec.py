"""Codec: every error path names the type, the field and the reason; round trips are exact."""

from __future__ import annotations

import math
import os

import msgpack
import pytest

import msgs
from msgs import DecodeError, Limits, decode, encode

JointState = msgs.get_type("sensor_msgs/msg/JointState")
JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")
UUID = msgs.get_type("unique_identifier_msgs/msg/UUID")
Log = msgs.get_type("rcl_interfaces/msg/Log")


def packed(obj: object) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


def expect_error(cls: object, obj: object, field: str, reason: str) -> DecodeError:
    with pytest.raises(DecodeError) as info:
        decode(cls, obj if isinstance(obj, bytes) else packed(obj))
    err = info.value
    assert err.type_name == cls._type
    assert err.path == field, str(err)
    assert reason in err.reason, str(err)
    assert cls._type in str(err)
    return err


def test_joint_state_round_trip_and_third_party_view() -> None:
    js = JointState(name=["left_knee", "right_knee"], position=[0.4, 0.0], velocity=[0.1, -0.1], effort=[1.0, 2.0])
    js.header.stamp.sec = 12
    js.header.frame_id = "pelvis"
    data = encode(js)
    assert decode(JointState, data) == js
    plain = msgpack.unpackb(data, raw=False)  # what a client without our code sees
    assert plain["name"] == ["left_knee", "right_knee"]
    assert plain["position"] == [0.4, 0.0]
    assert plain["header"] == {"stamp": {"sec": 12, "nanosec": 0}, "frame_id": "pelvis"}


def test_missing_fields_take_ros_defaults() -> None:
    msg = decode(JointState, packed({"name": ["a"]}))
    assert msg.position == [] and msg.header.frame_id == "" and msg.header.stamp.sec == 0
    q = decode(msgs.get_type("geometry_msgs/msg/Quaternion"), packed({}))
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)  # the .msg default, as ROS does


def test_wrong_type_names_field() -> None:
    expect_error(JointState, {"name": "knee"}, "name", "expected a list")
    expect_error(JointState, {"name": [1]}, "name[0]", "expected a string")
    expect_error(JointState, {"name": ["a"], "position": ["x"]}, "position[0]", "expected a number")
    expect_error(JointState, {"header": {"stamp": {"sec": 1.5}}}, "header.stamp.sec", "expected an integer")
    expect_error(JointState, {"header": []}, "header", "expected a map")
    expect_error(JointState, [1, 2], "", "expected a map")
    expect_error(msgs.get_type("std_msgs/msg/Bool"), {"data": 1}, "data", "expected a bool")


def test_integer_ranges() -> None:
    expect_error(Log, {"level": 256}, "level", "out of range for uint8")
    expect_error(Log, {"stamp": {"nanosec": -1}}, "stamp.nanosec", "out of range for uint32")


def test_unknown_field_is_rejected() -> None:
    expect_error(JointState, {"positions": [1.0]}, "positions", "unknown field")


def test_mismatched_lengths() -> None:
    expect_error(JointState, {"name": ["a", "b"], "position": [1.0]}, "position", "has 1 entries but name has 2")
    expect_error(JointState, {"name": ["a"], "effort": [1.0, 2.0]}, "effort", "has 2 entries")


def test_fixed_size_array() -> None:
    expect_error(UUID, {"uuid": b"\x01" * 15}, "uuid", "exactly 16")
    assert decode(UUID, packed({"uuid": list(range(16))})).uuid == bytes(range(16))  # list of ints accepted
    expect_error(UUID, {"uuid": [300] + [0] * 15}, "uuid[0]", "out of range")


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_floats(bad: float) -> None:
    expect_error(JointState, {"name": ["a", "b"], "position": [0.0, bad]}, "position[1]", "not a finite number")
    point = {"positions": [bad], "time_from_start": {"sec": 1}}
    expect_error(JointTrajectory, {"joint_names": ["j"], "points": [point]}, "points[0].positions[0]", "finite")
    allowed = decode(JointState, packed({"name": ["a"], "position": [bad]}), Limits(allow_nonfinite=True))
    assert allowed.position[0] != 0.0


def test_oversized_message_and_arrays() -> None:
    limits = Limits(max_message_bytes=1000, max_array_length=10, max_string_length=8)
    with pytest.raises(DecodeError, match="over the 1000-byte limit"):
        decode(JointState, packed({"name": ["a"] * 500}), limits)
    # msgpack's own limits refuse before anything is built; the top-level field is named
    with pytest.raises(DecodeError, match=r"JointState: name: too long \(11 exceeds max_array_len"):
        decode(JointState, packed({"name": ["a"] * 11}), limits)
    with pytest.raises(DecodeError, match=r"JointState: header: too long \(9 exceeds max_str_len"):
        decode(JointState, packed({"header": {"frame_id": "x" * 9}}), limits)


def test_truncated_and_random_bytes() -> None:
    data = encode(JointState(name=["a"], position=[1.0]))
    for cut in range(1, len(data) - 1, 7):
        with pytest.raises(DecodeError):
            decode(JointState, data[:cut])
    rng = __import__("random").Random(7)
    for _ in range(300):
        blob = bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 64)))
        try:
            decode(JointState, blob)
        except DecodeError:
            pass  # the only acceptable failure mode
    with pytest.raises(DecodeError):
        decode(JointState, os.urandom(0))


def test_numpy_arrays_encode() -> None:
    np = pytest.importorskip("numpy")
    js = JointState(name=["a", "b"], position=np.array([0.1, 0.2]))
    assert decode(JointState, encode(js)).position == [0.1, 0.2]


def test_every_builtin_type_has_a_class_and_encodes_its_default() -> None:
    types = msgs.list_types()
    assert len(types) >= 60
    for name in types:
        t = msgs.get_type(name)
        if isinstance(t, msgs.Service):
            classes = [t.Request, t.Response]
        elif isinstance(t, msgs.Action):
            classes = [t.Goal, t.Result, t.Feedback, t.SendGoalRequest, t.GetResultResponse, t.FeedbackMessage]
        else:
            classes = [t]
        for cls in classes:
            assert decode(cls, encode(cls())) == cls()


def test_constants_and_imports() -> None:
    from msgs.action_msgs import GoalStatus
    from msgs.control_msgs import FollowJointTrajectory

    assert GoalStatus.STATUS_SUCCEEDED == 4
    assert FollowJointTrajectory.Result.GOAL_TOLERANCE_VIOLATED == -5
    assert msgs.HumanoidState is msgs.get_type("humanoid_msgs/msg/HumanoidState")


def test_every_message_package_is_a_module() -> None:
    """``msgs.<pkg>`` modules are made from the definitions (msgs/packages.py), not written by hand."""
    import importlib

    for package in msgs.package_names():
        module = importlib.import_module(f"msgs.{package}")
        assert msgs.__dict__.get(package, module) is module and getattr(msgs, package) is module
    from msgs.sensor_msgs import JointState

    assert JointState is msgs.get_type("sensor_msgs/msg/JointState")
    with pytest.raises(ImportError, match="NoSuchType"):
        from msgs.sensor_msgs import NoSuchType  # noqa: F401
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("msgs.no_such_msgs")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("msgs.sensor_msgs.deeper")


def test_user_message_package(tmp_path) -> None:
    pkg = tmp_path / "my_robot_msgs" / "msg"
    pkg.mkdir(parents=True)
    (pkg / "GraspCommand.msg").write_text(
        "# hand configuration\nstd_msgs/Header header\nstring hand\nfloat64[5] finger_positions\nfloat64 force 2.5\n")
    msgs.add_search_path(tmp_path)
    Grasp = msgs.get_type("my_robot_msgs/msg/GraspCommand")
    g = Grasp(hand="left")
    assert g.force == 2.5 and g.finger_positions == [0.0] * 5
    assert decode(Grasp, encode(g)) == g
    from msgs.my_robot_msgs import GraspCommand  # a user package is importable like the shipped ones

    assert GraspCommand is Grasp
    with pytest.raises(DecodeError, match="finger_positions: expected exactly 5"):
        decode(Grasp, packed({"finger_positions": [1.0]}))


def test_bad_definitions_are_clear() -> None:
    from msgs.idl import DefinitionError, parse_message

    with pytest.raises(DefinitionError, match="line 2"):
        parse_message("float64 x\nfloat64[ y\n", "p/msg/T")
    with pytest.raises(DefinitionError, match="duplicate field"):
        parse_message("float64 x\nint32 x\n", "p/msg/T")
    with pytest.raises(DefinitionError, match="not an integer"):
        parse_message("int32 X = 1.5\n", "p/msg/T")


def test_a_laser_scan_carries_rep_117_infinities_and_other_types_still_refuse_them() -> None:
    LaserScan, Imu = msgs.get_type("sensor_msgs/msg/LaserScan"), msgs.get_type("sensor_msgs/msg/Imu")
    scan = decode(LaserScan, encode(LaserScan(ranges=[1.5, math.inf, -math.inf], range_max=10.0)))
    assert scan.ranges == [1.5, math.inf, -math.inf]
    with pytest.raises(DecodeError, match="angular_velocity.x: not a finite number"):
        decode(Imu, packed({"angular_velocity": {"x": math.inf}}))
    # from plain data too (a bag's CDR scans, played back): the same values, the same refusals
    assert msgs.from_dict(LaserScan, {"ranges": [1.5, math.inf, -math.inf]}).ranges == [1.5, math.inf, -math.inf]
    with pytest.raises(DecodeError, match="angular_velocity.x: not a finite number"):
        msgs.from_dict(Imu, {"angular_velocity": {"x": math.inf}})


def test_an_image_larger_than_the_array_limit_decodes_in_every_path() -> None:
    """uint8[] as bin is one object, bounded by the message size: a 640x480 depth image (1.2 MB) is more bytes
    than max_array_length entries; as a list of ints the array limit still holds."""
    Image = msgs.get_type("sensor_msgs/msg/Image")
    data = bytes(range(256)) * (640 * 480 * 4 // 256)
    fields = {"height": 480, "width": 640, "encoding": "32FC1", "step": 2560, "data": data}
    assert decode(Image, encode(Image(**fields))).data == data                    # the msgspec path
    small = Limits(max_array_length=10)
    assert decode(Image, packed(fields), small).data == data                       # the compiled / precise paths
    with pytest.raises(DecodeError, match=r"data: too long \(11 exceeds max_array_len\(10\)\)"):
        decode(Image, packed({"data": list(range(11))}), small)
