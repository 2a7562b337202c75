"""The tutorials' commander nodes: their trajectories (pure logic) and one real process on real Zenoh."""

from __future__ import annotations

import math
import threading

import msgpack

from msgs import duration_to_sec
from msgs.sensor_msgs import JointState
from nodes.commanders.joint_animation import ATLAS_JOINTS, animation, expected_position, waves
from nodes.commanders.joint_commander import LEG_JOINTS, knee_bend_pose, pose_for
from nodes.commanders.joint_monitor import report
from nodes.commanders.joint_sweep import movable_joints, sweep_positions
from nodes.commanders.trajectories import single_point, waveform_points
from nodes.commanders.wave_controller import wave_targets
from tests.conftest import wait_until


def test_joint_commander_poses_match_the_tutorial() -> None:
    bend = knee_bend_pose(LEG_JOINTS, -0.2, 0.4, -0.2)
    assert bend == [0.0, 0.0, -0.2, 0.4, -0.2, 0.0] * 2
    assert pose_for(0, LEG_JOINTS, bend) == [0.0] * 12
    assert pose_for(1, LEG_JOINTS, bend) == bend
    assert pose_for(2, LEG_JOINTS, bend) == [0.0] * 12
    msg = single_point(LEG_JOINTS, bend, 1.0)
    assert duration_to_sec(msg.points[0].time_from_start) == 1.0


def test_wave_targets_are_anti_phase_arms_and_legs() -> None:
    at_zero = wave_targets(0.0)
    assert at_zero == {"left_arm_controller": 0.0, "right_arm_controller": -0.0,
                       "left_leg_controller": 0.5, "right_leg_controller": -0.5}
    quarter = wave_targets(math.pi / 2)
    assert math.isclose(quarter["left_arm_controller"], 1.0) and math.isclose(quarter["right_arm_controller"], -1.0)
    assert abs(quarter["left_leg_controller"]) < 1e-12


def test_controller_lab_waveforms() -> None:
    sine = waveform_points("sine", 1.57, 0.1, 10.0, 0.1)
    assert len(sine) == 100
    assert duration_to_sec(sine[0].time_from_start) == 0.0
    assert math.isclose(duration_to_sec(sine[-1].time_from_start), 9.9)
    assert math.isclose(max(p.positions[0] for p in sine), 1.57)
    assert math.isclose(sine[25].positions[0], 1.57)
    square = waveform_points("square", 1.0, 0.5, 4.0, 0.1)
    assert {p.positions[0] for p in square} == {1.0, -1.0}
    times = [duration_to_sec(p.time_from_start) for p in square]
    assert all(b > a for a, b in zip(times, times[1:]))


def test_atlas_animation_is_the_tutorials_1500_points() -> None:
    msg = animation()
    assert len(msg.points) == 1500 and len(msg.joint_names) == 28 == len(ATLAS_JOINTS)
    assert msg.header.frame_id == "pelvis"
    times = [duration_to_sec(p.time_from_start) for p in msg.points]
    assert math.isclose(times[0], 0.01) and math.isclose(times[-1], 15.0)
    assert all(b > a for a, b in zip(times, times[1:]))
    x1, x2 = waves(300)
    theta = 0.05 * 2 * math.pi * 300 * 0.01
    assert math.isclose(x1, -0.5 * math.sin(2 * theta)) and math.isclose(x2, 0.5 * math.sin(theta))
    row = msg.points[300].positions
    assert row[ATLAS_JOINTS.index("back_lbz")] == x1 and row[ATLAS_JOINTS.index("back_mby")] == x2
    assert row[ATLAS_JOINTS.index("r_arm_uwy")] == x1 and row[ATLAS_JOINTS.index("l_arm_uwy")] == x2
    assert math.isclose(expected_position("back_mby", 3.01), x2)
    prefixed = animation(n=2, prefix="atlas::")
    assert prefixed.joint_names[0] == "atlas::back_lbz" and prefixed.header.frame_id == "atlas::pelvis"


def test_sweep_stays_inside_joint_limits() -> None:
    joints = movable_joints("humanoid_simplified")
    assert [j[0] for j in joints][:3] == ["left_shoulder_joint", "left_elbow_joint", "left_wrist_joint"]
    limits = [(lo, hi) for _, lo, hi in joints]
    for step in range(200):
        for (lo, hi), q in zip(limits, sweep_positions(limits, step * 0.1, 0.2, 0.8)):
            assert lo <= q <= hi


def test_monitor_report_lines() -> None:
    lines = report(JointState(name=["a", "b"], position=[0.123, -1.0], velocity=[0.5]))
    assert lines == ["=== Joint States ===", "a: pos=0.12, vel=0.50", "b: pos=-1.00, vel=0.00"]


def test_joint_commander_process_alternates_stand_and_bend(processes, session) -> None:
    """A third-party subscriber (zenoh + msgpack only) sees pose 0, pose 1, pose 0 ... on the JTC topic."""
    received: list[dict] = []
    lock = threading.Lock()

    def on_sample(sample) -> None:
        with lock:
            received.append(msgpack.unpackb(sample.payload.to_bytes()))

    sub = session.declare_subscriber("humanoid/joint_trajectory_controller/joint_trajectory", on_sample)
    try:
        proc = processes.start("-m", "nodes.commanders.joint_commander", "--ns", "humanoid", "--param",
                               "period:=0.2", name="joint_commander")
        wait_until(lambda: len(received) >= 4, 30, 0.05, "four commands from the joint commander")
        with lock:
            first = received[:4]
        knees = [m["points"][0]["positions"][m["joint_names"].index("left_knee")] for m in first]
        assert knees in ([0.0, 0.4, 0.0, 0.4], [0.4, 0.0, 0.4, 0.0])
        assert first[0]["joint_names"] == LEG_JOINTS
        assert first[0]["points"][0]["time_from_start"] == {"sec": 1, "nanosec": 0}
        assert "Sent command (pose 1)" in processes.output(proc)
    finally:
        sub.undeclare()
