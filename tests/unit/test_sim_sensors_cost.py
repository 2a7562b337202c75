"""The body sensors' cheap reads (nodes/sim/sensors.py reads SimpleFrames, the child link's body force, noise in
blocks, one shared walk over the contacts) against a straightforward reference: every reading straight from
DART's bodies and joints with numpy, one noise draw per sample, one walk over the world's contacts per sensor,
as the sensors were first written. Same DART state, same readings to floating-point round-off; the noise stream
bit for bit; the physics untouched by the sensors' frames."""

from __future__ import annotations

import math
import zlib
from pathlib import Path

import dartpy as dart
import numpy as np
import pytest

from nodes.sim.config import parse_gains
from nodes.sim.entity import EntitySpec, Pose
from nodes.sim.geometry import quaternion_from_rotation
from nodes.sim.sensors import (
    NOISE_BLOCK,
    ContactSensor,
    ForceTorqueSensor,
    ImuSensor,
    _NoiseModel,
)
from nodes.sim.simulation import Simulation
from nodes.sim.world import PhysicsWorld
from nodes.urdf.sensors import IMU_INTERFACES, Noise

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = (ROOT / "robots" / "humanoid.urdf").read_text()
W = dart.dynamics.Frame.World()
EPS = 1e-9
# round-off: readings are products and sums of the same doubles in another order (Python floats where DART's
# Eigen or numpy's BLAS computed them); accelerations divide velocity differences by 1 ms
RTOL, ATOL = 1e-9, 1e-9


class ReferenceNoise:
    """Gazebo's gaussian noise, one generator draw per sample (the first implementation)."""

    def __init__(self, channels: tuple[str, ...], noise: dict[str, Noise], seed: int, key: str) -> None:
        self.rng = np.random.Generator(np.random.PCG64([seed, zlib.crc32(key.encode())]))
        active = [(i, noise[c]) for i, c in enumerate(channels) if c in noise and noise[c].active]
        self.indices = [i for i, _ in active]
        models = [n for _, n in active]
        self.mean = np.array([n.mean for n in models])
        self.stddev = np.array([n.stddev for n in models])
        self.bias = np.zeros(len(models))
        if models:
            bias = np.array([n.bias_mean for n in models]) + \
                np.array([n.bias_stddev for n in models]) * self.rng.standard_normal(len(models))
            self.bias = bias * np.where(self.rng.random(len(models)) < 0.5, -1.0, 1.0)

    def apply(self, values: list[float]) -> None:
        if not self.indices:
            return
        noisy = self.mean + self.bias + self.stddev * self.rng.standard_normal(len(self.indices))
        for k, i in enumerate(self.indices):
            values[i] += float(noisy[k])


