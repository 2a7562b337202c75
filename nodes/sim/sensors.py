"""The robot's own senses, measured from DART: IMU, force/torque and contact sensors (declared in the URDF,
``nodes.urdf.sensors``).

- **IMU**: orientation of the sensor frame in the world (REP-145: x forward, z up, no drift), angular velocity
  in the sensor frame, and linear acceleration as an accelerometer reads it, the specific force Rᵀ(a − g):
  +9.81 on the up axis at rest. The acceleration is the sensor point's velocity change over the sensor period,
  not DART's value of the last step: DART folds a contact impulse into one step's acceleration, which spikes.
- **Force/torque**: the wrench the measured joint transmits (``Joint.getWrenchToChildBodyNode``: the child's
  wrench on the parent, in the child frame, about the joint origin, measured), turned into the
  ``measure_direction`` and ``frame`` the declaration asks for (Gazebo's meanings; the moment point stays the
  joint origin).
- **Contact**: the contacts of the link's collision shapes (position, normal, force, depth), from the last
  step's collision result.

Values are sampled at each sensor's ``update_rate`` (every control period without one) and held in between, as
a Gazebo sensor updates. Noise is Gazebo's gaussian model, drawn from a generator seeded by the simulator's
``sensor_seed``, the entity and the sensor's name: lockstep runs with noise are bit-identical.

What it costs: the IMU and the force/torque sensors are read every control period (1 kHz), so each dartpy call
counts. pybind11 converts a BodyNode or a Joint to the class that declares the method through their multiple
inheritance: a Frame method on a BodyNode (``getWorldTransform``, ``getLinearVelocity``) costs 20-38 k
instructions, a Joint method (``getWrenchToChildBodyNode``) 34 k, against ~5 k for the same on a SimpleFrame or a
BodyNode's own method (callgrind). So the sensors read a SimpleFrame fixed on the link (``_probe``) and the child
link's ``getBodyForce``, compute with plain floats, draw their noise in blocks, and the contact sensors share one
walk over the step's contacts (``ContactScan``) with the robot's balance.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import dartpy as dart
import numpy as np

from nodes.sim.geometry import quaternion_from_rotation
from nodes.urdf.sensors import FORCE_TORQUE_INTERFACES, IMU_INTERFACES, Noise, SensorSpec

_WORLD = dart.dynamics.Frame.World()
_EPS = 1e-9
_sqrt = math.sqrt
# Samples of noise drawn at a time per sensor: one generator call for 250 samples instead of 250 (a call costs
# ~7 k instructions, a value ~70).
NOISE_BLOCK = 250
_FOLD = 1000   # force/torque readings kept before they are added up

Vector = tuple[float, float, float]


class _Probes:
    """Frames fixed on links (SimpleFrames), read in place of the links: a probe's world transform and velocity
    are DART's for that point of the link (exactly the link's at the identity), and dartpy reads a SimpleFrame's
    for ~5 k instructions where the same Frame methods on a BodyNode cost 20-38 k. One per link and pose, shared
    by the sensors there: DART tells every frame on a link that it moved, ~1 k instructions a step each."""

    def __init__(self) -> None:
        self._frames: dict[tuple, dart.dynamics.SimpleFrame] = {}

    def on(self, body: dart.dynamics.BodyNode, pose: np.ndarray | None = None) -> dart.dynamics.SimpleFrame:
        pose = np.eye(4) if pose is None else np.asarray(pose, dtype=float)
        key = (body.getName(), pose.tobytes())
        frame = self._frames.get(key)
        if frame is None:
            relative = dart.math.Isometry3()
            relative.set_matrix(pose)
            frame = self._frames[key] = dart.dynamics.SimpleFrame(body, f"{body.getName()}_probe_{len(self._frames)}",
                                                                  relative)
        return frame


def _child_transform_is_identity(joint: dart.dynamics.Joint) -> bool:
    """Whether the joint frame is the child link's frame (always so for a URDF): the joint's wrench on the child
    is then minus the child's ``getBodyForce()`` exactly (``Joint::getWrenchToChildBodyNode`` applies
    ``dAdT(identity, -F)``), read for 6 k instructions instead of 34 k."""
    return bool(np.array_equal(joint.getTransformFromChildBodyNode().matrix(), np.eye(4)))


class _NoiseModel:
    """Gazebo's gaussian noise on some channels of one sensor: value + mean + bias + N(0, stddev)."""

    def __init__(self, channels: tuple[str, ...], noise: dict[str, Noise], seed: int, key: str) -> None:
        self.rng = np.random.Generator(np.random.PCG64([seed, zlib.crc32(key.encode())]))
        active = [(i, noise[c]) for i, c in enumerate(channels) if c in noise and noise[c].active]
        self.indices = [i for i, _ in active]
        self.models = [n for _, n in active]
        self.mean = np.array([n.mean for n in self.models])
        self.stddev = np.array([n.stddev for n in self.models])
        self.bias = np.zeros(len(self.models))
        if self.models:   # drawn once per channel, with a random sign (Gazebo's)
            self._draw_bias()
        self.width = len(channels)
        self._block: list[list[float]] = []
        self._next = 0

    def _draw_bias(self) -> None:
        bias = np.array([n.bias_mean for n in self.models]) + \
            np.array([n.bias_stddev for n in self.models]) * self.rng.standard_normal(len(self.models))
        sign = np.where(self.rng.random(len(self.models)) < 0.5, -1.0, 1.0)
        self.bias = bias * sign

    def _draw_block(self) -> None:
        # The generator draws its normals one after another whatever the count asked for, so row k of a block
        # is what the k-th call of standard_normal(len(indices)) gives, and (mean + bias) + stddev * z element by
        # element is the per-sample arithmetic: the same stream, bit for bit, as one draw per sample.
        z = self.rng.standard_normal((NOISE_BLOCK, len(self.indices)))
        block = np.zeros((NOISE_BLOCK, self.width))
        block[:, self.indices] = self.mean + self.bias + self.stddev * z
        self._block = block.tolist()
        self._next = 0

    def next(self) -> list[float]:
        """The next sample's noise, per channel (0.0 on a channel without noise)."""
        if self._next == len(self._block):
            self._draw_block()
        row = self._block[self._next]
        self._next += 1
        return row


