"""In-process DART checks of the simulator's physics pieces: limits, servo, kinematic mode, balance, resets."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nodes.sim.config import Gains, parse_gains
from nodes.sim.entity import EntitySpec, Pose, SpawnError
from nodes.sim.humanoid_state import convex_hull, inside_polygon
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld

ROOT = Path(__file__).resolve().parents[2]
ARM = (ROOT / "tests" / "data" / "sim_arm.urdf").read_text()
HUMANOID = (ROOT / "robots" / "humanoid.urdf").read_text()
KNEE_BEND = {"left_hip_pitch": -0.2, "left_knee": 0.4, "left_ankle_pitch": -0.2,
             "right_hip_pitch": -0.2, "right_knee": 0.4, "right_ankle_pitch": -0.2}


@pytest.fixture
def make_sim():
    created: list[Simulation] = []

    def make(ground: bool = True, gravity=(0.0, 0.0, -9.81), mode: str = "lockstep"):
        world = PhysicsWorld(1000.0, gravity)
        if ground:
            world.add_ground()
        warnings: list[str] = []
        sim = Simulation(world, parse_gains({"*": {"p": 2000.0, "d": 20.0}}), warnings.append, mode)
        sim.warnings = warnings  # type: ignore[attr-defined]
        created.append(sim)
        return sim

    yield make
    for sim in created:
        sim.clear()


def spawn_arm(sim: Simulation, name: str = "arm"):
    sim.spawn(EntitySpec(name, ARM, fixed=True, pose=Pose.from_xyz_rpy(0, 0, 0.5)))
    return sim.hardware[name]


def test_position_command_beyond_limit_is_clamped_and_joint_stops_there(make_sim):
    sim = make_sim(ground=False)
    hw = spawn_arm(sim)
    assert hw.apply_command(["shoulder", "elbow"], ["position", "position"], [5.0, -9.0]) == 2
    sim.step(3000)
    q = hw.positions()
    assert q[0] == pytest.approx(0.8, abs=0.02)     # ros2_control max of the position interface
    assert q[1] == pytest.approx(-1.5, abs=0.02)    # URDF lower limit
    assert q[0] <= 0.8 + 0.02 and q[1] >= -1.5 - 0.02
    assert sum("outside" in w for w in sim.warnings) == 2
    hw.apply_command(["shoulder"], ["position"], [5.0])
    assert sum("outside" in w for w in sim.warnings) == 2   # logged once per joint


def test_effort_into_the_limit_stops_at_the_urdf_limit(make_sim):
    sim = make_sim(ground=False, gravity=(0.0, 0.0, 0.0))
    hw = spawn_arm(sim)
    hw.apply_command(["shoulder"], ["effort"], [500.0])     # clamped to the 40 Nm effort limit
    assert hw.target[0] == 40.0
    peak = -math.inf
    for _ in range(2000):
        sim.step(1)
        peak = max(peak, hw.positions()[0])
    assert 0.95 < peak <= 1.0 + 5e-3     # DART's limit constraint holds it at upper = 1.0


def test_velocity_limit_holds_for_velocity_and_effort_commands(make_sim):
    sim = make_sim(ground=False, gravity=(0.0, 0.0, 0.0))
    hw = spawn_arm(sim)
    hw.apply_command(["shoulder"], ["velocity"], [10.0])    # URDF velocity limit 2 rad/s
    sim.step(100)
    assert hw.velocities()[0] == pytest.approx(2.0, abs=1e-3)
    sim.reset_world()
    hw.apply_command(["shoulder"], ["effort"], [-40.0])     # 40 Nm on a 1.5 kg arm: far past 2 rad/s unchecked
    fastest = 0.0
    for _ in range(300):
        sim.step(1)
        fastest = max(fastest, abs(hw.velocities()[0]))
    assert fastest == pytest.approx(2.0, abs=1e-6)


def test_position_servo_torque_stays_within_effort_limit(make_sim):
    """Applied and reported torque never exceed the URDF limit (spring-damper torque included)."""
    sim = make_sim(ground=False)
    hw = spawn_arm(sim)
    hw.apply_command(["shoulder", "elbow"], ["position", "position"], [0.8, 1.5])
    reported, saturated_force = [], []
    for _ in range(1500):
        hw.before_step()
        for i in np.nonzero(hw.saturated())[0]:   # a saturated joint gets exactly the limit, no spring
            saturated_force.append(abs(hw.skeleton.getForce(int(hw.dofs[i]))) / hw.max_effort[i])
            assert hw.dart_joints[i].getSpringStiffness(0) == 0.0
        sim.world.step()
        reported.append(np.abs(hw.efforts()) / hw.max_effort)
    reported = np.array(reported)
    assert reported.max() <= 1.0                  # never more than the limit
    assert saturated_force and max(saturated_force) == pytest.approx(1.0)
    assert (reported[:, 1] == 1.0).sum() > 10      # the elbow's 20 Nm limit was reached and held
    q = hw.positions()
    assert q[0] == pytest.approx(0.8, abs=0.02) and q[1] == pytest.approx(1.5, abs=0.02)
    assert reported[-1].max() < 0.2                # settled: the spring is back in charge


def test_bad_commands_are_rejected_and_state_kept(make_sim):
    sim = make_sim(ground=False)
    hw = spawn_arm(sim)
    sim.step(10)
    before = hw.target.copy()
    assert hw.apply_command(["shoulder"], ["position"], [float("nan")]) == 0
    assert hw.apply_command(["ghost"], ["position"], [0.1]) == 0
    assert hw.apply_command(["elbow"], ["velocity"], [0.1]) == 0          # elbow has no velocity interface
    np.testing.assert_array_equal(hw.target, before)
    assert hw.mode == ["position", "position"]
    with pytest.raises(ValueError, match="same length"):
        hw.apply_command(["shoulder", "elbow"], ["position"], [0.1])
    assert any("non-finite" in w for w in sim.warnings)
    assert any("unknown joint 'ghost'" in w for w in sim.warnings)
    assert any("no 'velocity' command interface" in w for w in sim.warnings)
    sim.step(10)
    assert np.all(np.isfinite(hw.positions()))


def test_kinematic_mode_sets_joints_exactly(make_sim):
    sim = make_sim(ground=False, mode="kinematic")
    hw = spawn_arm(sim)
    for k in range(50):
        targets = [0.5 * math.sin(0.1 * k), -0.5 * math.sin(0.2 * k)]
        hw.apply_command(["shoulder", "elbow"], ["position", "position"], targets)
        sim.step(1)
        assert hw.positions().tolist() == targets
    assert sim.world.time == pytest.approx(0.05)


def test_spawn_rejects_bad_requests_and_leaves_world_unchanged(make_sim):
    sim = make_sim()
    spawn_arm(sim)
    skeletons = sim.world.world.getNumSkeletons()
    bad = [
        (EntitySpec("arm", ARM), "already exists"),
        (EntitySpec("ground_plane", ARM), "already exists"),
        (EntitySpec("arm2", ARM, namespace="arm"), "namespace 'arm'"),
        (EntitySpec("arm3", ARM, pose=Pose((0.0, math.nan, 0.0))), "NaN"),
        (EntitySpec("arm4", ARM, initial_positions={"wrist": 0.1}), "unknown joint 'wrist'"),
        (EntitySpec("arm5", ARM, initial_positions={"elbow": 3.0}), "outside"),
        (EntitySpec("arm6", ARM.replace("</robot>", "")), "line"),
        (EntitySpec("bad name", ARM), "name"),
        (EntitySpec("arm*", ARM), "name"),
        (EntitySpec("arm8", ARM, namespace="robots/**"), "robot_namespace"),
        (EntitySpec("arm9", ARM, namespace="a//b"), "robot_namespace"),
    ]
    for spec, reason in bad:
        with pytest.raises(ValueError) as info:
            sim.spawn(spec)
        assert reason in str(info.value), (spec.name, str(info.value))
    with pytest.raises(SpawnError, match="reference_frame"):
        sim.spawn(EntitySpec("arm7", ARM), reference_frame="nowhere")
    assert sim.world.world.getNumSkeletons() == skeletons
    assert list(sim.entities) == ["arm"]


def test_reference_frame_and_initial_joints(make_sim):
    sim = make_sim(ground=False)
    sim.spawn(EntitySpec("base", ARM, fixed=True, pose=Pose.from_xyz_rpy(1, 2, 0, 0, 0, math.pi / 2)))
    child = sim.spawn(EntitySpec("child", ARM, fixed=True, pose=Pose.from_xyz_rpy(1, 0, 0),
                                 initial_positions={"elbow": 0.5}), reference_frame="base")
    np.testing.assert_allclose(child.world_pose().position, (1.0, 3.0, 0.0), atol=1e-9)
    assert sim.hardware["child"].positions()[1] == 0.5
    names = [row[0] for row in sim.model_states()]
    assert names == ["base", "child"]


def test_ros2_control_initial_value_is_where_a_joint_starts(make_sim):
    """gazebo_ros2_control's initial_value applies to every spawn (a bare SpawnEntity request too); the
    request's own initial positions win; reset returns there; a value that is no number is refused by name."""
    valued = ARM.replace('<joint name="elbow">\n      <command_interface name="position"/>\n      <state_interface name="position"/>',
                         '<joint name="elbow">\n      <command_interface name="position"/>\n      <state_interface name="position">'
                         '<param name="initial_value">0.7</param></state_interface>')
    assert valued != ARM
    sim = make_sim(ground=False)
    hw = sim.spawn(EntitySpec("a", valued, fixed=True)) and sim.hardware["a"]
    assert hw.positions()[1] == pytest.approx(0.7)
    sim.step(200)
    sim.reset_world()
    assert hw.positions()[1] == pytest.approx(0.7, abs=1e-6)
    sim.spawn(EntitySpec("b", valued, fixed=True, namespace="b", initial_positions={"elbow": -0.2}))
    assert sim.hardware["b"].positions()[1] == pytest.approx(-0.2)
    with pytest.raises(SpawnError, match="joint 'elbow': <ros2_control> initial_value 'x' is not a number"):
        sim.spawn(EntitySpec("c", valued.replace(">0.7<", ">x<"), fixed=True, namespace="c"))


