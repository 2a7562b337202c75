"""Message classes behave as rosidl_python's generated ones (Jazzy's ``_msg.py.em``), and the interface packages
import under their ROS names as the same class objects as ``msgs.<pkg>``."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import msgs
from msgs.classes import FieldTypeError, FieldValueError
from msgs.slot_types import BasicType, BoundedString, NamespacedType, UnboundedSequence, UnboundedString
from tests.conftest import ROOT

SEED_PACKAGE = Path("/work/shared/seed-code/002/humanoid_msgs")
if not SEED_PACKAGE.is_dir():
    SEED_PACKAGE = ROOT / "msgs" / "definitions" / "humanoid_msgs"


# ---------------------------------------------------------------- rosidl semantics

def test_construction_defaults_keywords_and_unknown_keywords():
    from msgs.trajectory_msgs import JointTrajectoryPoint

    point = JointTrajectoryPoint(positions=[0.1, 0.2])
    assert point.positions == [0.1, 0.2] and point.velocities == [] and point.time_from_start.sec == 0
    with pytest.raises(TypeError, match="posit"):
        JointTrajectoryPoint(posit=[1.0])
    assert msgs.get_type("std_msgs/msg/ColorRGBA")().a == 0.0
    assert msgs.get_type("rcl_interfaces/msg/ParameterDescriptor")().read_only is False


def test_nested_assignment_append_constants_and_round_trip():
    from msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
    from msgs.visualization_msgs import Marker

    traj = JointTrajectory(joint_names=["knee"])
    point = JointTrajectoryPoint(positions=[0.4])
    point.time_from_start.sec = 1
    traj.points.append(point)
    traj.header.stamp.nanosec = 5
    assert msgs.decode(JointTrajectory, msgs.encode(traj)) == traj
    assert Marker.LINE_STRIP == 4 and Marker().type == 0
    marker = Marker(type=Marker.LINE_STRIP)
    assert marker.type == 4 and marker._type == "visualization_msgs/msg/Marker"   # a field named "type"


def test_fields_and_field_types_and_slot_types_as_rosidl_spells_them():
    from msgs.sensor_msgs import Imu, JointState

    # the dict rosidl_generator_py writes in sensor_msgs/msg/_joint_state.py
    assert JointState.get_fields_and_field_types() == {
        "header": "std_msgs/Header", "name": "sequence<string>", "position": "sequence<double>",
        "velocity": "sequence<double>", "effort": "sequence<double>"}
    assert Imu.get_fields_and_field_types()["orientation_covariance"] == "double[9]"
    assert msgs.get_type("std_msgs/msg/Bool").get_fields_and_field_types() == {"data": "boolean"}
    assert msgs.get_type("std_msgs/msg/ByteMultiArray").get_fields_and_field_types()["data"] == "sequence<octet>"
    assert JointState.SLOT_TYPES[0] == NamespacedType(["std_msgs", "msg"], "Header")
    assert JointState.SLOT_TYPES[1] == UnboundedSequence(UnboundedString())
    assert JointState.SLOT_TYPES[2] == UnboundedSequence(BasicType("double"))
    assert JointState.__slots__ == ("header", "name", "position", "velocity", "effort")
    bounded = msgs.register_message("test_msgs/msg/Bounded", "string<=3 code\nint32[<=2] ids\n")
    assert bounded.get_fields_and_field_types() == {"code": "string<3>", "ids": "sequence<int32, 2>"}
    assert bounded.SLOT_TYPES[0] == BoundedString(3)


def test_equality_and_repr():
    from msgs.geometry_msgs import Point, Vector3

    assert Point(x=1.0) == Point(x=1.0) and Point(x=1.0) != Point(x=2.0)
    assert Point(x=1.0) != Vector3(x=1.0)
    assert repr(Point(x=1.0)) == "geometry_msgs.msg.Point(x=1.0, y=0.0, z=0.0)"


def test_a_wrong_type_is_refused_when_assigned_naming_the_field():
    Time = msgs.get_type("builtin_interfaces/msg/Time")
    stamp = Time()
    with pytest.raises(AssertionError, match="'nanosec'"):
        stamp.nanosec = 0.5                    # 003's trajectory sender, as Humble refuses it
    with pytest.raises(FieldTypeError, match="builtin_interfaces/msg/Time: the 'sec' field must be an integer"):
        Time(sec="1")
    with pytest.raises(FieldValueError, match="in \\[0, 4294967295\\]"):
        stamp.nanosec = -1
    Float64 = msgs.get_type("std_msgs/msg/Float64")
    with pytest.raises(TypeError, match="'data' field must be a float"):
        Float64(data="1.0")
    with pytest.raises(TypeError, match="'header' field must be a sub message of type 'std_msgs/msg/Header'"):
        msgs.get_type("sensor_msgs/msg/JointState")(header=stamp)
    with pytest.raises(TypeError, match="'position' field must be a sequence"):
        msgs.get_type("sensor_msgs/msg/JointState")(position="abc")
    with pytest.raises(AttributeError, match="no field 'positon'"):
        msgs.get_type("sensor_msgs/msg/JointState")().positon = [1.0]
    with pytest.raises(ValueError, match="exactly 9 items"):
        msgs.get_type("sensor_msgs/msg/Imu")(orientation_covariance=[0.0] * 8)
    with pytest.raises(ValueError, match="at most 3 characters"):
        msgs.register_message("test_msgs/msg/Bounded2", "string<=3 code\n")(code="long")


def test_numbers_convert_as_python_would():
    from msgs.sensor_msgs import JointState

    js = JointState(position=np.array([1, 2.5]), velocity=(1, 2))
    assert js.position == [1.0, 2.5] and type(js.position) is list and type(js.velocity[0]) is float
    js.effort = [np.float32(0.5)]
    assert js.effort == [0.5] and type(js.effort[0]) is float
    assert msgs.get_type("std_msgs/msg/Float64")(data=3).data == 3.0
    assert msgs.get_type("std_msgs/msg/UInt8MultiArray")(data=np.array([1, 2], dtype=np.uint8)).data == b"\x01\x02"
    assert msgs.get_type("std_msgs/msg/Int32")(data=np.int64(7)).data == 7
    nan = msgs.get_type("std_msgs/msg/Float64")(data=math.nan)   # rosidl takes NaN; sending it is refused
    assert math.isnan(nan.data)


def test_what_a_receiver_refuses_is_refused_when_encoding_naming_the_field():
    from msgs.geometry_msgs import Point, PoseArray
    from msgs.sensor_msgs import JointState, LaserScan

    js = JointState(name=["a", "b"], position=[0.1, 0.2])
    js.position[1] = math.nan
    with pytest.raises(msgs.EncodeError, match=r"JointState: position\[1\]: not a finite number"):
        msgs.encode(js)
    js.position[1] = "x"   # inside a list: no setter sees it
    with pytest.raises(msgs.EncodeError, match=r"position\[1\]: expected a number"):
        msgs.encode(js)
    poses = PoseArray()
    poses.poses.append(Point())
    with pytest.raises(msgs.EncodeError, match=r"poses\[0\]: expected a map for geometry_msgs/msg/Pose, got Point"):
        msgs.encode(poses)
    with pytest.raises(msgs.EncodeError, match="velocity: has 1 entries but name has 2"):
        msgs.encode(JointState(name=["a", "b"], velocity=[1.0]))
    names = msgs.get_type("std_msgs/msg/String")(data="x")
    names.data = "y"
    assert msgs.decode(type(names), msgs.encode(names)).data == "y"
    assert msgs.decode(LaserScan, msgs.encode(LaserScan(ranges=[math.inf]))).ranges == [math.inf]


# ---------------------------------------------------------------- ROS names

def _run(code: str, cwd: Path, **env: str) -> subprocess.CompletedProcess:
    environment = {k: v for k, v in os.environ.items() if not k.startswith(("ZENROID_", "ROS_", "AMENT_"))}
    environment.update({"PYTHONPATH": str(ROOT), **env})
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, env=environment,
                          capture_output=True, text=True, timeout=120)


def test_ros_names_are_the_same_class_objects():
    import std_msgs.msg
    from control_msgs.action import FollowJointTrajectory
    from example_interfaces.srv import AddTwoInts
    from std_msgs.msg import String as RosString

    assert RosString is msgs.std_msgs.String is std_msgs.msg.String
    assert isinstance(msgs.std_msgs.String(), RosString) and isinstance(RosString(), msgs.std_msgs.String)
    assert AddTwoInts is msgs.get_type("example_interfaces/srv/AddTwoInts")
    assert AddTwoInts.Request(a=1, b=2).b == 2 and FollowJointTrajectory.Goal is msgs.control_msgs.FollowJointTrajectory.Goal
    assert not hasattr(std_msgs.msg, "NoSuchType")


def test_a_fresh_interpreter_finds_them_after_the_pth_line_alone(tmp_path):
    """What zenroid-interfaces.pth runs at start-up; msgs is imported only when a type is looked up."""
    pth_line = (ROOT / "zenroid-interfaces.pth").read_text().strip()
    done = _run(f"""
        {pth_line}
        import sys
        assert "msgs" not in sys.modules
        from trajectory_msgs.msg import JointTrajectory
        import std_msgs.msg
        from example_interfaces.srv import AddTwoInts
        from control_msgs.action import FollowJointTrajectory
        import msgs
        assert JointTrajectory is msgs.trajectory_msgs.JointTrajectory
        print("ok")
    """, tmp_path)
    assert done.stdout.strip() == "ok", done.stderr


def test_start_up_imports_no_zenroid_module(tmp_path):
    """The finder is asked for sitecustomize and usercustomize at every start-up: it answers without the package
    index, so ``nodes`` is imported from wherever the program's own sys.path says, later."""
    done = _run("import sys; print(sorted(m for m in sys.modules if m.split('.')[0] in ('nodes', 'msgs')))",
                tmp_path)
    assert done.stdout.strip() == "[]", done.stdout + done.stderr