class _Sensor:
    channels: tuple[str, ...] = ()
    # Whether anyone reads this sensor's measurement now (None: always). A contact sensor is read by its bumper
    # plugin only; the plugins set this to "its topic has a subscriber", so nobody listening costs no contact walk.
    wanted: Callable[[], bool] | None = None

    def __init__(self, spec: SensorSpec, skeleton: dart.dynamics.Skeleton, seed: int, entity: str,
                 probes: _Probes | None = None) -> None:
        self.spec = spec
        self.name = spec.name
        self.probes = probes if probes is not None else _Probes()
        self.entity = entity
        self.body = skeleton.getBodyNode(spec.link)
        if self.body is None:
            raise ValueError(f"sensor '{spec.name}': link '{spec.link}' was not loaded by DART")
        self.period = 1.0 / spec.update_rate if spec.update_rate else 0.0
        self.due_after = self.period - _EPS   # the due test's threshold, computed once
        self._noise_key = (seed, f"{entity}/{spec.name}")
        self.noise = _NoiseModel(self.channels, spec.noise, *self._noise_key)
        self.noisy = bool(self.noise.indices)
        self._quiet = [0.0] * len(self.channels)   # the noise of a sensor without any
        self.values: list[float] = [0.0] * len(self.channels)
        self.stamp = math.nan            # sim time of the last sample
        # where each declared state interface sits in ``values``
        self.interface_index = [self.channels.index(i) for i in spec.state_interfaces]

    def reset(self) -> None:
        """As at spawn (a reset simulation replays the same noise)."""
        self.stamp = math.nan
        self.noise = _NoiseModel(self.channels, self.spec.noise, *self._noise_key)

    def skip(self) -> None:
        """Due but unread (``wanted`` says so): left as it was."""

    def due(self, t: float) -> bool:
        return not (self.stamp <= t) or t - self.stamp >= self.due_after

    def sample(self, t: float, gravity: Sequence[float]) -> None:
        self.values = self.measure(t, gravity, self.noise.next() if self.noisy else self._quiet)
        self.stamp = t

    def measure(self, t: float, gravity: Sequence[float], noise: list[float]) -> list[float]:
        """The reading at ``t`` plus ``noise`` (a value per channel), added as the list is built: it runs at
        1 kHz, and adding it afterwards, channel by channel, cost as much again as building it."""
        raise NotImplementedError