def test_humanoid_stands_balanced_and_knee_bend_reaches_target(make_sim):
    sim = make_sim()
    sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.915)))
    hw = sim.hardware["humanoid"]
    entity = sim.entities["humanoid"]
    sim.step(500)
    z0 = entity.world_pose().position[2]
    balance = sim.balance("humanoid")
    assert balance.is_balanced and len(balance.support_polygon) >= 4
    assert 0.7 < balance.center_of_mass[2] < 0.95
    names = list(KNEE_BEND)
    goal = np.array([KNEE_BEND[n] for n in names])
    for k in range(1, 1001):                       # the tutorial's 1 s move, linearly interpolated
        hw.apply_command(names, ["position"] * 6, list(goal * k / 1000))
        sim.step(1)
    sim.step(2000)
    index = [hw.index[n] for n in names]
    assert np.max(np.abs(hw.positions()[index] - goal)) < 0.02
    assert abs(entity.world_pose().position[2] - z0) < 0.05     # bent knees, not fallen
    assert sim.balance("humanoid").is_balanced


def test_reset_simulation_replays_bit_identically(make_sim):
    sim = make_sim()
    sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.915)))
    hw = sim.hardware["humanoid"]

    def run() -> np.ndarray:
        rows = []
        for k in range(600):
            s = min(k / 300, 1.0)
            hw.apply_command(["left_knee", "right_knee"], ["position"] * 2, [0.4 * s, 0.4 * s])
            sim.step(1)
            rows.append(np.array(sim.entities["humanoid"].skeleton.getPositions()))
        return np.array(rows)

    sim.step(123)
    sim.reset_simulation()
    first = run()
    sim.step(45)
    sim.reset_simulation()
    assert sim.world.time == 0.0 and sim.step_count == 0
    second = run()
    assert np.array_equal(first, second)


