"""Frame links (zero mass / no inertia on fixed joints) merged into their parent body for the physics, as
Gazebo lumps fixed joints; moving links without inertia refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from nodes.urdf import parse_urdf, validate
from nodes.urdf.frames import frame_links, lump_frames
from nodes.urdf.model import UrdfError

INERTIA = '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>'


def robot(extra_links: str = "", extra_joints: str = "", arm_inertial: str | None = None) -> str:
    arm = arm_inertial if arm_inertial is not None else f'<inertial><mass value="1"/>{INERTIA}</inertial>'
    return f"""<robot name="r">
  <link name="base"><inertial><mass value="2"/>{INERTIA}</inertial>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="arm">{arm}</link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.5"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  {extra_links}{extra_joints}
</robot>"""


SENSOR_FRAME = """
  <link name="camera_optical"/>
  <link name="tool"><inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.05"/><geometry><sphere radius="0.02"/></geometry></collision></link>
  <link name="weight"><inertial><mass value="0.5"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/>
    </inertial></link>"""
SENSOR_JOINTS = """
  <joint name="cam" type="fixed"><parent link="base"/><child link="camera_optical"/>
    <origin xyz="0.1 0 0.2" rpy="0 0 1.5707963267948966"/></joint>
  <joint name="tool_j" type="fixed"><parent link="arm"/><child link="tool"/><origin xyz="0 0 0.3"/></joint>
  <joint name="weight_j" type="fixed"><parent link="tool"/><child link="weight"/><origin xyz="0.2 0 0"/></joint>"""


def test_frames_are_found_and_are_not_errors():
    model = parse_urdf(robot(SENSOR_FRAME, SENSOR_JOINTS))
    assert frame_links(model) == ["camera_optical", "tool", "weight"]
    issues = validate(model)
    assert not [i for i in issues if i.severity == "error"], issues
    frames_warnings = [i.message for i in issues if "frames" in i.message]
    assert len(frames_warnings) == 1 and "camera_optical, tool, weight" in frames_warnings[0]


def test_frames_merge_into_their_body_with_shapes_mass_and_poses():
    lumped = lump_frames(robot(SENSOR_FRAME, SENSOR_JOINTS))
    model = parse_urdf(lumped.xml)
    assert sorted(model.links) == ["arm", "base"]
    assert not frame_links(model)
    # the point mass 0.5 kg, 0.3 m up and 0.2 m out on the arm, joins the arm's 1 kg at its origin
    arm = model.links["arm"].inertial
    assert arm.mass == pytest.approx(1.5)
    com = np.array([0.2, 0.0, 0.3]) * 0.5 / 1.5
    assert arm.origin[:3, 3] == pytest.approx(com)
    d = np.array([0.2, 0.0, 0.3]) - com
    expected = 0.01 * np.eye(3) + 1.0 * (com @ com * np.eye(3) - np.outer(com, com)) \
        + 0.5 * (d @ d * np.eye(3) - np.outer(d, d))
    assert arm.inertia == pytest.approx(expected)
    # the tool's sphere now on the arm, 0.3 + 0.05 up
    (sphere,) = model.links["arm"].collisions
    assert sphere.origin[:3, 3] == pytest.approx([0, 0, 0.35])
    body, pose = lumped.body_of("weight")
    assert body == "arm" and pose[:3, 3] == pytest.approx([0.2, 0, 0.3])
    body, pose = lumped.body_of("camera_optical")
    assert body == "base" and pose[:3, 3] == pytest.approx([0.1, 0, 0.2])
    assert pose[:3, :3] @ np.array([1, 0, 0]) == pytest.approx([0, 1, 0])
    assert parse_urdf(lumped.xml).total_mass() == pytest.approx(parse_urdf(robot(SENSOR_FRAME, SENSOR_JOINTS))
                                                                .total_mass())


def test_a_massless_root_takes_its_fixed_children():
    xml = robot().replace('<link name="base"><inertial><mass value="2"/>' + INERTIA + "</inertial>",
                          '<link name="base_link"/><link name="base"><inertial><mass value="2"/>' + INERTIA
                          + "</inertial>")
    xml = xml.replace("</robot>", '<joint name="root_j" type="fixed"><parent link="base_link"/>'
                                  '<child link="base"/><origin xyz="0 0 1"/></joint></robot>')
    lumped = lump_frames(xml)
    model = parse_urdf(lumped.xml)
    assert sorted(model.links) == ["arm", "base_link"]
    assert model.links["base_link"].inertial.mass == pytest.approx(2)
    assert model.joints["j"].parent == "base_link"
    assert model.joints["j"].origin[:3, 3] == pytest.approx([0, 0, 1.5])


@pytest.mark.parametrize("inertial, reason", [
    ("", "no <inertial>"),
    ('<inertial><mass value="0"/>' + INERTIA + "</inertial>", "mass 0"),
    ('<inertial><mass value="1"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>',
     "not positive definite"),
])
def test_a_moving_link_without_inertia_is_an_error_naming_it(inertial, reason):
    from nodes.sim.urdf_info import parse_urdf as sim_parse

    with pytest.raises(UrdfError) as info:
        sim_parse(robot(arm_inertial=inertial))
    assert "link 'arm'" in str(info.value) and "joint 'j'" in str(info.value) and reason in str(info.value)


def test_dart_gets_the_robot_mass_not_a_kilogram_per_frame():
    dart = pytest.importorskip("dartpy")
    from nodes.sim.entity import Entity, EntitySpec

    entity = Entity(EntitySpec(name="r", xml=robot(SENSOR_FRAME, SENSOR_JOINTS)))
    assert entity.skeleton.getMass() == pytest.approx(3.5)
    names = [entity.skeleton.getBodyNode(i).getName() for i in range(entity.skeleton.getNumBodyNodes())]
    assert sorted(names) == ["arm", "base"]
    assert isinstance(entity.skeleton.getRootJoint(), dart.dynamics.FreeJoint)
    assert "camera_optical, tool, weight" in entity.info.warnings[-1]


def test_a_sensor_on_a_frame_rides_its_body():
    pytest.importorskip("dartpy")
    from nodes.sim.urdf_info import parse_urdf as sim_parse

    imu = """<gazebo reference="camera_optical"><sensor name="imu" type="imu"><update_rate>100</update_rate>
      </sensor></gazebo>"""
    info = sim_parse(robot(SENSOR_FRAME, SENSOR_JOINTS + imu))
    (sensor,) = info.sensors
    assert sensor.link == "base"
    assert sensor.pose[:3, 3] == pytest.approx([0.1, 0, 0.2])


def test_a_sensor_declared_twice_on_one_link_is_one_sensor():
    camera = """<sensor name="cam" type="camera"><update_rate>5</update_rate><camera><horizontal_fov>1</horizontal_fov>
      <image><width>8</width><height>6</height><format>R8G8B8</format></image><clip><near>0.1</near>
      <far>5</far></clip></camera></sensor>"""
    model = parse_urdf(robot(extra_joints=f'<gazebo reference="base">{camera}{camera}</gazebo>'))
    assert [s.name for s in model.rendered_sensors] == ["cam"]
    assert any("declared again" in w for w in model.warnings)


def test_a_floating_root_without_mass_is_refused_named():
    pytest.importorskip("dartpy")
    from nodes.sim.entity import Entity, EntitySpec
    from nodes.sim.pose import SpawnError

    xml = robot().replace('<link name="base"><inertial><mass value="2"/>' + INERTIA + "</inertial>",
                          '<link name="base">')
    with pytest.raises(SpawnError, match="root link 'base' of a floating base has no mass"):
        Entity(EntitySpec(name="r", xml=xml))
    assert not Entity(EntitySpec(name="r", xml=xml, fixed=True)).floating   # welded: its mass does not matter
