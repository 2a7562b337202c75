"""The shared URDF model's visual/collision geometry, materials, ``<ros2_control>`` bounds and source lines."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodes.urdf.model import DEFAULT_RGBA, UrdfError, parse_urdf

LEG = """<robot name="leg">
  <material name="red"><color rgba="1 0 0 1"/></material>
  <link name="hip">
    <visual><geometry><box size="0.2 0.2 0.1"/></geometry><material name="red"/></visual>
    <collision><origin xyz="0 0 0.1"/><geometry><mesh filename="hip.stl" scale="2 2 2"/></geometry></collision>
  </link>
  <link name="thigh">
    <visual><origin xyz="0 0 -0.2" rpy="0 0 1.5707963267948966"/>
      <geometry><cylinder radius="0.05" length="0.4"/></geometry>
      <material name="inline"><color rgba="0 0 1 0.5"/></material></visual>
  </link>
  <link name="foot"><visual><geometry><sphere radius="0.05"/></geometry><material name="nope"/></visual></link>
  <joint name="hip_pitch" type="revolute"><parent link="hip"/><child link="thigh"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="ankle" type="fixed"><parent link="thigh"/><child link="foot"/><origin xyz="0 0 -0.4"/></joint>
  <ros2_control name="GazeboSystem" type="system">
    <joint name="hip_pitch">
      <command_interface name="position"><param name="min">-0.5</param><param name="max">0.5</param></command_interface>
      <command_interface name="velocity"><param name="max">inf</param></command_interface>
      <command_interface name="effort"/>
      <state_interface name="position"/>
    </joint>
  </ros2_control>
</robot>"""


def test_visuals_collisions_and_materials() -> None:
    model = parse_urdf(LEG)
    hip, thigh, foot = (model.links[name] for name in ("hip", "thigh", "foot"))
    assert model.materials == {"red": (1.0, 0.0, 0.0, 1.0)}
    assert [v.kind for v in hip.visuals + thigh.visuals + foot.visuals] == ["box", "cylinder", "sphere"]
    assert hip.visuals[0].size == (0.2, 0.2, 0.1) and hip.visuals[0].rgba == (1.0, 0.0, 0.0, 1.0)
    assert hip.visuals[0].material == "red"
    assert thigh.visuals[0].rgba == (0.0, 0.0, 1.0, 0.5)  # inline colour wins
    assert foot.visuals[0].rgba == DEFAULT_RGBA  # unknown material name: grey
    assert (thigh.visuals[0].radius, thigh.visuals[0].length) == (0.05, 0.4)
    assert np.allclose(thigh.visuals[0].origin[:3, 3], [0, 0, -0.2])
    assert np.allclose(thigh.visuals[0].origin[:3, :3] @ [1, 0, 0], [0, 1, 0])
    [mesh] = hip.collisions
    assert (mesh.kind, mesh.filename, mesh.scale) == ("mesh", "hip.stl", (2.0, 2.0, 2.0))
    assert hip.has_visual and hip.has_collision and not thigh.has_collision
    assert model.visual_links() == ["hip", "thigh", "foot"] and model.leaf_links() == ["foot"]
    assert mesh.line == 5 and model.joints["ankle"].line == 15 and model.line == 1


def test_ros2_control_interfaces_and_numeric_bounds() -> None:
    [joint] = parse_urdf(LEG).ros2_control
    assert joint.name == "hip_pitch" and joint.line == 17
    assert joint.command_interfaces == ["position", "velocity", "effort"]
    assert joint.state_interfaces == ["position"]
    assert joint.params["position"] == {"min": "-0.5", "max": "0.5"}
    assert joint.bounds == {"position": (-0.5, 0.5), "velocity": (-math.inf, math.inf)}


@pytest.mark.parametrize("old, new, reason, line", [
    ('<box size="0.2 0.2 0.1"/>', '<box size="0.2 0.2"/>', "link 'hip', visual 0: <box size='0.2 0.2'> needs 3", 4),
    ('<sphere radius="0.05"/>', '<sphere radius="nan"/>', "<sphere radius='nan'> is not finite", 12),
    ('<sphere radius="0.05"/>', "<cone/>", "unknown geometry 'cone'", 12),
    ('<mesh filename="hip.stl" scale="2 2 2"/>', "<mesh/>", "link 'hip', collision 0: <mesh> has no filename", 5),
    ('<param name="min">-0.5</param>', '<param name="min">nan</param>', "<param name='min'> value is NaN", 18),
    ('<param name="min">-0.5</param>', '<param name="min">low</param>', "value 'low' is not a number", 18),
    ('<color rgba="0 0 1 0.5"/>', '<color rgba="0 0 1"/>', "<color rgba='0 0 1'> needs 4", 10),
    ('<limit lower="-1"', '<limit lower="x"', "<limit lower='x'> is not a number", 14),
])
def test_errors_name_the_element_reason_and_line(old: str, new: str, reason: str, line: int) -> None:
    assert old in LEG
    with pytest.raises(UrdfError) as info:
        parse_urdf(LEG.replace(old, new))
    assert reason in str(info.value)
    assert info.value.line == line


def test_syntax_errors_carry_the_line_and_entities_are_refused() -> None:
    with pytest.raises(UrdfError, match="XML syntax error") as info:
        parse_urdf(LEG.replace("</robot>", ""))
    assert info.value.line == 24
    with pytest.raises(UrdfError, match="declares entities"):
        parse_urdf('<!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="r"><link name="&a;"/></robot>')
