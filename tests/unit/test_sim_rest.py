"""World models at rest sleep until something touches them (nodes/sim/rest.py): the lab's free objects fall
asleep once they lie still while the robot moves, a falling box wakes the one it lands on, a request wakes a
model, a reset wakes them all, and the same run twice gives the same poses."""

from __future__ import annotations

import math

import numpy as np

from nodes.share import robot_file
from nodes.sim.config import parse_gains
from nodes.sim.entity import EntitySpec
from nodes.sim.pose import Pose
from nodes.sim.sdf import load_world, parse_model
from nodes.sim.sdf_model import WorldModel
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld

DYNAMIC = {"block", "book", "box_small", "box_medium", "box_large", "ball"}


def box(name: str, z: float, size: float = 0.3) -> WorldModel:
    inertia = size * size / 6
    sdf = (f"<?xml version='1.0'?><sdf version='1.7'><model name='{name}'><pose>3 3 {z} 0 0 0</pose><link name='l'>"
           f"<inertial><mass>1</mass><inertia><ixx>{inertia}</ixx><iyy>{inertia}</iyy><izz>{inertia}</izz></inertia>"
           f"</inertial><collision name='c'><geometry><box><size>{size} {size} {size}</size></box></geometry>"
           f"</collision></link></model></sdf>")
    return WorldModel(parse_model(sdf, name))


def squatting_lab() -> Simulation:
    sim = Simulation(PhysicsWorld(1000.0), parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
    sim.load_world(load_world("simple_lab"), 50.0, 1.0)
    sim.spawn(EntitySpec(name="humanoid", xml=robot_file("humanoid").read_text(),
                         pose=Pose.from_xyz_rpy(0, 0, 0.93, 0, 0, 0)))
    sim.hold_all()
    return sim


def squat(sim: Simulation, steps: int) -> None:
    hw = sim.hardware["humanoid"]
    legs = [(n, f) for n in hw.names for part, f in (("hip_pitch", -0.5), ("knee", 1.0), ("ankle_pitch", -0.5))
            if n.endswith(part)]
    for _ in range(steps):
        depth = 0.3 * (1 - math.cos(2 * sim.world.time))
        hw.apply_command([n for n, _ in legs], ["position"] * len(legs), [f * depth for _, f in legs])
        sim.step(1)


def test_the_labs_free_objects_sleep_while_the_robot_moves_and_stay_where_they_lie():
    sim = squatting_lab()
    squat(sim, 300)
    before = {name: sim.entities[name].world_pose().position for name in DYNAMIC}
    assert not sim.rest.asleep
    squat(sim, 700)
    assert set(sim.rest.asleep) == DYNAMIC        # the walls, table and ramp are static: never tracked
    squat(sim, 500)
    for name in DYNAMIC:
        assert np.allclose(sim.entities[name].world_pose().position, before[name], atol=2e-3), name
    assert sim.entities["humanoid"].world_pose().position[2] < 0.9   # the robot squats on


def test_a_falling_box_wakes_the_one_it_lands_on_and_both_sleep_again():
    sim = Simulation(PhysicsWorld(1000.0), parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
    sim.world.add_ground()
    sim.add_model(box("under", 0.15))
    sim.step(700)
    assert sim.rest.asleep == ["under"]
    sim.add_model(box("dropped", 0.8))
    for _ in range(400):
        sim.step(1)
        if "under" not in sim.rest.asleep:
            break
    assert "under" not in sim.rest.asleep, "the landing box woke it"
    landed = sim.world.time
    sim.step(1500)
    assert set(sim.rest.asleep) == {"under", "dropped"}
    assert abs(sim.entities["dropped"].world_pose().position[2] - 0.45) < 0.01   # on top of the other
    assert landed < 1.2


def test_a_request_and_a_reset_wake_models():
    sim = Simulation(PhysicsWorld(1000.0), parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
    sim.world.add_ground()
    sim.add_model(box("crate", 0.15))
    sim.step(700)
    assert sim.rest.asleep == ["crate"]
    sim.wake("crate")                 # as set_entity_state / apply_link_wrench do
    assert not sim.rest.asleep
    sim.step(700)
    assert sim.rest.asleep == ["crate"]
    sim.reset_world()
    assert not sim.rest.asleep


def test_the_same_run_twice_gives_the_same_poses():
    poses = []
    for _ in range(2):
        sim = squatting_lab()
        squat(sim, 1200)
        poses.append([sim.entities[name].world_pose().position for name in sorted(sim.entities)])
    assert np.array_equal(np.array(poses[0]), np.array(poses[1]))
