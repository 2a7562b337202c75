"""The simulated sensors against physics (in-process DART): a humanoid standing still reads gravity on its IMU and
its weight on its ankle force/torque sensors; the conventions of frame and direction; noise that is repeatable."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodes.sim.config import parse_gains
from nodes.sim.entity import EntitySpec, Pose
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = (ROOT / "robots" / "humanoid.urdf").read_text()
FOOT_MASS = 1.2   # each foot hangs below its ankle sensor


def make_sim(seed: int = 0, ground: bool = True, enabled: bool = True) -> Simulation:
    world = PhysicsWorld(1000.0, (0.0, 0.0, -9.81))
    if ground:
        world.add_ground()
    return Simulation(world, parse_gains({"*": {"p": 3000.0, "d": 30.0}}), None, "lockstep", sensor_seed=seed,
                      sensors_enabled=enabled)


def run(sim: Simulation, steps: int, namespace: str = "humanoid") -> np.ndarray:
    frames = []
    for _ in range(steps):
        sim.sample_sensors()
        frames.append(sim.sensors[namespace].state_values())
        sim.step(1)
    return np.array(frames)


@pytest.fixture(scope="module")
def standing():
    sim = make_sim()
    sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.93)))
    run(sim, 1500)   # settle onto the ground
    yield sim, run(sim, 500)
    sim.clear()


def test_hardware_frame_layout_follows_the_declared_interfaces(standing):
    sim, frames = standing
    table = sim.sensors["humanoid"].table()
    assert [row["name"] for row in table] == ["imu_sensor", "left_foot_ft", "right_foot_ft"]
    assert [row["frame_id"] for row in table] == ["pelvis", "left_foot", "right_foot"]
    assert frames.shape[1] == 10 + 6 + 6 == sim.sensors["humanoid"].count


def test_standing_still_the_imu_reads_gravity_up_and_no_rotation(standing):
    _, frames = standing
    orientation, angular, linear = frames[:, 0:4], frames[:, 4:7], frames[:, 7:10]
    assert np.abs(linear - [0.0, 0.0, 9.81]).max() < 0.3     # specific force: +g on the up axis (noise and bias in)
    assert np.abs(angular).max() < 0.05
    assert np.abs(orientation - [0, 0, 0, 1]).max() < 1e-3  # upright pelvis: identity in the world


def test_standing_still_the_ankle_sensors_carry_the_weight_above_them(standing):
    sim, frames = standing
    weight_above = (sim.entities["humanoid"].skeleton.getMass() - 2 * FOOT_MASS) * 9.81
    left, right = frames[:, 10:16], frames[:, 16:22]
    # child_to_parent in the foot frame: the foot pushes the leg up
    assert (left[:, 2] + right[:, 2]).mean() == pytest.approx(weight_above, rel=0.01)
    assert left[:, 2].mean() == pytest.approx(right[:, 2].mean(), rel=0.05)
    assert np.abs(left[:, :2]).max() < 0.02 * weight_above


def test_hanging_foot_force_and_torque_follow_measure_direction_and_frame():
    xml = HUMANOID.replace("<measure_direction>child_to_parent</measure_direction>",
                           "<measure_direction>parent_to_child</measure_direction>", 1)
    sim = make_sim(ground=False)
    sim.spawn(EntitySpec("humanoid", xml, fixed=True, pose=Pose.from_xyz_rpy(0, 0, 2.0)))
    frames = run(sim, 400)
    left, right = frames[-1, 10:16], frames[-1, 16:22]
    weight = FOOT_MASS * 9.81
    # right (child_to_parent): the hanging foot pulls the leg down; left (parent_to_child): the leg holds it up
    assert right[2] == pytest.approx(-weight, rel=1e-3) and left[2] == pytest.approx(weight, rel=1e-3)
    # the foot's centre of mass is 3 cm ahead of the ankle: its weight's moment about the joint origin
    assert right[4] == pytest.approx(0.03 * weight, rel=1e-2) and left[4] == pytest.approx(-0.03 * weight, rel=1e-2)
    sim.clear()


def test_noise_is_the_same_for_a_seed_and_differs_between_seeds():
    traces = []
    for seed in (7, 7, 8):
        sim = make_sim(seed)
        sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.93)))
        traces.append(run(sim, 300))
        sim.clear()
    assert np.array_equal(traces[0], traces[1])                      # bit-identical
    assert not np.array_equal(traces[0][:, 4:10], traces[2][:, 4:10])
    assert np.array_equal(traces[0][:, 10:], traces[2][:, 10:])      # the F/T sensors have no noise declared


def test_sensor_rate_holds_values_between_samples_and_reset_replays_them():
    xml = HUMANOID.replace("<update_rate>1000</update_rate>", "<update_rate>250</update_rate>", 1)   # the IMU
    sim = make_sim(seed=3)
    sim.spawn(EntitySpec("humanoid", xml, pose=Pose.from_xyz_rpy(0, 0, 0.93)))
    first = run(sim, 40)
    imu = first[:, 4:10]
    changes = np.nonzero(np.any(np.diff(imu, axis=0) != 0, axis=1))[0] + 1
    assert list(changes) == list(range(4, 40, 4))        # a new reading every 4 control periods (250 Hz at 1 kHz)
    sim.reset_simulation()
    again = run(sim, 40)
    assert np.array_equal(again[:, :10], first[:, :10])   # reset: the same readings, noise included
    # (before the first step after a reset DART still holds the last joint wrenches: ~1e-15 N, not zero)
    assert np.array_equal(again[1:], first[1:])
    sim.clear()


def test_sensors_switched_off_leave_no_state_interfaces():
    sim = make_sim(enabled=False)
    sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.93)))
    assert sim.sensors["humanoid"].table() == [] and run(sim, 2).shape == (2, 0)
    sim.clear()