def test_a_real_ros_package_on_the_path_wins(tmp_path):
    fake = tmp_path / "ros" / "std_msgs" / "msg"
    fake.mkdir(parents=True)
    (fake.parent / "__init__.py").write_text("")
    (fake / "__init__.py").write_text("class String:\n    real = True\n")
    done = _run("""
        import msgs
        from std_msgs.msg import String
        from geometry_msgs.msg import Point
        print(getattr(String, "real", False), Point is msgs.geometry_msgs.Point)
    """, tmp_path, PYTHONPATH=os.pathsep.join([str(tmp_path / "ros"), str(ROOT)]))
    assert done.stdout.split() == ["True", "True"], done.stderr


@pytest.mark.parametrize("package", ["humanoid_msgs", "tutorial_interfaces"])
def test_a_user_package_in_the_workspace_imports_with_no_build(tmp_path, package):
    """Seed 002's humanoid_msgs copied into a workspace's src/ (and the same files as a package zenroid has
    never heard of): importable as <pkg>.msg/.srv/.action, from the workspace's own files."""
    src = tmp_path / "ws" / "src" / package
    shutil.copytree(SEED_PACKAGE, src)
    if package != "humanoid_msgs":
        xml = (src / "package.xml").read_text() if (src / "package.xml").exists() else ""
        (src / "package.xml").write_text(xml.replace("<name>humanoid_msgs</name>", f"<name>{package}</name>")
                                         or f"<package format='3'><name>{package}</name></package>")
    (src / "msg" / "HumanoidJointCommand.msg").write_text(
        (src / "msg" / "HumanoidJointCommand.msg").read_text() + "\nstring note_from_workspace\n")
    done = _run(f"""
        import msgs
        from {package}.msg import HumanoidState, HumanoidJointCommand
        from {package}.srv import PlanTrajectory
        from {package}.action import NavigateToGoal
        from geometry_msgs.msg import Point
        state = HumanoidState(joint_names=["knee"], joint_positions=[0.4])
        state.support_polygon.append(Point(x=1.0))
        assert msgs.decode(HumanoidState, msgs.encode(state)) == state
        assert "note_from_workspace" in HumanoidJointCommand.get_fields_and_field_types()
        assert HumanoidState is msgs.get_type("{package}/msg/HumanoidState")
        print(PlanTrajectory.Request.__name__, NavigateToGoal.Goal.__name__)
    """, tmp_path / "ws")
    assert done.stdout.split() == ["PlanTrajectory_Request", "NavigateToGoal_Goal"], done.stderr


