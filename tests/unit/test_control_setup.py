"""A <ros2_control> block and controllers file generated for a robot without one (zenroid setup_robot)."""

from __future__ import annotations

from pathlib import Path

import yaml

from nodes.share.controllers import broadcasters
from nodes.sim.urdf_info import parse_urdf as sim_parse
from nodes.tools.cli import main
from nodes.urdf import parse_urdf
from nodes.urdf.control_setup import control_block, controllers_config, limbs

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = (ROOT / "robots" / "humanoid.urdf").read_text()
BARE = HUMANOID[:HUMANOID.index("<ros2_control")] + HUMANOID[HUMANOID.index("</ros2_control>") + 15:]


def test_every_movable_joint_and_declared_sensor_is_in_the_block():
    model = parse_urdf(BARE)
    block = control_block(model)
    for joint in model.movable_joints():
        assert f'<joint name="{joint.name}">' in block
    assert block.count('<command_interface name="position"/>') == len(model.movable_joints())
    assert '<sensor name="imu_sensor">' in block and '<sensor name="left_foot_ft">' in block


def test_the_simulator_runs_the_block_it_would_write():
    info = sim_parse(BARE)
    assert not info.has_ros2_control
    assert all(j.command_interfaces == ["position"] and j.state_interfaces == ["position", "velocity"]
               for j in info.joints)
    assert any("no <ros2_control> block: generated one" in w for w in info.warnings)


def test_controllers_from_the_robot_and_its_own_block_wins():
    config = controllers_config(parse_urdf(BARE))
    joints = config["joint_trajectory_controller"]["ros__parameters"]["joints"]
    assert joints == [j.name for j in parse_urdf(BARE).movable_joints()]
    assert sorted(broadcasters(config)) == ["imu_sensor_broadcaster", "left_foot_ft_broadcaster",
                                            "right_foot_ft_broadcaster"]
    own = controllers_config(parse_urdf(HUMANOID))   # the humanoid's block lists the same joints, its order
    assert own["joint_trajectory_controller"]["ros__parameters"]["joints"] == [
        j.name for j in parse_urdf(HUMANOID).ros2_control]


def test_limbs_from_name_patterns():
    grouped = limbs(["left_hip_pitch_joint", "left_knee_joint", "right_ankle_roll", "left_shoulder_pitch",
                     "waist_yaw_joint", "leg_left_4_joint", "something_else"])
    assert grouped == {"left_leg": ["left_hip_pitch_joint", "left_knee_joint", "leg_left_4_joint"],
                       "right_leg": ["right_ankle_roll"], "left_arm": ["left_shoulder_pitch"],
                       "torso": ["waist_yaw_joint"]}


def test_setup_robot_writes_the_files(tmp_path, capsys):
    urdf = tmp_path / "bare.urdf"
    urdf.write_text(BARE)
    assert main(["setup_robot", str(urdf), "-o", str(tmp_path / "out"), "--per-limb"]) == 0
    said = capsys.readouterr().out
    assert "generated a <ros2_control> block (22 joints" in said and str(tmp_path / "out") in said
    config = yaml.safe_load((tmp_path / "out" / "humanoid_controllers.yaml").read_text())
    assert "left_leg_controller" in config["controller_manager"]["ros__parameters"]
    written = (tmp_path / "out" / "humanoid.urdf").read_text()
    assert parse_urdf(written).ros2_control and (tmp_path / "out" / "humanoid.ros2_control.xml").is_file()