class ImuSensor(_Sensor):
    channels = IMU_INTERFACES

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.offset = np.array(self.spec.pose[:3, 3])
        self.frame = self.probes.on(self.body, self.spec.pose)   # the sensor frame on the link
        if any(i < 4 for i in self.noise.indices):
            raise ValueError(f"sensor '{self.name}': noise on the orientation is not simulated")
        self._velocity: Vector | None = None   # world velocity of the sensor point at the last sample

    def reset(self) -> None:
        super().reset()
        self._velocity = None

    def measure(self, t: float, gravity: Sequence[float], noise: list[float]) -> list[float]:
        frame = self.frame
        rotation = frame.getWorldTransform().rotation().tolist()   # the sensor frame in the world
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation
        # [angular; linear] velocity of the sensor frame in its own coordinates: the angular velocity the IMU
        # reports, and the sensor point's linear velocity, turned into the world's
        wx, wy, wz, ux, uy, uz = frame.getSpatialVelocity().tolist()
        vx = r00 * ux + r01 * uy + r02 * uz
        vy = r10 * ux + r11 * uy + r12 * uz
        vz = r20 * ux + r21 * uy + r22 * uz
        dt = t - self.stamp
        previous = self._velocity
        self._velocity = (vx, vy, vz)
        gx, gy, gz = gravity
        if previous is not None and dt > _EPS:      # averaged over the sensor period
            px, py, pz = previous
            fx, fy, fz = (vx - px) / dt - gx, (vy - py) / dt - gy, (vz - pz) / dt - gz
        else:
            ax, ay, az = self.body.getLinearAcceleration(self.offset, _WORLD, _WORLD).tolist()
            fx, fy, fz = ax - gx, ay - gy, az - gz
        # the specific force in the sensor frame, Rᵀ(a − g); the orientation as quaternion_from_rotation gives
        # it, its first case (a turn under 120°, trace > 0) inline
        trace = r00 + r11 + r22
        if trace > 0:
            q = _sqrt(trace + 1.0) * 2
            qx, qy, qz, qw = (r21 - r12) / q, (r02 - r20) / q, (r10 - r01) / q, 0.25 * q
        else:
            qx, qy, qz, qw = quaternion_from_rotation(rotation)
        _, _, _, _, n4, n5, n6, n7, n8, n9 = noise   # an IMU's orientation has no noise (SensorSpec has none)
        return [qx, qy, qz, qw, wx + n4, wy + n5, wz + n6, r00 * fx + r10 * fy + r20 * fz + n7,
                r01 * fx + r11 * fy + r21 * fz + n8, r02 * fx + r12 * fy + r22 * fz + n9]