class Reference:
    """The reference reading of one sensor of the suite, from the same DART state."""

    def __init__(self, sensor, seed: int, contacts) -> None:
        self.sensor = sensor
        self.spec = sensor.spec
        self.body = sensor.body
        self.contacts_of = contacts
        self.noise = ReferenceNoise(sensor.channels, self.spec.noise, seed, f"{sensor.entity}/{sensor.name}")
        self.velocity = None
        self.stamp = math.nan
        self.readings: list[list[float]] = []

    def sample(self, t: float, gravity: np.ndarray):
        if isinstance(self.sensor, ImuSensor):
            values = self.imu(t, gravity)
        elif isinstance(self.sensor, ForceTorqueSensor):
            values = self.force_torque()
        else:
            values = self.contact(t, gravity)
        if isinstance(values, list):
            self.noise.apply(values)
            if isinstance(self.sensor, ForceTorqueSensor):
                self.readings.append(values)
        self.stamp = t
        return values

    def imu(self, t: float, gravity: np.ndarray) -> list[float]:
        body, pose = self.body, self.spec.pose
        offset = pose[:3, 3]
        rotation = body.getWorldTransform().rotation()
        if not np.allclose(pose, np.eye(4)):
            rotation = rotation @ pose[:3, :3]
            velocity = body.getLinearVelocity(offset, W, W)
            angular = rotation.T @ body.getAngularVelocity()
        else:
            velocity = body.getLinearVelocity()
            angular = body.getAngularVelocity(W, body)
        dt = t - self.stamp
        if self.velocity is not None and dt > EPS:
            acceleration = (velocity - self.velocity) / dt
        else:
            acceleration = body.getLinearAcceleration(offset, W, W)
        self.velocity = velocity
        specific = rotation.T @ (acceleration - gravity)
        return [*quaternion_from_rotation(rotation.tolist()), *angular.tolist(), *specific.tolist()]

    def force_torque(self) -> list[float]:
        joint = self.sensor.joint
        wrench = np.asarray(joint.getWrenchToChildBodyNode())
        torque, force = wrench[:3], wrench[3:]
        parent = joint.getParentBodyNode()
        if self.spec.frame == "parent" and parent is not None:
            rotation = parent.getWorldTransform().rotation().T @ self.body.getWorldTransform().rotation()
            torque, force = rotation @ torque, rotation @ force
        elif self.spec.frame == "sensor":
            mount = self.spec.pose[:3, :3]
            torque, force = mount.T @ torque, mount.T @ force
        s = -1.0 if self.spec.measure_direction == "parent_to_child" else 1.0
        return [s * float(v) for v in (*force, *torque)]

    def world_wrench(self):
        mean = np.mean(self.readings, axis=0) if self.readings else np.asarray(self.sensor.values)
        self.readings = []
        transform = self.body.getWorldTransform()
        parent = self.sensor.joint.getParentBodyNode()
        if self.spec.frame == "parent" and parent is not None:
            rotation = parent.getWorldTransform().rotation()
        elif self.spec.frame == "sensor":
            rotation = transform.rotation() @ self.spec.pose[:3, :3]
        else:
            rotation = transform.rotation()
        values = mean * (-1.0 if self.spec.measure_direction == "parent_to_child" else 1.0)
        return np.asarray(transform.translation()), rotation @ values[:3], rotation @ values[3:]

    def contact(self, t: float, gravity: np.ndarray) -> list[tuple]:
        body = self.body
        found = []
        for contact in self.contacts_of():
            first = contact.collisionObject1.getShapeFrame().getBodyNodePtr()
            second = contact.collisionObject2.getShapeFrame().getBodyNodePtr()
            if first is not None and first.getName() == body.getName() and \
                    first.getSkeleton().getName() == body.getSkeleton().getName():
                other, sign = second, 1.0
            elif second is not None and second.getName() == body.getName() and \
                    second.getSkeleton().getName() == body.getSkeleton().getName():
                other, sign = first, -1.0
            else:
                continue
            name = f"{other.getSkeleton().getName()}::{other.getName()}" if other is not None else ""
            found.append([np.asarray(contact.point), sign * np.asarray(contact.normal),
                          float(contact.penetrationDepth), name])
        velocity = np.asarray(body.getCOMLinearVelocity())
        dt = t - self.stamp
        if self.velocity is not None and dt > EPS:
            acceleration = (velocity - self.velocity) / dt
        else:
            acceleration = np.asarray(body.getCOMLinearAcceleration())
        self.velocity = velocity
        joint = body.getParentJoint()
        on_parent = np.zeros(3)
        if joint is not None and joint.getParentBodyNode() is not None:
            on_parent = body.getWorldTransform().rotation() @ np.asarray(joint.getWrenchToChildBodyNode())[3:]
        total = body.getMass() * (acceleration - gravity) + on_parent
        depths = np.array([max(c[2], 0.0) for c in found])
        shares = depths / depths.sum() if found and depths.sum() > 0 else np.full(len(found), 1.0 / max(len(found), 1))
        return [(position, normal, total * share, depth, other)
                for (position, normal, depth, other), share in zip(found, shares, strict=True)]


