"""The squat commander's pure logic: compensation geometry, profile sampling, joint-limit refusals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from msgs import duration_to_sec
from nodes.commanders.joint_commander import LEG_JOINTS
from nodes.commanders.squat import (
    SquatError,
    check_limits,
    leg_lengths,
    leg_targets,
    min_jerk,
    squat_cycle,
    squat_pose,
)
from nodes.kinematics import KinematicTree
from nodes.urdf import load_robot_description, parse_urdf

ROBOTS = Path(__file__).resolve().parents[2] / "robots"
HUMANOID = parse_urdf((ROBOTS / "humanoid.urdf").read_text())


def test_min_jerk_starts_and_ends_at_rest():
    assert min_jerk(0.0) == (0.0, 0.0, 0.0)
    assert min_jerk(1.0) == (1.0, 0.0, 0.0)
    s, ds, _ = min_jerk(0.5)
    assert s == pytest.approx(0.5) and ds == pytest.approx(1.875)     # the peak speed factor


def test_squat_keeps_the_soles_flat_and_the_hip_over_the_ankle():
    thigh, shin = leg_lengths(HUMANOID, "left")
    assert (thigh, shin) == (pytest.approx(0.35), pytest.approx(0.35))
    pose = squat_pose(0.785, thigh, shin)
    assert pose.hip_pitch + pose.knee + pose.ankle_pitch == pytest.approx(0.0)     # sole parallel to the ground
    assert pose.hip_pitch == pytest.approx(-0.3925)                               # equal segments: half each
    unequal = squat_pose(0.785, 0.4, 0.3)
    assert 0.4 * math.sin(-unequal.hip_pitch) == pytest.approx(0.3 * math.sin(-unequal.ankle_pitch))
    # forward kinematics: hip straight above the ankle, foot flat, pelvis lower by the right amount
    tree = KinematicTree(HUMANOID)
    q = tree.configuration(leg_targets(pose))
    for side in ("left", "right"):
        hip = tree.link_transform(q, f"{side}_thigh")[:3, 3]
        ankle = tree.link_transform(q, f"{side}_ankle_pitch_link")[:3, 3]
        foot = tree.link_transform(q, f"{side}_foot")[:3, :3]
        assert hip[0] == pytest.approx(ankle[0], abs=1e-9)
        np.testing.assert_allclose(foot, np.eye(3), atol=1e-9)
        assert hip[2] - ankle[2] == pytest.approx(0.7 * math.cos(0.785 / 2))


def test_cycle_samples_positions_velocities_and_accelerations():
    bottom = leg_targets(squat_pose(0.785, 0.35, 0.35))
    msg = squat_cycle(LEG_JOINTS, bottom, 2.0, 1.0, 2.0, 0.1)
    times = [duration_to_sec(p.time_from_start) for p in msg.points]
    assert times[0] == pytest.approx(0.1) and times[-1] == pytest.approx(5.0)
    assert all(b > a for a, b in zip(times, times[1:]))
    assert len(msg.points) == 20 + 1 + 20
    knee = LEG_JOINTS.index("left_knee")
    assert msg.points[19].positions[knee] == pytest.approx(0.785) and msg.points[19].velocities[knee] == 0.0
    assert msg.points[20].positions[knee] == pytest.approx(0.785) and times[20] == pytest.approx(3.0)
    assert msg.points[-1].positions[knee] == pytest.approx(0.0)
    assert all(len(p.velocities) == len(p.accelerations) == 12 for p in msg.points)
    assert max(p.velocities[knee] for p in msg.points) == pytest.approx(1.875 * 0.785 / 2.0)
    # velocities are the derivative of the positions (finite differences agree)
    pos = [p.positions[knee] for p in msg.points[:20]]
    vel = [p.velocities[knee] for p in msg.points[:20]]
    for k in range(1, 19):
        assert (pos[k + 1] - pos[k - 1]) / 0.2 == pytest.approx(vel[k], abs=0.02)


def test_a_target_outside_a_limit_is_refused_naming_joint_value_and_limit():
    deep = leg_targets(squat_pose(2.6, 0.35, 0.35))
    with pytest.raises(SquatError, match=r"joint 'left_knee' would reach 2\.6 rad \(squat\), above its upper limit "
                                         r"2\.4 rad"):
        check_limits(HUMANOID, deep, 2.0)
    with pytest.raises(SquatError, match=r"joint 'left_ankle_pitch' would reach -1\.1 rad \(squat\), below its lower "
                                         r"limit -0\.9 rad"):
        check_limits(HUMANOID, leg_targets(squat_pose(2.2, 0.35, 0.35)), 2.0)
    check_limits(HUMANOID, leg_targets(squat_pose(0.785, 0.35, 0.35)), 2.0)     # the exercise's squat is fine


def test_too_fast_for_the_20_dof_variant_is_refused_with_the_velocity_limit():
    variant = parse_urdf(load_robot_description(ROBOTS / "humanoid_20dof.urdf.xacro"))
    targets = leg_targets(squat_pose(0.785, 0.35, 0.35))
    check_limits(variant, targets, 2.0)                                          # 0.74 rad/s peak: fine
    with pytest.raises(SquatError, match=r"joint 'left_knee' would move at 2\.944 rad/s, above its velocity limit "
                                         r"2 rad/s"):
        check_limits(variant, targets, 0.5)