def test_stubs_give_an_ide_the_field_types(tmp_path):
    import ast

    from msgs.stubs import write_stubs

    written = write_stubs(tmp_path)
    for path in written:
        ast.parse(path.read_text(), filename=str(path))   # every stub module is valid Python
    joint_state = (tmp_path / "sensor_msgs" / "msg" / "__init__.pyi").read_text()
    assert "    position: list[float]\n" in joint_state and "    header: std_msgs.msg.Header\n" in joint_state
    assert "class AddTwoInts:\n    Request = AddTwoInts_Request" in (
        tmp_path / "example_interfaces" / "srv" / "__init__.pyi").read_text()
    assert "    LINE_STRIP: ClassVar[int]\n" in (tmp_path / "visualization_msgs" / "msg" / "__init__.pyi").read_text()


def test_fields_named_like_builtins_construct():
    """Constructor parameters are the field names: ``type`` (Marker, ControllerState), ``min``, ``max``..."""
    odd = msgs.register_message("test_msgs/msg/Odd", "int32 min\nint32 max\nfloat64 v\nstring type\nint32[] list\n")
    made = odd(min=1, max=2, v=3, type="a", list=[1, 2])
    assert (made.min, made.max, made.v, made.type, made.list) == (1, 2, 3.0, "a", [1, 2])
    with pytest.raises(TypeError, match="'type' field must be a str"):
        odd(type=1)
    assert msgs.get_type("controller_manager_msgs/msg/ControllerState")(type="jtc").type == "jtc"