def robot_contacts(contacts, name: str) -> tuple[list[list[float]], set[str]]:
    """The first balance's walks: the robot's contact points with other models, and its links touching them."""
    points, links = [], set()
    for contact in contacts:
        first = contact.collisionObject1.getShapeFrame()
        second = contact.collisionObject2.getShapeFrame()
        if (first.getSkeleton().getName() == name) != (second.getSkeleton().getName() == name):
            points.append(np.asarray(contact.point).tolist())
        for mine, other in ((first, second), (second, first)):
            if mine.getSkeleton().getName() == name and other.getSkeleton().getName() != name:
                links.add(mine.getBodyNodePtr().getName())
    return points, links


def make_sim(seed: int = 5) -> Simulation:
    world = PhysicsWorld(1000.0, (0.0, 0.0, -9.81))
    world.add_ground()
    return Simulation(world, parse_gains({"*": {"p": 3000.0, "d": 30.0}}), None, "lockstep", sensor_seed=seed)


def variant(xml: str, kind: str) -> str:
    """The humanoid with its sensors declared otherwise (a mounted IMU, F/T frames and directions, F/T noise)."""
    if kind == "mounted":
        xml = xml.replace('<sensor name="imu_sensor" type="imu">',
                          '<sensor name="imu_sensor" type="imu"><pose>0.05 -0.02 0.1 0.3 -0.2 0.5</pose>', 1)
        xml = xml.replace("<frame>child</frame>", "<frame>parent</frame>", 1)   # left ankle
        xml = xml.replace('<sensor name="right_foot_ft" type="force_torque">',
                          '<sensor name="right_foot_ft" type="force_torque"><pose>0 0 0 0.2 0.1 -0.4</pose>', 1)
        xml = xml.replace("<frame>child</frame>", "<frame>sensor</frame>", 1)  # right ankle
        xml = xml.replace("<measure_direction>child_to_parent</measure_direction>",
                          "<measure_direction>parent_to_child</measure_direction>", 1)
    elif kind == "noisy_ft":
        xml = xml.replace("<measure_direction>child_to_parent</measure_direction>",
                          "<measure_direction>child_to_parent</measure_direction><noise><type>gaussian</type>"
                          "<mean>0.1</mean><stddev>2.0</stddev><bias_mean>0.5</bias_mean>"
                          "<bias_stddev>0.1</bias_stddev></noise>")
    return xml


def close(actual, expected, what: str) -> float:
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    np.testing.assert_allclose(actual, expected, rtol=RTOL, atol=ATOL, err_msg=what)
    return float(np.max(np.abs(actual - expected), initial=0.0))


