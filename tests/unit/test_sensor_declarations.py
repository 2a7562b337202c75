"""Sensors declared in a URDF (<ros2_control><sensor> + <gazebo reference><sensor>): what is read, and every bad
declaration refused with the sensor and the field named (the simulator's parse and check_urdf alike)."""

from __future__ import annotations

from pathlib import Path

import pytest

from nodes.sim.urdf_info import parse_urdf as sim_parse
from nodes.urdf.model import UrdfError, parse_urdf
from nodes.urdf.sensors import FORCE_TORQUE_INTERFACES, IMU_INTERFACES
from nodes.urdf.validate import validate

ROOT = Path(__file__).resolve().parents[2]

BODY = """
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1"/></inertial></link>
  <link name="foot"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1"/></inertial></link>
  <joint name="ankle" type="revolute"><parent link="base"/><child link="foot"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
"""


def robot(control: str = "", gazebo: str = "") -> str:
    return (f'<robot name="r">{BODY}<ros2_control name="s" type="system">'
            f'<joint name="ankle"><command_interface name="position"/></joint>{control}</ros2_control>'
            f"{gazebo}</robot>")


IMU_CONTROL = '<sensor name="imu"><state_interface name="orientation.w"/>' \
              '<state_interface name="linear_acceleration.z"/><param name="frame_id">base</param></sensor>'
IMU_GAZEBO = """<gazebo reference="base"><sensor name="imu" type="imu"><always_on>1</always_on>
  <update_rate>250</update_rate><pose>0 0 0.1 0 0 0</pose>
  <imu><angular_velocity><x><noise type="gaussian"><mean>0.1</mean><stddev>0.01</stddev><bias_mean>0.5</bias_mean>
  <bias_stddev>0.2</bias_stddev></noise></x></angular_velocity></imu></sensor></gazebo>"""
FT_GAZEBO = """<gazebo reference="ankle"><sensor name="ft" type="force_torque"><update_rate>100</update_rate>
  <force_torque><frame>parent</frame><measure_direction>parent_to_child</measure_direction></force_torque>
  </sensor></gazebo>"""


def test_imu_and_force_torque_declarations_are_read_and_matched_by_name():
    xml = robot(IMU_CONTROL + '<sensor name="ft"/>', IMU_GAZEBO + FT_GAZEBO)
    info = sim_parse(xml)
    imu, ft = info.sensors
    assert (imu.name, imu.type, imu.link, imu.update_rate, imu.always_on) == ("imu", "imu", "base", 250.0, True)
    assert imu.state_interfaces == ["orientation.w", "linear_acceleration.z"]
    assert imu.params == {"frame_id": "base"}
    assert imu.pose[2, 3] == pytest.approx(0.1)
    noise = imu.noise["angular_velocity.x"]
    assert (noise.type, noise.mean, noise.stddev, noise.bias_mean, noise.bias_stddev) == ("gaussian", 0.1, 0.01,
                                                                                          0.5, 0.2)
    assert set(imu.noise) == {"angular_velocity.x"}
    # a force/torque sensor on a joint measures that joint, between its parent and child links
    assert (ft.joint, ft.link, ft.parent_link, ft.frame, ft.measure_direction) == (
        "ankle", "foot", "base", "parent", "parent_to_child")
    assert ft.state_interfaces == list(FORCE_TORQUE_INTERFACES)   # none listed: all of the type's


def test_a_force_torque_sensor_on_a_link_measures_its_parent_joint_and_camera_types_are_left_to_others():
    gazebo = ('<gazebo reference="foot"><sensor name="ft" type="force_torque"/></gazebo>'
              '<gazebo reference="base"><sensor name="cam" type="camera"/></gazebo>')
    (ft,) = sim_parse(robot("", gazebo)).sensors
    assert (ft.joint, ft.link) == ("ankle", "foot") and ft.state_interfaces == []


def test_shipped_humanoids_declare_the_pelvis_imu_the_ankle_force_torque_and_the_foot_contact_sensors():
    from nodes.sim.robot_files import read_robot_xml

    for name, ankles, feet in (("humanoid.urdf", ("left_ankle_roll", "right_ankle_roll"), ("left_foot", "right_foot")),
                               ("humanoid_20dof.urdf.xacro", ("left_ankle_roll", "right_ankle_roll"),
                                ("left_foot", "right_foot")),
                               ("atlas.urdf", ("l_leg_lax", "r_leg_lax"), ("l_foot", "r_foot"))):
        info = sim_parse(read_robot_xml(ROOT / "robots" / name))
        sensors = {s.name: s for s in info.sensors}
        assert set(sensors) == {"imu_sensor", "left_foot_ft", "right_foot_ft", "left_foot_contact",
                                "right_foot_contact"}, name
        assert (sensors["left_foot_contact"].link, sensors["right_foot_contact"].link) == feet
        assert sensors["left_foot_contact"].plugin.key("humanoid") == "humanoid/left_foot/contacts"   # bumper plugin
        assert sensors["imu_sensor"].link == "pelvis"
        assert sensors["imu_sensor"].state_interfaces == list(IMU_INTERFACES)
        assert (sensors["left_foot_ft"].joint, sensors["right_foot_ft"].joint) == ankles
        assert sensors["left_foot_ft"].state_interfaces == list(FORCE_TORQUE_INTERFACES)


