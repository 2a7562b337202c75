"""The joint servo of the simulator's hardware interface (nodes/sim/hardware.py), in process with DART: velocity
limits held by DART's joint limit constraint, the saturated-motor switch, effort and velocity commands, what is
reported, and bit-identical replays."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nodes.sim.config import parse_gains
from nodes.sim.entity import EntitySpec, Pose
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld

ROOT = Path(__file__).resolve().parents[2]
ARM = (ROOT / "tests" / "data" / "sim_arm.urdf").read_text()
INERTIA = '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>'
# A revolute joint (URDF velocity 0: no limit), then a continuous one limited to 1.5 rad/s.
SPINNER = f"""<robot name="spinner">
  <link name="base"><inertial><mass value="1"/>{INERTIA}</inertial></link>
  <link name="a"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>{INERTIA}</inertial></link>
  <link name="b"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>{INERTIA}</inertial></link>
  <joint name="free_speed" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="0" effort="10"/></joint>
  <joint name="wheel" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0.4 0 0"/>
    <axis xyz="0 0 1"/><limit velocity="1.5" effort="10"/></joint>
</robot>"""
DT = 0.001


@pytest.fixture
def make_sim():
    created: list[Simulation] = []

    def make(gravity=(0.0, 0.0, 0.0), p: float = 2000.0, d: float = 20.0) -> Simulation:
        sim = Simulation(PhysicsWorld(1.0 / DT, gravity), parse_gains({"*": {"p": p, "d": d}}))
        created.append(sim)
        return sim

    yield make
    for sim in created:
        sim.clear()


def spawn(sim: Simulation, xml: str = ARM, name: str = "arm"):
    sim.spawn(EntitySpec(name, xml, fixed=True, pose=Pose.from_xyz_rpy(0, 0, 0.5)))
    return sim.hardware[name]


# -- velocity limits ----------------------------------------------------------------------------------------
def test_continuous_joint_velocity_limit_holds_for_velocity_and_position(make_sim):
    """DART enforces only the limits of joints whose limits are enforced; a continuous joint's velocity limit is
    held too (its position limits are infinite), and the position advances no faster than the limit."""
    sim = make_sim()
    hw = spawn(sim, SPINNER, "spinner")
    hw.apply_command(["wheel"], ["position"], [100.0])   # far away: the spring saturates at 10 Nm
    fastest = 0.0
    for _ in range(1500):
        sim.step(1)
        fastest = max(fastest, abs(hw.velocities()[1]))
    assert fastest == pytest.approx(1.5, rel=1e-8)
    assert hw.positions()[1] <= 1.5 * 1500 * DT        # a post-step clamp of the velocity alone reached 2.54 rad


def test_urdf_velocity_zero_means_no_limit(make_sim):
    """URDF velocity="0" is "no limit" (hardware/info reports 0); DART's loader made it a [0, 0] limit that froze
    the joint once limits were enforced."""
    sim = make_sim()
    hw = spawn(sim, SPINNER, "spinner")
    assert hw.max_velocity[0] == math.inf
    hw.apply_command(["free_speed"], ["position"], [1.0])
    sim.step(300)
    assert hw.positions()[0] > 0.9                 # it stayed at 0 before


def test_velocity_limit_narrowed_by_ros2_control_is_what_dart_enforces(make_sim):
    sim = make_sim()
    hw = spawn(sim, ARM.replace('<command_interface name="velocity"/>',
                                '<command_interface name="velocity"><param name="min">-1.2</param>'
                                '<param name="max">1.2</param></command_interface>'))
    assert hw.max_velocity[0] == 1.2
    hw.apply_command(["shoulder"], ["effort"], [40.0])
    fastest = 0.0
    for _ in range(300):
        sim.step(1)
        fastest = max(fastest, abs(hw.velocities()[0]))
    assert fastest == pytest.approx(1.2, rel=1e-8)


# -- the position servo: target as a spring force, the saturated motor -----------------------------------------
def expected_torque(hw, dt: float) -> np.ndarray:
    """DART's spring-damper torque at the start of a step, per joint: kp (target - q - dt qd) - kd qd."""
    q, qd = hw.positions(), hw.velocities()
    return hw.kp * (hw.target - q - dt * qd) - hw.kd * qd


