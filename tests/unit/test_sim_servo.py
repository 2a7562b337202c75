"""The joint servo of the simulator's hardware interface (nodes/sim/hardware.py), in process with DART: velocity
limits held by DART's joint limit constraint, the saturated-motor switch, effort and velocity commands, what is
reported, and bit-identical replays."""

from __future__ import annotations

import math
from pathlib import Path

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

    def make(gravity=(0.0, 0.0, 0.0)) -> Simulation:
        sim = Simulation(PhysicsWorld(1.0 / DT, gravity), parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
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
