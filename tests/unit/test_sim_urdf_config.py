"""Simulator input checking without DART stepping: URDF limits/ros2_control, gains, entities, commands."""

from __future__ import annotations

import math
from pathlib import Path

import msgpack
import pytest

from nodes.sim.config import parse_entities, parse_gains
from nodes.sim.hardware import CommandError
from nodes.sim.robot_files import ConfigError
from nodes.sim.robot_link import parse_command
from nodes.sim.urdf_info import UrdfError, parse_urdf
from tests.support.samples import chain_urdf

DATA = Path(__file__).resolve().parents[1] / "data"
ARM = (DATA / "sim_arm.urdf").read_text()
HUMANOID = (Path(__file__).resolve().parents[2] / "robots" / "humanoid.urdf").read_text()


def test_arm_limits_and_ros2_control_interfaces():
    info = parse_urdf(ARM)
    shoulder, elbow = info.joint("shoulder"), info.joint("elbow")
    assert info.root_link == "base" and info.has_ros2_control
    assert shoulder.command_interfaces == ["position", "velocity", "effort"]
    assert elbow.command_interfaces == ["position"]
    assert elbow.state_interfaces == ["position", "velocity"]
    # <param name="min/max"> narrows the URDF limit for that interface only
    assert shoulder.bounds("position") == (-0.8, 0.8)
    assert shoulder.bounds("velocity") == (-2.0, 2.0)
    assert shoulder.bounds("effort") == (-40.0, 40.0)
    assert elbow.bounds("position") == (-1.5, 1.5)


def test_humanoid_has_22_position_joints_with_limits():
    info = parse_urdf(HUMANOID)
    assert len(info.joints) == 22
    knee = info.joint("left_knee")
    assert knee.command_interfaces == ["position"]
    assert math.isfinite(knee.max_position) and knee.max_effort > 0


def test_without_ros2_control_every_movable_joint_gets_position_control():
    xml = ARM[: ARM.index("<ros2_control")] + "</robot>"
    info = parse_urdf(xml)
    assert not info.has_ros2_control
    assert [j.command_interfaces for j in info.joints] == [["position"], ["position"]]


@pytest.mark.parametrize("mutate, expected", [
    (lambda x: x.replace("</robot>", ""), "line"),                                   # XML syntax error
    (lambda x: x.replace('<child link="lower"/>', '<child link="nowhere"/>'), "'nowhere'"),
    (lambda x: x.replace('velocity="3.0"', 'velocity="fast"'), "velocity='fast'"),
    (lambda x: x.replace('lower="-1.5" upper="1.5"', 'lower="1.5" upper="-1.5"'), "lower limit"),
    (lambda x: x.replace('<command_interface name="position"/>', '<command_interface name="torque"/>'), "torque"),
    (lambda x: x.replace('<joint name="elbow">', '<joint name="wrist">'), "'wrist'"),
    (lambda x: x.replace('<param name="min">-0.8</param>', '<param name="min">nan</param>'), "NaN"),
    (lambda x: x.replace('<origin xyz="0 0 0.3"/>', '<origin xyz="0 0 nan"/>'), "not finite"),
    (lambda x: x.replace('<origin xyz="0 0 0.3"/>', '<origin xyz="0 0"/>'), "3 number(s)"),
    (lambda x: x.replace('<mass value="0.5"/>', '<mass value="-1"/>'), "negative"),
    (lambda x: x.replace('<box size="0.2 0.2 0.1"/></geometry></collision>',
                         '<mesh filename="package://arm/x.stl"/></geometry></collision>'), "package 'arm' not found"),
    (lambda x: x.replace('<box size="0.2 0.2 0.1"/></geometry></collision>',
                         '<mesh filename="../../etc/passwd"/></geometry></collision>'), "needs the robot's file"),
    (lambda x: x.replace('<box size="0.2 0.2 0.1"/></geometry></collision>',
                         '<mesh filename="/dev/zero"/></geometry></collision>'), "outside its package root"),
    (lambda x: x.replace('<box size="0.2 0.2 0.1"/></geometry></collision>',
                         '<mesh filename="file:///etc/passwd"/></geometry></collision>'), "outside its package root"),
    (lambda x: "", "empty"),
])
def test_bad_urdf_errors_name_line_and_reason(mutate, expected):
    with pytest.raises(UrdfError) as info:
        parse_urdf(mutate(ARM))
    message = str(info.value)
    assert expected in message
    if expected != "empty":
        assert message.startswith("line "), message