def test_saturation_switches_the_spring_off_and_back_on(make_sim):
    """A position joint whose spring-damper torque would exceed the effort limit gets exactly the limit as a plain
    force with its spring off; once the torque is back inside, the spring tracks again. Both switches happen."""
    sim = make_sim(gravity=(0.0, 0.0, -9.81))
    hw = spawn(sim)
    world = sim.world.world
    hw.apply_command(["shoulder", "elbow"], ["position", "position"], [0.8, 1.5])
    states, ons, offs = [np.zeros(2, dtype=bool)], 0, 0
    for _ in range(1500):
        torque = np.clip(expected_torque(hw, DT), -hw.max_effort, hw.max_effort)
        hw.before_step(DT)
        saturated = hw.saturated()
        for i, joint in enumerate(hw.dart_joints):
            force = hw.skeleton.getForce(int(hw.dofs[i]))
            if saturated[i]:
                assert joint.getSpringStiffness(0) == 0.0 and joint.getDampingCoefficient(0) == 0.0
                assert abs(force) == hw.max_effort[i]                   # exactly the limit
            else:
                assert joint.getSpringStiffness(0) == hw.kp[i] and joint.getDampingCoefficient(0) == hw.kd[i]
                assert force == hw.kp[i] * hw.target[i]                 # the target, as a spring force
        np.testing.assert_allclose(hw.efforts(), torque, rtol=1e-12, atol=1e-9)
        assert np.all(np.abs(hw.efforts()) <= hw.max_effort)
        ons += int(np.sum(saturated & ~states[-1]))
        offs += int(np.sum(~saturated & states[-1]))
        states.append(saturated)
        world.step()
    assert ons >= 2 and offs >= 2                 # both joints went into saturation and came out of it
    assert not states[-1].any()
    assert hw.positions() == pytest.approx([0.8, 1.5], abs=0.02)


def test_target_as_force_tracks_as_a_moving_rest_position_does(make_sim):
    """DART's spring force is linear in the rest position: the target given as the force kp * target moves the
    joints as moving the rest position would (the same arithmetic up to rounding)."""
    import dartpy as dart

    sim = make_sim(gravity=(0.0, 0.0, -9.81), p=300.0, d=5.0)   # soft: never saturated
    hw = spawn(sim)
    reference = dart.simulation.World()
    reference.setGravity([0.0, 0.0, -9.81])
    reference.setTimeStep(DT)
    robot = sim.entities["arm"].skeleton.clone("reference")
    reference.addSkeleton(robot)
    joints = [robot.getJoint(name) for name in hw.names]
    for joint, kp, kd in zip(joints, hw.kp, hw.kd, strict=True):
        joint.setSpringStiffness(0, float(kp))
        joint.setDampingCoefficient(0, float(kd))
    for k in range(1000):
        targets = [0.3 * math.sin(k / 200), 0.4 * math.sin(k / 300)]   # within the velocity limits
        hw.apply_command(hw.names, ["position"] * 2, targets)
        for joint, target in zip(joints, targets, strict=True):
            joint.setRestPosition(0, target)
        sim.step(1)
        reference.step()
        assert not hw.saturated().any()
    np.testing.assert_allclose(hw.positions(), np.asarray(robot.getPositions())[hw.dofs], atol=1e-10)
    np.testing.assert_allclose(hw.velocities(), np.asarray(robot.getVelocities())[hw.dofs], atol=1e-8)


def test_time_step_change_is_taken_into_the_servo(make_sim):
    sim = make_sim(gravity=(0.0, 0.0, -9.81))
    hw = spawn(sim)
    hw.apply_command(["shoulder", "elbow"], ["position", "position"], [0.2, 0.3])
    sim.step(200)
    sim.world.set_time_step(0.002)
    torque = np.clip(expected_torque(hw, 0.002), -hw.max_effort, hw.max_effort)
    sim.step(1)
    np.testing.assert_allclose(hw.efforts(), torque, rtol=1e-12, atol=1e-9)


