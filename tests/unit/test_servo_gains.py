"""Servo gains from the physics: one rule for a 1 kg cart, our 57 kg humanoid and a 33 kg G1."""

from __future__ import annotations

from pathlib import Path

import pytest

dart = pytest.importorskip("dartpy")

from nodes.sim.config import Gains, parse_gains  # noqa: E402
from nodes.sim.entity import EntitySpec  # noqa: E402
from nodes.sim.pose import Pose  # noqa: E402
from nodes.sim.simulation import Simulation  # noqa: E402
from nodes.sim.world import PhysicsWorld  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CART = """<robot name="cart">
  <link name="rail"><inertial><mass value="5"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="cart"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial><collision><geometry><box size="0.2 0.1 0.05"/></geometry></collision></link>
  <joint name="slide" type="prismatic"><parent link="rail"/><child link="cart"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="100" velocity="2"/></joint>
</robot>"""


def simulation(gains: dict | None = None) -> Simulation:
    world = PhysicsWorld(1000.0, (0.0, 0.0, -9.81))
    world.add_ground()
    return Simulation(world, parse_gains(gains or {}))


def test_a_1kg_cart_holds_its_target_against_gravity():
    sim = simulation()
    try:
        sim.spawn(EntitySpec("cart", CART, fixed=True, pose=Pose.from_xyz_rpy(0, 0, 1.0)))
        hw = sim.hardware["cart"]
        assert 100 < hw.gains[0].kp < 5000          # N/m: a kilogram, not a humanoid's knee
        hw.apply_command(["slide"], ["position"], [0.2])
        sim.step(2000)
        assert hw.positions()[0] == pytest.approx(0.2, abs=0.02)   # static error ~ m g / kp
    finally:
        sim.clear()


def test_legs_that_carry_the_body_get_more_than_the_arms_and_the_humanoid_stands():
    sim = simulation()
    try:
        xml = (ROOT / "robots" / "humanoid.urdf").read_text()
        sim.spawn(EntitySpec("humanoid", xml, auto_z=True))
        hw = sim.hardware["humanoid"]
        kp = {name: g.kp for name, g in zip(hw.names, hw.gains, strict=True)}
        assert kp["left_knee"] > 2000 and kp["left_hip_pitch"] > 2000      # the body's weight on each leg
        assert kp["left_elbow"] < kp["left_shoulder_pitch"] < kp["left_knee"]
        assert kp["left_knee"] == kp["right_knee"]
        z = sim.entities["humanoid"].world_pose().position[2]
        assert z == pytest.approx(0.91, abs=0.01)                       # z: auto put the feet on the ground
        sim.step(1000)
        assert sim.entities["humanoid"].world_pose().position[2] == pytest.approx(z, abs=0.01)
        assert sim.balance("humanoid").is_balanced
    finally:
        sim.clear()


def test_config_patterns_still_win():
    sim = simulation({"*_knee": {"p": 3000.0, "d": 30.0}})
    try:
        sim.spawn(EntitySpec("humanoid", (ROOT / "robots" / "humanoid.urdf").read_text(), auto_z=True))
        hw = sim.hardware["humanoid"]
        gains = dict(zip(hw.names, hw.gains, strict=True))
        assert gains["left_knee"] == Gains(3000.0, 30.0)
        assert gains["left_hip_pitch"] != Gains(3000.0, 30.0)
    finally:
        sim.clear()