class ForceTorqueSensor(_Sensor):
    channels = FORCE_TORQUE_INTERFACES

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        spec = self.spec
        self.joint = self.body.getSkeleton().getJoint(spec.joint)
        if self.joint is None:
            raise ValueError(f"sensor '{spec.name}': joint '{spec.joint}' was not loaded by DART")
        self.parent = self.joint.getParentBodyNode()
        self.sign = -1.0 if spec.measure_direction == "parent_to_child" else 1.0
        # the joint's wrench is minus the child's body force: read in the child frame, as ``sign * -F``
        self._direct = spec.frame == "child" and _child_transform_is_identity(self.joint)
        self._flip = -self.sign
        self.frame = self.probes.on(self.body)   # the child link's world transform
        self._plain = self._direct and not self.noisy
        # the readings since the last world_wrench: kept, and added up there (as they came) at its rate, 100 Hz;
        # folded into a sum every _FOLD readings if nobody asks
        self._readings: list[list[float]] = []
        self._sum, self._folded = [0.0] * 6, 0

    def measure(self, t: float, gravity: Sequence[float], noise: list[float]) -> list[float]:
        n0, n1, n2, n3, n4, n5 = noise
        if self._direct:
            mx, my, mz, fx, fy, fz = self.body.getBodyForce().tolist()   # [torque, force] on the child, child frame
            k = self._flip
            return [k * fx + n0, k * fy + n1, k * fz + n2, k * mx + n3, k * my + n4, k * mz + n5]
        wrench = np.asarray(self.joint.getWrenchToChildBodyNode())   # [torque, force]: child on parent, child frame
        torque, force = wrench[:3], wrench[3:]
        frame = self.spec.frame
        if frame == "parent" and self.parent is not None:
            rotation = self.parent.getWorldTransform().rotation().T @ self.body.getWorldTransform().rotation()
            torque, force = rotation @ torque, rotation @ force
        elif frame == "sensor":
            mount = self.spec.pose[:3, :3]
            torque, force = mount.T @ torque, mount.T @ force
        s = self.sign
        return [s * float(force[0]) + n0, s * float(force[1]) + n1, s * float(force[2]) + n2,
                s * float(torque[0]) + n3, s * float(torque[1]) + n4, s * float(torque[2]) + n5]

    def sample(self, t: float, gravity: Sequence[float]) -> None:
        if self._plain:   # measure's first case without noise, inline: this runs at 1 kHz
            mx, my, mz, fx, fy, fz = self.body.getBodyForce().tolist()
            k = self._flip
            values = [k * fx, k * fy, k * fz, k * mx, k * my, k * mz]
        else:
            values = self.measure(t, gravity, self.noise.next() if self.noisy else self._quiet)
        self.values = values
        self.stamp = t
        readings = self._readings
        readings.append(values)
        if len(readings) == _FOLD:
            self._sum = self._added(readings)
            self._folded += len(readings)
            readings.clear()

    def _added(self, readings: list[list[float]]) -> list[float]:
        """``_sum`` plus ``readings``, one after another."""
        a = self._sum
        for b in readings:
            a = [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3], a[4] + b[4], a[5] + b[5]]
        return a

    def reset(self) -> None:
        super().reset()
        self._readings, self._sum, self._folded = [], [0.0] * 6, 0

    def world_wrench(self) -> tuple[Vector, Vector, Vector]:
        """The mean of the readings since the last call (noise included; the last reading when there was none)
        as the child's wrench on the parent in world coordinates: (joint origin, force, torque about it).
        A mean, as the ZMP's CoM acceleration: one step's reading swings with a contact impulse."""
        transform = self.frame.getWorldTransform()
        if self.spec.frame == "parent" and self.parent is not None:
            rotation = self.parent.getWorldTransform().rotation().tolist()
        elif self.spec.frame == "sensor":
            rotation = (transform.rotation() @ self.spec.pose[:3, :3]).tolist()
        else:
            rotation = transform.rotation().tolist()
        count = self._folded + len(self._readings)
        mean = [v / count for v in self._added(self._readings)] if count else self.values
        self._readings, self._sum, self._folded = [], [0.0] * 6, 0
        s = self.sign
        fx, fy, fz, mx, my, mz = (s * v for v in mean)
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation
        x, y, z = transform.translation().tolist()
        return ((x, y, z),
                (r00 * fx + r01 * fy + r02 * fz, r10 * fx + r11 * fy + r12 * fz, r20 * fx + r21 * fy + r22 * fz),
                (r00 * mx + r01 * my + r02 * mz, r10 * mx + r11 * my + r12 * mz, r20 * mx + r21 * my + r22 * mz))