@pytest.mark.parametrize("kind", ["shipped", "mounted", "noisy_ft"])
def test_readings_match_the_straightforward_reference(kind):
    sim = make_sim()
    sim.spawn(EntitySpec("humanoid", variant(HUMANOID, kind), pose=Pose.from_xyz_rpy(0, 0, 0.93)))
    suite = sim.sensors["humanoid"]
    hw = sim.hardware["humanoid"]
    references = {s.name: Reference(s, sim.sensor_seed, sim.world.contacts) for s in suite.sensors}
    names = list(hw.names)
    pitch = {"hip_pitch": -0.5, "knee": 1.0, "ankle_pitch": -0.5}
    squat = [pitch.get(n.split("_", 1)[1], 0.0) if n.startswith(("left_", "right_")) else 0.0 for n in names]
    torso = sim.entities["humanoid"].skeleton.getBodyNode("torso")
    gravity = np.asarray(sim.world.gravity)
    worst = 0.0
    sampled = {name: 0 for name in references}
    try:
        for k in range(1200):
            t = sim.world.time
            due = [s for s in suite.sensors if s.due(t)]
            expected = {s.name: references[s.name].sample(t, gravity) for s in due}   # the same DART state
            sim.sample_sensors()
            for sensor in due:
                sampled[sensor.name] += 1
                want = expected[sensor.name]
                if isinstance(sensor, ContactSensor):
                    got = sensor.contacts
                    assert [c.other for c in got] == [c[4] for c in want]
                    for c, (position, normal, force, depth, _) in zip(got, want, strict=True):
                        assert c.depth == depth
                        worst = max(worst, close(c.position, position, "contact position"),
                                    close(c.normal, normal, "contact normal"), close(c.force, force, "contact force"))
                else:
                    worst = max(worst, close(sensor.values, want, f"{sensor.name} at step {k}"))
            if k % 10 == 0:
                # the balance's inputs: contact points and loaded links from the shared walk, foot wrenches
                touching = suite.contacts(t)
                points, links = robot_contacts(sim.world.contacts(), "humanoid")
                assert touching.points == points and touching.links == links
                wrenches = suite.force_torque(links)
                expected_wrenches = [(s.spec.link, references[s.name].world_wrench()) for s in suite.sensors
                                     if isinstance(s, ForceTorqueSensor)]     # every mean restarts
                expected_wrenches = [wrench for link, wrench in expected_wrenches if link in links]
                assert len(wrenches) == len(expected_wrenches)
                for got, want in zip(wrenches, expected_wrenches, strict=True):
                    for a, b in zip(got, want, strict=True):
                        worst = max(worst, close(a, b, "world wrench"))
            depth = 0.3 * (1.0 - math.cos(2 * math.pi * k / 1000.0))
            hw.apply_command(names, ["position"] * len(names), [p * depth for p in squat])
            if 600 <= k < 700:     # a push on the torso: contacts come and go
                torso.addExtForce(np.array([120.0, 40.0, 0.0]), np.zeros(3), False, False)
            sim.step(1)
    finally:
        sim.clear()
    assert sampled["imu_sensor"] == 1200 and sampled["left_foot_contact"] == 120
    assert worst < 1e-9


def test_noise_blocks_are_the_per_sample_stream_bit_for_bit():
    noise = {c: Noise("gaussian", mean=0.01 * i, stddev=0.2 + 0.1 * i, bias_mean=0.05, bias_stddev=0.02)
             for i, c in enumerate(IMU_INTERFACES[4:])}
    blocks = _NoiseModel(IMU_INTERFACES, noise, 3, "humanoid/imu_sensor")
    reference = ReferenceNoise(IMU_INTERFACES, noise, 3, "humanoid/imu_sensor")
    for _ in range(int(2.5 * NOISE_BLOCK)):
        want = [0.0] * len(IMU_INTERFACES)
        reference.apply(want)
        got = blocks.next()
        assert got == want   # exactly: the same draws, the same arithmetic


def test_sensors_leave_the_physics_alone():
    """Their SimpleFrames ride on the links but do not change a step: positions bit-identical, sensors on or off."""
    traces = []
    for enabled in (True, False):
        world = PhysicsWorld(1000.0, (0.0, 0.0, -9.81))
        world.add_ground()
        sim = Simulation(world, parse_gains({"*": {"p": 3000.0, "d": 30.0}}), sensors_enabled=enabled)
        sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.93)))
        rows = []
        for _ in range(400):
            sim.sample_sensors()
            sim.step(1)
            rows.append(np.array(sim.entities["humanoid"].skeleton.getPositions()))
        traces.append(np.array(rows))
        sim.clear()
    assert np.array_equal(traces[0], traces[1])


def test_one_frame_per_link_and_the_shared_walk_sees_a_cleared_result():
    sim = make_sim()
    sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.93)))
    suite = sim.sensors["humanoid"]
    try:
        frames = {id(s.frame) for s in suite.sensors}
        assert len(frames) == 3          # the pelvis IMU's, each foot's (its F/T and contact sensors share it)
        sim.step(300)
        t = sim.world.time
        assert len(suite.contacts(t).points) >= 4
        sim.delete("ground_plane")       # clears the world's contacts at the same sim time
        assert suite.contacts(t).points == [] and suite.contacts(t).links == set()
    finally:
        sim.clear()


