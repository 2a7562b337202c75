"""Cameras and range sensors as Gazebo users declare them (nodes/urdf/rendered_sensors.py): what is read, the
topics gazebo_ros' camera and ray plugins resolve to, and every bad declaration refused with the sensor and the
field named (the simulator refuses such a robot at spawn; ``zenroid check_urdf`` reports it)."""

from __future__ import annotations

import math

import pytest
from lxml import etree

from nodes.sim.urdf_info import UrdfError
from nodes.sim.urdf_info import parse_urdf as sim_parse
from nodes.urdf.rendered_sensors import MAX_PIXELS, MAX_RAYS, parse_rendered_sensors, rendered_sensor_problems

CAMERA = """<gazebo reference="head"><sensor name="cam" type="{type}"><update_rate>{rate}</update_rate>
  <camera><horizontal_fov>{fov}</horizontal_fov><image><width>{w}</width><height>{h}</height>
  <format>{format}</format></image><clip><near>{near}</near><far>{far}</far></clip></camera>
  <plugin name="cam_plugin" filename="libgazebo_ros_camera.so"><ros><namespace>/eyes</namespace>
  <remapping>cam/image_raw:=cam/rgb</remapping></ros><frame_name>{frame}</frame_name></plugin></sensor></gazebo>"""
RAY = """<gazebo reference="head"><sensor name="laser" type="ray"><update_rate>{rate}</update_rate>
  <ray><scan><horizontal><samples>{samples}</samples><resolution>1</resolution><min_angle>{low}</min_angle>
  <max_angle>{high}</max_angle></horizontal>{vertical}</scan><range><min>{rmin}</min><max>{rmax}</max>
  <resolution>0.01</resolution></range></ray>
  <plugin name="laser" filename="libgazebo_ros_ray_sensor.so"><ros><remapping>~/out:=scan</remapping></ros>
  <output_type>{output}</output_type><frame_name>head</frame_name></plugin></sensor></gazebo>"""
CAMERA_OK = dict(type="depth", rate=30, fov=1.047, w=320, h=240, format="R8G8B8", near=0.05, far=10, frame="head")
RAY_OK = dict(rate=20, samples=720, low=-1.5708, high=1.5708, vertical="", rmin=0.1, rmax=10,
              output="sensor_msgs/LaserScan")


def robot(*gazebo: str) -> str:
    return ('<robot name="r"><link name="base"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" '
            'ixz="0" iyz="0"/></inertial></link><link name="head"><inertial><mass value="1"/><inertia ixx="1" '
            'iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link><joint name="neck" type="fixed"><parent '
            'link="base"/><child link="head"/></joint>' + "".join(gazebo) + "</robot>")


def specs(xml: str, namespace: str = "r"):
    return parse_rendered_sensors(etree.fromstring(xml.encode()), namespace)


def test_a_depth_camera_and_a_laser_are_read_with_their_plugins_topics_and_frames():
    camera, laser = specs(robot(CAMERA.format(**CAMERA_OK), RAY.format(**RAY_OK)))
    assert (camera.name, camera.type, camera.update_rate, camera.frame_id) == ("cam", "depth", 30.0, "head")
    assert (camera.camera.width, camera.camera.height, camera.camera.encoding, camera.camera.depth) == \
        (320, 240, "rgb8", True)
    assert camera.camera.focal == pytest.approx(320 / (2 * math.tan(1.047 / 2)))
    # gazebo_ros_camera: <camera_name> (the sensor's name) in the namespace, remapped where asked
    assert camera.keys == {"image": "eyes/cam/rgb", "camera_info": "eyes/cam/camera_info",
                           "depth": "eyes/cam/depth/image_raw", "depth_info": "eyes/cam/depth/camera_info",
                           "points": "eyes/cam/points"}
    # gazebo_ros_ray_sensor: ~/out of the plugin's node, here remapped, in the robot's namespace
    assert laser.keys == {"scan": "r/scan"} and laser.ray.output == "scan" and not laser.ray.visual
    assert (laser.ray.horizontal.count, laser.ray.vertical.count, laser.ray.range_max) == (720, 1, 10.0)
    assert rendered_sensor_problems([camera, laser], {"base", "head"}, physics_rate=1000.0) == []


def test_defaults_without_a_plugin_or_a_rate():
    bare = ('<gazebo reference="head"><sensor name="lidar" type="gpu_lidar"><lidar><scan><horizontal>'
            '<samples>900</samples><min_angle>-3.14</min_angle><max_angle>3.13</max_angle></horizontal><vertical>'
            '<samples>16</samples><min_angle>-0.26</min_angle><max_angle>0.26</max_angle></vertical></scan>'
            '</lidar></sensor></gazebo>')
    (lidar,) = specs(robot(bare))
    assert lidar.update_rate == 10.0 and lidar.ray.visual and lidar.ray.output == "points"
    assert lidar.keys == {"points": "r/lidar/points"} and lidar.ray.rays == 900 * 16
    assert list(lidar.ray.vertical.angles())[0] == pytest.approx(-0.26)