@dataclass(slots=True)
class ContactPoint:
    """One contact of a contact sensor's link (world frame)."""

    position: Vector
    normal: Vector
    force: Vector
    depth: float
    other: str                 # the other body, ``model::link``


# one contact of a sensed link, as the scan finds it: position, normal (out of the link), depth, the other body
RawContact = tuple[Vector, Vector, float, str]


@dataclass(slots=True)
class RobotContacts:
    """A robot's contacts in the last step (world frame)."""

    points: list[list[float]]                  # every contact with another model (the support polygon's)
    links: set[str]                            # the robot's links touching another model
    sensed: dict[str, list[RawContact]]        # every contact of each contact-sensed link (with itself too)


class ContactScan:
    """One walk over the world's contacts of the last step per sample time, shared by a robot's contact sensors
    and its balance (support polygon, links carrying load) instead of a walk each.

    Each collision object met is resolved once per walk (its shape frame looked up among the robot's shape nodes,
    an other model's name read only when a sensed link touches it) and remembered for the walk's other contacts:
    pybind11 hands back the Python object it already holds for a C++ object, so a contact costs two attribute
    reads (~6 k instructions) where comparing the bodies' and skeletons' names cost ten dartpy calls. The position
    is read only for the robot's contacts, the normal and depth only for sensed links'."""

    def __init__(self, skeleton: dart.dynamics.Skeleton, contacts_of: Callable[[], Sequence]) -> None:
        self.contacts_of = contacts_of
        # The DART world, when ``contacts_of`` is a PhysicsWorld's ``contacts``: the count of its last collision
        # result (7.5 k instructions) tells a cleared result from the walked one, where the list of contacts
        # costs 3 k per contact more to build and free.
        world = getattr(getattr(contacts_of, "__self__", None), "world", None)
        self._world = world if isinstance(world, dart.simulation.World) else None
        model = skeleton.getName()
        self.shapes: dict[object, str] = {}     # the robot's shape nodes -> their link
        self.names: dict[str, str] = {}         # link -> "model::link"
        for i in range(skeleton.getNumBodyNodes()):
            body = skeleton.getBodyNode(i)
            link = body.getName()
            self.names[link] = f"{model}::{link}"
            for node in body.getShapeNodes():
                self.shapes[node] = link
        self.sensed: set[str] = set()           # links with a contact sensor
        self._key: tuple[float, int] | None = None
        self._last = RobotContacts([], set(), {})

    def reset(self) -> None:
        self._key = None

    def at(self, t: float) -> RobotContacts:
        """The robot's contacts at sim time ``t`` (walked once per time and contact count: a removed model
        clears the world's contacts, which changes the count unless there were none)."""
        if self._world is not None:
            key = (t, self._world.getLastCollisionResult().getNumContacts())   # (the result comes as a copy)
            if key == self._key:
                return self._last
            contacts = self.contacts_of()
        else:
            contacts = self.contacts_of()
            key = (t, len(contacts))
            if key == self._key:
                return self._last
        shapes, sensed = self.shapes, self.sensed
        points: list[list[float]] = []
        links: set[str] = set()
        by_link: dict[str, list[RawContact]] = {}
        # collision objects met in this walk -> [the robot's link or None, shape frame, name or None]; held here,
        # so the same C++ object comes back as this same Python object
        met: dict[object, list] = {}
        for contact in contacts:
            first = contact.collisionObject1
            second = contact.collisionObject2
            one = met.get(first)
            if one is None:
                frame = first.getShapeFrame()
                one = met[first] = [shapes.get(frame), frame, None]
            two = met.get(second)
            if two is None:
                frame = second.getShapeFrame()
                two = met[second] = [shapes.get(frame), frame, None]
            mine1, mine2 = one[0], two[0]
            if mine1 is None:
                if mine2 is None:
                    continue                       # not this robot's
                point = contact.point.tolist()
                points.append(point)
                links.add(mine2)
            elif mine2 is None:
                point = contact.point.tolist()
                points.append(point)
                links.add(mine1)
            else:
                point = None                       # with itself: neither support nor load
            if mine1 in sensed or mine2 in sensed:
                position = tuple(point if point is not None else contact.point.tolist())
                nx, ny, nz = contact.normal.tolist()
                depth = contact.penetrationDepth
                if mine1 in sensed:
                    by_link.setdefault(mine1, []).append((position, (nx, ny, nz), depth, self._name(two)))
                if mine2 in sensed:
                    by_link.setdefault(mine2, []).append((position, (-nx, -ny, -nz), depth, self._name(one)))
        self._key = key
        self._last = RobotContacts(points, links, by_link)
        return self._last

    def _name(self, entry: list) -> str:
        """``model::link`` of a resolved collision object (read from DART once per walk for another model's)."""
        if entry[0] is not None:
            return self.names[entry[0]]
        if entry[2] is None:
            body = entry[1].getBodyNodePtr()
            entry[2] = f"{body.getSkeleton().getName()}::{body.getName()}" if body is not None else ""
        return entry[2]