def test_gains_come_from_patterns(make_sim):
    world = PhysicsWorld()
    sim = Simulation(world, parse_gains({"elbow": {"p": 7.0, "d": 0.5}, "*": {"p": 11.0}}))
    try:
        hw = spawn_arm(sim)
        assert hw.gains == [Gains(11.0, 0.0), Gains(7.0, 0.5)]
        assert hw.dart_joints[1].getSpringStiffness(0) == 7.0
    finally:
        sim.clear()


def test_convex_hull_and_point_in_polygon():
    square = convex_hull([(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.5), (1, 0.5)])
    assert square == [(0, 0), (1, 0), (1, 1), (0, 1)]
    assert inside_polygon((0.5, 0.5), square)
    assert inside_polygon((1.0, 0.5), square)            # on an edge
    assert not inside_polygon((1.1, 0.5), square)
    assert not inside_polygon((0.5, 0.5), [(0, 0), (1, 0)])   # a line has no inside


@pytest.mark.parametrize("detector", ["fcl", "dart", "bullet", "ode"])
def test_every_collision_detector_holds_the_humanoid_on_the_ground(detector):
    world = PhysicsWorld(1000.0, (0.0, 0.0, -9.81), detector)
    world.add_ground()
    sim = Simulation(world, parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
    try:
        sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.915)))
        sim.step(500)
        assert sim.entities["humanoid"].world_pose().position[2] == pytest.approx(0.91, abs=0.01)
        assert sim.balance("humanoid").is_balanced
        assert world.collision_detector == detector
    finally:
        sim.clear()