BAD = [
    ("unknown link", robot("", '<gazebo reference="nose"><sensor name="imu" type="imu"/></gazebo>'),
     ["sensor 'imu'", "<gazebo reference='nose'> is not a link of the robot"]),
    ("unknown interface", robot('<sensor name="imu"><state_interface name="orientation.q"/></sensor>', IMU_GAZEBO),
     ["<ros2_control> sensor 'imu'", "state_interface 'orientation.q' is not one of the imu interfaces"]),
    ("force interface on an imu", robot('<sensor name="imu"><state_interface name="force.x"/></sensor>', IMU_GAZEBO),
     ["sensor 'imu'", "state_interface 'force.x'"]),
    ("zero update_rate", robot("", IMU_GAZEBO.replace("<update_rate>250", "<update_rate>0")),
     ["sensor 'imu'", "<update_rate> 0: must be a positive number"]),
    ("negative update_rate", robot("", IMU_GAZEBO.replace("<update_rate>250", "<update_rate>-5")),
     ["sensor 'imu'", "<update_rate> -5"]),
    ("absurd update_rate", robot("", IMU_GAZEBO.replace("<update_rate>250", "<update_rate>1e9")),
     ["sensor 'imu'", "<update_rate> 1e9: over 100000 Hz"]),
    ("negative stddev", robot("", IMU_GAZEBO.replace("<stddev>0.01", "<stddev>-0.01")),
     ["sensor 'imu'", "noise of angular_velocity.x", "<stddev> -0.01 must not be negative"]),
    ("negative bias_stddev", robot("", IMU_GAZEBO.replace("<bias_stddev>0.2", "<bias_stddev>-1")),
     ["sensor 'imu'", "<bias_stddev> -1 must not be negative"]),
    ("ros2_control sensor without a gazebo sensor", robot('<sensor name="lost"/>'),
     ["<ros2_control> sensor 'lost'", "no <gazebo reference=...><sensor name='lost'>"]),
    ("imu on a joint", robot("", '<gazebo reference="ankle"><sensor name="imu" type="imu"/></gazebo>'),
     ["sensor 'imu'", "is a joint; an imu sensor goes on a link"]),
    ("bad frame", robot("", FT_GAZEBO.replace("<frame>parent", "<frame>world")),
     ["sensor 'ft'", "<frame> 'world' is not one of child, parent, sensor"]),
    ("unknown type", robot("", '<gazebo reference="base"><sensor name="x" type="imuu"/></gazebo>'),
     ["sensor 'x'", "type 'imuu' is not one of imu, force_torque, contact"]),
]


@pytest.mark.parametrize(("case", "xml", "expected"), BAD, ids=[b[0] for b in BAD])
def test_bad_declarations_are_refused_naming_sensor_and_field(case, xml, expected):
    with pytest.raises(UrdfError) as caught:
        sim_parse(xml)
    for part in expected:
        assert part in str(caught.value), (case, str(caught.value))
    # check_urdf reports the same problem as an error
    errors = [str(i) for i in validate(parse_urdf(xml)) if i.severity == "error"]
    assert any(expected[-1] in e for e in errors), errors


def test_text_where_a_number_belongs_names_the_sensor_and_line():
    xml = robot("", IMU_GAZEBO.replace("<update_rate>250", "<update_rate>fast"))
    with pytest.raises(UrdfError, match=r"sensor 'imu' \(line \d+\) <update_rate>: 'fast' is not a number"):
        parse_urdf(xml)


PLUGIN = """<plugin name="imu_plugin" filename="libgazebo_ros_imu_sensor.so">
  <ros><namespace>/demo</namespace><remapping>~/out:=imu</remapping></ros><frame_name>base</frame_name></plugin>"""


def test_a_gazebo_ros_imu_plugin_is_read_with_its_topic_and_frame():
    (imu,) = sim_parse(robot("", IMU_GAZEBO.replace("</sensor>", PLUGIN + "</sensor>"))).sensors
    assert (imu.plugin.name, imu.plugin.frame_name, imu.plugin.key()) == ("imu_plugin", "base", "demo/imu")
    plain = PLUGIN.replace("<ros><namespace>/demo</namespace><remapping>~/out:=imu</remapping></ros>", "")
    (imu,) = sim_parse(robot("", IMU_GAZEBO.replace("</sensor>", plain + "</sensor>"))).sensors
    assert imu.plugin.key() == "imu_plugin/out"    # gazebo_ros: ~/out of a node named after the plugin


def test_a_plugin_frame_that_tf_does_not_publish_is_refused():
    xml = robot("", IMU_GAZEBO.replace("</sensor>", PLUGIN.replace(">base<", ">imu_link<") + "</sensor>"))
    with pytest.raises(UrdfError, match="sensor 'imu'.*<frame_name> 'imu_link' is not a link of the robot"):
        sim_parse(xml)