class ContactSensor(_Sensor):
    """The contacts of a link's collision shapes in the last step, each with a share of the link's contact force.

    DART's collision result carries no forces (its constraint solver keeps the impulses), so the link's total
    contact force comes from Newton's law on the link: m a = m g + (the parent joint's force on it) + contacts,
    with a the centre of mass's acceleration averaged over the sensor period (one step's swings with a contact
    impulse, as the IMU's does). Each contact point gets a share in proportion to its penetration depth."""

    channels = ()

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.link = self.body.getName()
        self.contacts: list[ContactPoint] = []
        self.scan: ContactScan | None = None    # the suite's
        self._com_velocity: Vector | None = None
        joint = self.body.getParentJoint()
        # the joint the link hangs from, if it has a parent link (a root joint transmits nothing measured here)
        self._joint = joint if joint is not None and joint.getParentBodyNode() is not None else None
        self._direct = self._joint is not None and _child_transform_is_identity(self._joint)
        self.frame = self.probes.on(self.body)

    def reset(self) -> None:
        super().reset()
        self._com_velocity = None

    def skip(self) -> None:
        """Due but unread (``wanted`` says so): no reading; the next one starts its average afresh."""
        self.contacts = []
        self._com_velocity = None

    def _contact_force(self, t: float, gravity: Sequence[float]) -> Vector:
        """The world force on the link from everything it touches."""
        body = self.body
        vx, vy, vz = velocity = tuple(body.getCOMLinearVelocity().tolist())
        dt = t - self.stamp
        previous = self._com_velocity
        if previous is not None and dt > _EPS:
            ax, ay, az = (vx - previous[0]) / dt, (vy - previous[1]) / dt, (vz - previous[2]) / dt
        else:
            ax, ay, az = body.getCOMLinearAcceleration().tolist()
        self._com_velocity = velocity
        mass = body.getMass()
        gx, gy, gz = gravity
        fx, fy, fz = mass * (ax - gx), mass * (ay - gy), mass * (az - gz)
        if self._joint is not None:
            # what this link applies to its parent through the joint (the force/torque sensor's reading, in the
            # link frame), turned into the world's: the joint's force on the link is its opposite
            if self._direct:
                _, _, _, px, py, pz = body.getBodyForce().tolist()
                wx, wy, wz = -px, -py, -pz
            else:
                _, _, _, wx, wy, wz = self._joint.getWrenchToChildBodyNode().tolist()
            (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = self.frame.getWorldTransform().rotation().tolist()
            fx += r00 * wx + r01 * wy + r02 * wz
            fy += r10 * wx + r11 * wy + r12 * wz
            fz += r20 * wx + r21 * wy + r22 * wz
        return fx, fy, fz

    def measure(self, t: float, gravity: Sequence[float], noise: list[float]) -> list[float]:
        found = self.scan.at(t).sensed.get(self.link) if self.scan is not None else None
        fx, fy, fz = self._contact_force(t, gravity)
        contacts = []
        if found:
            depths = [0.0 if 0.0 > depth else depth for _, _, depth, _ in found]   # max(depth, 0.0)
            total = sum(depths)
            shares = [d / total for d in depths] if total > 0 else [1.0 / len(found)] * len(found)
            for (position, normal, depth, other), share in zip(found, shares, strict=True):
                contacts.append(ContactPoint(position, normal, (fx * share, fy * share, fz * share), depth, other))
        self.contacts = contacts
        return []


_MODELS: dict[str, type[_Sensor]] = {"imu": ImuSensor, "force_torque": ForceTorqueSensor, "contact": ContactSensor}


class SensorSuite:
    """Every sensor of one entity, sampled once per control period (each at its own rate)."""

    def __init__(self, specs: list[SensorSpec], skeleton: dart.dynamics.Skeleton, entity: str, seed: int = 0,
                 contacts: Callable[[], Sequence] = list) -> None:
        probes = _Probes()
        self.sensors: list[_Sensor] = [_MODELS[spec.type](spec, skeleton, seed, entity, probes) for spec in specs]
        self.contact_scan = ContactScan(skeleton, contacts)
        for sensor in self.sensors:
            if isinstance(sensor, ContactSensor):
                sensor.scan = self.contact_scan
                self.contact_scan.sensed.add(sensor.link)
        self.by_name = {sensor.name: sensor for sensor in self.sensors}
        self._force_torque = [s for s in self.sensors if isinstance(s, ForceTorqueSensor)]
        # the ros2_control ones, whose values go into hardware/state frames
        self._reported = [s for s in self.sensors if s.interface_index]
        self.count = sum(len(s.interface_index) for s in self._reported)
        # per reported sensor, which values in which order (None: all of them, as measured)
        self._layout = [(s, None if s.interface_index == list(range(len(s.channels))) else s.interface_index)
                        for s in self._reported]

    def sample(self, t: float, gravity: Sequence[float]) -> None:
        for sensor in self.sensors:
            stamp = sensor.stamp
            if not (stamp <= t) or t - stamp >= sensor.due_after:   # _Sensor.due, inline: it runs at 1 kHz
                wanted = sensor.wanted
                if wanted is None or wanted():
                    sensor.sample(t, gravity)
                else:
                    sensor.skip()

    def state_values(self) -> list[float]:
        """The ros2_control state interfaces of every sensor, in ``table()`` order."""
        out: list[float] = []
        for sensor, index in self._layout:
            values = sensor.values
            out += values if index is None else [values[i] for i in index]
        return out

    def table(self) -> list[dict]:
        """The ``hardware/info`` sensor list (only sensors with ros2_control state interfaces)."""
        return [{"name": s.name, "type": s.spec.type, "frame_id": s.spec.link,
                 "state_interfaces": list(s.spec.state_interfaces)} for s in self._reported]

    def reset(self) -> None:
        for sensor in self.sensors:
            sensor.reset()
        self.contact_scan.reset()

    def contacts(self, t: float) -> RobotContacts:
        """The robot's contacts in the last step (``ContactScan.at``: one walk shared with the contact sensors)."""
        return self.contact_scan.at(t)

    def force_torque(self, links: set[str]) -> list[tuple[Vector, Vector, Vector]]:
        """World wrenches (``ForceTorqueSensor.world_wrench``) of the force/torque sensors on ``links``."""
        wrenches = [(s.spec.link, s.world_wrench()) for s in self._force_torque]
        return [wrench for link, wrench in wrenches if link in links]   # every mean restarts, loaded or not