# -- effort and velocity commands, switching interfaces -------------------------------------------------------
def test_effort_and_velocity_commands_and_back_to_position(make_sim):
    sim = make_sim()
    hw = spawn(sim)
    shoulder = hw.dart_joints[0]
    hw.apply_command(["shoulder"], ["effort"], [10.0])
    hw.before_step(DT)
    assert hw.skeleton.getForce(int(hw.dofs[0])) == 10.0 and shoulder.getSpringStiffness(0) == 0.0
    assert hw.efforts()[0] == 10.0                                     # reported as commanded
    sim.world.world.step()
    hw.apply_command(["shoulder"], ["velocity"], [1.0])
    assert hw.mode[0] == "velocity"
    sim.step(200)
    assert hw.velocities()[0] == pytest.approx(1.0, abs=1e-6)
    assert hw.efforts()[0] == 0.0
    hw.apply_command(["shoulder"], ["position"], [0.0])                # the spring again, from where it is
    assert shoulder.getSpringStiffness(0) == hw.kp[0] and hw.mode == ["position", "position"]
    sim.step(1500)
    assert hw.positions()[0] == pytest.approx(0.0, abs=0.01)
    hw.apply_command(["shoulder"], ["effort"], [5.0])
    hw.hold_position()                                                 # a timeout: position control where it is
    assert hw.mode == ["position", "position"] and hw.target[0] == hw.positions()[0]


def test_command_lists_in_any_order_subset_or_type(make_sim):
    sim = make_sim()
    hw = spawn(sim)
    assert hw.apply_command(["elbow", "shoulder"], ["position", "position"], [0.3, 0.1]) == 2
    assert hw.target.tolist() == [0.1, 0.3]
    assert hw.apply_command(("elbow",), ("position",), (0.4,)) == 1
    assert hw.target.tolist() == [0.1, 0.4]
    assert hw.apply_command(["ghost", "shoulder"], ["position", "position"], [9.0, 0.2]) == 1
    assert hw.target.tolist() == [0.2, 0.4]
    assert hw.apply_command(["shoulder", "elbow"], ["position", "position"], [0.5, float("inf")]) == 1
    assert hw.target.tolist() == [0.5, 0.4]
    names, interfaces = ["shoulder", "elbow"], ["position", "position"]
    assert hw.apply_command(names, interfaces, [0.6, 0.7]) == 2
    names[0], names[1] = "elbow", "shoulder"                           # the same list object, changed: no stale plan
    assert hw.apply_command(names, interfaces, [0.6, 0.7]) == 2
    assert hw.target.tolist() == [0.7, 0.6]
    for bad in ([None, 0.1], [[0.1], 0.2], ["x", 0.1]):
        with pytest.raises(ValueError, match="list of numbers"):
            hw.apply_command(["shoulder", "elbow"], ["position", "position"], bad)
    assert hw.target.tolist() == [0.7, 0.6]


def test_saturating_runs_are_bit_identical(make_sim):
    """Saturation switches, velocity limits and interface switches replay bit for bit."""

    def run() -> np.ndarray:
        sim = make_sim(gravity=(0.0, 0.0, -9.81))
        hw = spawn(sim)
        rows = []
        for k in range(900):
            if k % 300 == 0:
                hw.apply_command(["shoulder", "elbow"], ["position", "position"], [0.8 - k / 500, 1.5 - k / 300])
            if k == 450:
                hw.apply_command(["shoulder"], ["effort"], [-40.0])
            if k == 600:
                hw.apply_command(["shoulder"], ["velocity"], [1.5])
            sim.step(1)
            rows.append(np.concatenate([hw.positions(), hw.velocities(), hw.efforts(), hw.saturated()]))
        return np.array(rows)

    first, second = run(), run()
    assert first[:, 6:].any()                                           # something saturated
    assert np.array_equal(first, second)