def test_unknown_collision_detector_is_rejected():
    with pytest.raises(ValueError, match="collision_detector 'physx'"):
        PhysicsWorld(1000.0, collision_detector="physx")


def test_deleting_a_model_in_contact_leaves_no_stale_contacts():
    # The last step's contacts point into the deleted model's collision objects: reading them crashed the
    # process (use-after-free), so this runs in a child process and checks its exit status.
    import subprocess
    import sys

    script = f"""
import sys
sys.path.insert(0, {str(ROOT)!r})
from nodes.sim.config import parse_gains
from nodes.sim.entity import EntitySpec, Pose
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld
world = PhysicsWorld()
world.add_ground()
sim = Simulation(world, parse_gains(None))
sim.spawn(EntitySpec("humanoid", open({str(ROOT / "robots" / "humanoid.urdf")!r}).read(),
                     pose=Pose.from_xyz_rpy(0, 0, 0.915)))
for _ in range(5):
    sim.spawn(EntitySpec("arm", open({str(ROOT / "tests" / "data" / "sim_arm.urdf")!r}).read(), fixed=True,
                         pose=Pose.from_xyz_rpy(3, 0, 0)))
    sim.step(5)
    assert len(world.contacts()) >= 4     # the arm base rests in the ground
    sim.delete("arm")
    for _ in range(20):
        sim.balance("humanoid")
    sim.delete("ground_plane")
    sim.balance("humanoid")
    world.add_ground()
    sim.step(50)
    sim.reset_world()          # a fresh collision detector: the old one's contacts must go too
    sim.balance("humanoid")
    sim.step(50)
    sim.reset_simulation()
    sim.balance("humanoid")
sim.clear()
print("survived")
"""
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and "survived" in result.stdout, result.stderr[-2000:]


def test_a_push_moves_the_zmp_out_of_the_support_polygon(make_sim):
    sim = make_sim()
    sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.915)))
    sim.step(500)
    assert sim.balance("humanoid").is_balanced
    torso = sim.entities["humanoid"].skeleton.getBodyNode("torso")
    during = []
    for _ in range(100):                       # 250 N forward on the torso for 0.1 s
        torso.addExtForce(np.array([250.0, 0.0, 0.0]), np.zeros(3), False, False)
        sim.step(1)
        sim.sample_sensors()        # as the simulator node does every control period
        during.append(sim.balance("humanoid"))
    hull = [(x, y) for x, y, _ in during[0].support_polygon]
    assert not all(inside_polygon(b.zmp, hull) for b in during)
    assert min(b.zmp[0] for b in during) < -0.08       # behind the heels (x_min of the feet = -0.08)
    # the measured centre of pressure (ankle force/torque sensors) moves to the toes (x_max = 0.14): the robot
    # leans into the push, and is_balanced, judged by it, says so
    cops = [b.cop[0] for b in during if b.source == "cop"]
    assert len(cops) > 80 and max(cops) > 0.13 and not all(b.is_balanced for b in during)
    sim.step(3000)
    settled = sim.balance("humanoid")
    assert settled.is_balanced and settled.center_of_mass[2] > 0.8   # it recovered and still stands


def test_spawn_refuses_a_billion_laughs_urdf(make_sim):
    """The spawn path goes through the project's XML safety check: entities are refused, never expanded."""
    from nodes.sim.urdf_info import UrdfError

    sim = make_sim()
    hostile = (ROOT / "tests" / "data" / "urdf_broken" / "billion_laughs.urdf").read_text()
    with pytest.raises(UrdfError, match="XML declares entities .*refused"):
        sim.spawn(EntitySpec("lol", hostile))
    assert sim.world.world.getNumSkeletons() == 1 and not sim.entities   # only the ground