def reference_balance_state(com, com_acceleration, gravity_z: float, contacts, feet, weight: float):
    """The first balance_state: numpy for the ZMP, the mean contact height and the polygon's edges."""
    from nodes.sim.humanoid_state import COP_MARGIN, COP_MIN_LOAD, center_of_pressure

    def inside(point, polygon, tolerance=1e-6):
        if len(polygon) < 3:
            return False
        px, py = point
        for (ax, ay), (bx, by) in zip(polygon, polygon[1:] + polygon[:1], strict=True):
            edge = np.hypot(bx - ax, by - ay)
            if edge != 0 and ((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / edge < -tolerance:
                return False
        return True

    def hull_of(points):
        unique = sorted(set(points))
        if len(unique) <= 2:
            return unique

        def cross(o, a, b):
            return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

        lower, upper = [], []
        for p in unique:
            while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
                lower.pop()
            lower.append(p)
        for p in reversed(unique):
            while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
                upper.pop()
            upper.append(p)
        return lower[:-1] + upper[:-1]

    com = np.asarray(com, dtype=float)
    hull = hull_of((float(p[0]), float(p[1])) for p in contacts)
    ground_z = float(np.mean([p[2] for p in contacts])) if contacts else 0.0
    denominator = float(com_acceleration[2]) - gravity_z
    zmp = com[:2] - (com[2] - ground_z) * np.asarray(com_acceleration[:2]) / denominator \
        if abs(denominator) > 1e-6 else com[:2].copy()
    zmp = (float(zmp[0]), float(zmp[1]))
    cop, load = center_of_pressure(feet, ground_z) if feet else (None, 0.0)
    if cop is not None and contacts and load >= COP_MIN_LOAD * weight:
        return hull, ground_z, zmp, cop, inside(cop, hull, -COP_MARGIN), "cop"
    return hull, ground_z, zmp, cop, inside(zmp, hull), "zmp"


def test_balance_matches_the_first_balance_state(monkeypatch):
    """The plain-float balance_state against the numpy one, on the inputs of a squat with a push."""
    import nodes.sim.simulation as simulation

    calls = []
    plain = simulation.balance_state

    def recorded(*args):
        result = plain(*args)
        calls.append((args, result))
        return result

    monkeypatch.setattr(simulation, "balance_state", recorded)
    sim = make_sim()
    sim.spawn(EntitySpec("humanoid", HUMANOID, pose=Pose.from_xyz_rpy(0, 0, 0.93)))
    hw = sim.hardware["humanoid"]
    torso = sim.entities["humanoid"].skeleton.getBodyNode("torso")
    knees = ["left_knee", "right_knee", "left_hip_pitch", "right_hip_pitch", "left_ankle_pitch", "right_ankle_pitch"]
    try:
        for k in range(2000):
            sim.sample_sensors()
            if k % 10 == 0:
                sim.balance("humanoid")
            depth = 0.3 * (1.0 - math.cos(2 * math.pi * k / 1000.0))
            hw.apply_command(knees, ["position"] * 6, [depth, depth, -depth / 2, -depth / 2, -depth / 2, -depth / 2])
            if 1200 <= k < 1300:
                torso.addExtForce(np.array([400.0, 0.0, 0.0]), np.zeros(3), False, False)
            sim.step(1)
    finally:
        sim.clear()
    sources = set()
    for (com, acceleration, gravity_z, contacts, feet, weight), state in calls:
        hull, ground_z, zmp, cop, balanced, source = reference_balance_state(
            com, acceleration, gravity_z, contacts, feet, weight)
        assert [(x, y) for x, y, _ in state.support_polygon] == hull
        assert all(z == pytest.approx(ground_z, abs=1e-15) for _, _, z in state.support_polygon)
        assert state.zmp == zmp and state.source == source and state.is_balanced == balanced
        assert (state.cop is None) == (cop is None)
        if cop is not None:
            assert state.cop == pytest.approx(cop, abs=1e-12)
        sources.add((source, balanced))
    assert len(calls) == 200 and ("cop", True) in sources and ("cop", False) in sources