def test_entity_declarations_are_refused_before_parsing():
    hostile = (DATA / "urdf_broken" / "billion_laughs.urdf").read_text()
    with pytest.raises(UrdfError, match="XML declares entities"):
        parse_urdf(hostile)
    with pytest.raises(UrdfError, match="external DTD"):
        parse_urdf((DATA / "urdf_broken" / "external_dtd.urdf").read_text())


def test_robot_files_are_checked_before_xacro_runs(tmp_path):
    from nodes.sim.robot_files import read_robot_xml

    hostile = tmp_path / "lol.urdf.xacro"
    hostile.write_text((DATA / "urdf_broken" / "billion_laughs.urdf").read_text().replace(
        '<robot name=', '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name='))
    with pytest.raises(ConfigError, match="declares entities"):
        read_robot_xml(hostile)
    assert "<robot" in read_robot_xml(Path(__file__).resolve().parents[2] / "robots" / "simple_robot.urdf.xacro")


def test_gain_patterns_first_match_wins_and_fallback():
    gains_for = parse_gains({"*_knee": {"p": 100, "d": 2}, "left_*": {"p": 50}})
    assert (gains_for("left_knee").kp, gains_for("left_knee").kd) == (100.0, 2.0)
    assert (gains_for("left_hip").kp, gains_for("left_hip").kd) == (50.0, 0.0)
    assert gains_for("neck") is None   # from the physics (nodes.sim.servo_gains)


@pytest.mark.parametrize("table, where", [
    ({"*": 5}, "gains.*"),
    ({"*": {"p": -1}}, "gains.*.p"),
    ({"*": {"p": float("nan")}}, "gains.*.p"),
    ({"*": {"kp": 1}}, "unknown keys"),
    ({"*": {"d": 1}}, "missing p"),
])
def test_bad_gains_are_named(table, where):
    with pytest.raises(ConfigError, match=None) as info:
        parse_gains(table)
    assert where in str(info.value)


def test_startup_entities_parse_and_reject_bad_entries():
    [entity] = parse_entities([{"name": "humanoid", "file": "humanoid", "z": 0.915, "Y": 1.57,
                                "joints": {"left_knee": 0.4}, "fixed": False}])
    assert entity.xyz == (0.0, 0.0, 0.915) and entity.rpy == (0.0, 0.0, 1.57)
    assert entity.joints == {"left_knee": 0.4}
    for bad, where in [
        ([{"file": "x"}], "entities[0].name"),
        ([{"name": "a"}], "exactly one of file and topic"),
        ([{"name": "a", "file": "x", "topic": "y"}], "exactly one of file and topic"),
        ([{"name": "a", "file": "x", "z": float("nan")}], "entities[0].z"),
        ([{"name": "a", "file": "x", "colour": "red"}], "unknown keys"),
        ([{"name": "a", "file": "x", "fixed": "yes"}], "entities[0].fixed"),
        ("humanoid", "expected a list"),
    ]:
        with pytest.raises(ConfigError) as info:
            parse_entities(bad)
        assert where in str(info.value)


def test_hardware_command_parsing_names_the_field():
    good = msgpack.packb({"step": 3, "update_rate": 1000, "name": ["a"], "interface": ["position"],
                          "value": [0.5]})
    command = parse_command(good)
    assert (command.step, command.name, command.value) == (3, ["a"], [0.5])
    # NaN passes the parser: it is rejected per joint (and logged) when applied
    nan = msgpack.packb({"name": ["a"], "interface": ["position"], "value": [float("nan")]})
    assert math.isnan(parse_command(nan).value[0])
    with pytest.raises(CommandError, match="value: has 1 entries but name has 0"):
        parse_command(msgpack.packb({"value": [0.5]}))
    for payload, field in [
        (b"\xc1garbage", "msgpack"),
        (msgpack.packb([1, 2]), "expected a map"),
        (msgpack.packb({"step": -1}), "step"),
        (msgpack.packb({"step": True}), "step"),
        (msgpack.packb({"name": "a"}), "name"),
        (msgpack.packb({"value": ["x"]}), "value"),
        (msgpack.packb({"velocity": []}), "velocity: unknown field"),
    ]:
        with pytest.raises(CommandError) as info:
            parse_command(payload)
        assert field in str(info.value)


@pytest.mark.parametrize("star", [False, True])
def test_models_beyond_the_link_limit_are_refused_before_dart(star: bool) -> None:
    from nodes.sim.urdf_info import MAX_LINKS

    with pytest.raises(UrdfError, match=f"10001 <link> elements, over the simulator.s limit of {MAX_LINKS}"):
        parse_urdf(chain_urdf(10_000, star))