def test_the_shipped_humanoid_sees_with_the_contract_keys():
    from nodes.sim.robot_files import read_robot_xml
    from tests.unit.test_sensor_declarations import ROOT

    info = sim_parse(read_robot_xml(ROOT / "robots" / "humanoid.urdf"))
    keys = {spec.name: spec.keys for spec in info.rendered_sensors}
    resolved = {name: {o: f"humanoid/{k}" for o, k in outputs.items()} for name, outputs in keys.items()}
    assert resolved == {
        "camera": {"image": "humanoid/camera/rgb", "camera_info": "humanoid/camera/camera_info",
                   "depth": "humanoid/camera/depth", "depth_info": "humanoid/camera/depth/camera_info",
                   "points": "humanoid/camera/points"},
        "lidar": {"points": "humanoid/lidar/points"},
        "laser": {"scan": "humanoid/scan"},
    }
    frames = {spec.name: spec.frame_id for spec in info.rendered_sensors}
    assert frames == {"camera": "camera_optical_frame", "lidar": "lidar_link", "laser": "laser_link"}


BAD = [
    ("pixel cap", CAMERA, dict(CAMERA_OK, w=4000, h=3000), [f"over the cap of {MAX_PIXELS}"]),
    ("zero width", CAMERA, dict(CAMERA_OK, w=0), ["width and height must be at least 1"]),
    ("fov zero", CAMERA, dict(CAMERA_OK, fov=0), ["<horizontal_fov> 0: must be in (0, pi)"]),
    ("fov pi", CAMERA, dict(CAMERA_OK, fov=3.1416), ["<horizontal_fov> 3.1416: must be in (0, pi)"]),
    ("near >= far", CAMERA, dict(CAMERA_OK, near=2, far=2), ["<clip> near 2 far 2"]),
    ("unknown format", CAMERA, dict(CAMERA_OK, format="BAYER_RGGB8"), ["<format> 'BAYER_RGGB8' is not one of"]),
    ("zero rate", CAMERA, dict(CAMERA_OK, rate=0), ["<update_rate> 0: must be a positive number"]),
    ("negative rate", CAMERA, dict(CAMERA_OK, rate=-1), ["<update_rate> -1"]),
    ("frame TF does not have", CAMERA, dict(CAMERA_OK, frame="nowhere"), ["<frame_name> 'nowhere' is not a link"]),
    ("rays cap", RAY, dict(RAY_OK, samples=2000, vertical="<vertical><samples>1000</samples><resolution>1"
                                                          "</resolution><min_angle>-0.5</min_angle><max_angle>0.5"
                                                          "</max_angle></vertical>"),
     [f"2000 x 1000 = 2000000 rays a scan, over the cap of {MAX_RAYS}"]),
    ("min range >= max", RAY, dict(RAY_OK, rmin=5, rmax=1), ["<range> min 5 max 1"]),
    ("angles reversed", RAY, dict(RAY_OK, low=1, high=-1), ["<min_angle> 1 > <max_angle> -1"]),
    ("zero samples", RAY, dict(RAY_OK, samples=0), ["<samples> 0: must be at least 1"]),
]


@pytest.mark.parametrize("case, template, values, expected", BAD, ids=[b[0] for b in BAD])
def test_bad_declarations_are_refused_naming_sensor_and_field(case, template, values, expected):
    problems = rendered_sensor_problems(specs(robot(template.format(**values))), {"base", "head"}, 1000.0)
    name = "cam" if template is CAMERA else "laser"
    assert problems and all(f"sensor '{name}'" in p for p in problems), problems
    for text in expected:
        assert any(text in p for p in problems), (text, problems)
    with pytest.raises(UrdfError, match=f"sensor '{name}'"):   # and the simulator refuses the robot
        sim_parse(robot(template.format(**values)))


def test_a_rate_above_the_physics_rate_and_an_unknown_output_type_are_refused():
    (camera,) = specs(robot(CAMERA.format(**dict(CAMERA_OK, rate=2000))))
    assert any("over the physics rate (1000 Hz)" in p for p in rendered_sensor_problems([camera], {"head"}, 1000.0))
    with pytest.raises(UrdfError, match=r"sensor 'laser'.*<output_type> 'sensor_msgs/Range' is not one of"):
        sim_parse(robot(RAY.format(**dict(RAY_OK, output="sensor_msgs/Range"))))
    with pytest.raises(UrdfError, match=r"sensor 'cam'.*<width>: '1e3x' is not a number"):
        sim_parse(robot(CAMERA.format(**dict(CAMERA_OK, w="1e3x"))))
