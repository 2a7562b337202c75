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
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from dataclasses import dataclass

import dartpy as dart
import numpy as np

from nodes.sim.geometry import quaternion_from_rotation
from nodes.urdf.sensors import FORCE_TORQUE_INTERFACES, IMU_INTERFACES, Noise, SensorSpec

_WORLD = dart.dynamics.Frame.World()
_EPS = 1e-9


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

    def _draw_bias(self) -> None:
        bias = np.array([n.bias_mean for n in self.models]) + \
            np.array([n.bias_stddev for n in self.models]) * self.rng.standard_normal(len(self.models))
        sign = np.where(self.rng.random(len(self.models)) < 0.5, -1.0, 1.0)
        self.bias = bias * sign

    def apply(self, values: list[float]) -> None:
        if not self.indices:
            return
        noisy = self.mean + self.bias + self.stddev * self.rng.standard_normal(len(self.indices))
        for k, i in enumerate(self.indices):
            values[i] += float(noisy[k])


class _Sensor:
    channels: tuple[str, ...] = ()

    def __init__(self, spec: SensorSpec, skeleton: dart.dynamics.Skeleton, seed: int, entity: str) -> None:
        self.spec = spec
        self.name = spec.name
        self.entity = entity
        self.body = skeleton.getBodyNode(spec.link)
        if self.body is None:
            raise ValueError(f"sensor '{spec.name}': link '{spec.link}' was not loaded by DART")
        self.period = 1.0 / spec.update_rate if spec.update_rate else 0.0
        self._noise_key = (seed, f"{entity}/{spec.name}")
        self.noise = _NoiseModel(self.channels, spec.noise, *self._noise_key)
        self.values: list[float] = [0.0] * len(self.channels)
        self.stamp = math.nan            # sim time of the last sample
        # where each declared state interface sits in ``values``
        self.interface_index = [self.channels.index(i) for i in spec.state_interfaces]

    def reset(self) -> None:
        """As at spawn (a reset simulation replays the same noise)."""
        self.stamp = math.nan
        self.noise = _NoiseModel(self.channels, self.spec.noise, *self._noise_key)

    def due(self, t: float) -> bool:
        return not (self.stamp <= t) or t - self.stamp >= self.period - _EPS

    def sample(self, t: float, gravity: np.ndarray) -> None:
        self.values = self.measure(t, gravity)
        self.noise.apply(self.values)
        self.stamp = t

    def measure(self, t: float, gravity: np.ndarray) -> list[float]:
        raise NotImplementedError


class ImuSensor(_Sensor):
    channels = IMU_INTERFACES

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.offset = np.array(self.spec.pose[:3, 3])
        self.mount = np.array(self.spec.pose[:3, :3])
        self.mounted = not np.allclose(self.spec.pose, np.eye(4))
        self._velocity: np.ndarray | None = None   # world velocity of the sensor point at the last sample

    def reset(self) -> None:
        super().reset()
        self._velocity = None

    def measure(self, t: float, gravity: np.ndarray) -> list[float]:
        body = self.body
        rotation = body.getWorldTransform().rotation()
        if self.mounted:
            rotation = rotation @ self.mount
            velocity = body.getLinearVelocity(self.offset, _WORLD, _WORLD)
            angular = rotation.T @ body.getAngularVelocity()
        else:
            velocity = body.getLinearVelocity()
            angular = body.getAngularVelocity(_WORLD, body)   # in the body frame: one call, no product
        dt = t - self.stamp
        if self._velocity is not None and dt > _EPS:
            acceleration = (velocity - self._velocity) / dt      # averaged over the sensor period
        else:
            acceleration = body.getLinearAcceleration(self.offset, _WORLD, _WORLD)
        self._velocity = velocity
        specific = rotation.T @ (acceleration - gravity)
        return [*quaternion_from_rotation(rotation.tolist()), *angular.tolist(), *specific.tolist()]


class ForceTorqueSensor(_Sensor):
    channels = FORCE_TORQUE_INTERFACES

    def __init__(self, spec: SensorSpec, skeleton: dart.dynamics.Skeleton, seed: int, entity: str) -> None:
        super().__init__(spec, skeleton, seed, entity)
        self.joint = skeleton.getJoint(spec.joint)
        if self.joint is None:
            raise ValueError(f"sensor '{spec.name}': joint '{spec.joint}' was not loaded by DART")
        self.parent = self.joint.getParentBodyNode()
        self.sign = -1.0 if spec.measure_direction == "parent_to_child" else 1.0
        self._sum, self._count = [0.0] * 6, 0   # readings since the last world_wrench

    def measure(self, t: float, gravity: np.ndarray) -> list[float]:
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
        return [s * float(force[0]), s * float(force[1]), s * float(force[2]),
                s * float(torque[0]), s * float(torque[1]), s * float(torque[2])]

    def sample(self, t: float, gravity: np.ndarray) -> None:
        super().sample(t, gravity)
        self._sum = [a + b for a, b in zip(self._sum, self.values, strict=True)]
        self._count += 1

    def reset(self) -> None:
        super().reset()
        self._sum, self._count = [0.0] * 6, 0

    def world_wrench(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The mean of the readings since the last call (noise included; the last reading when there was none)
        as the child's wrench on the parent in world coordinates: (joint origin, force, torque about it).
        A mean, as the ZMP's CoM acceleration: one step's reading swings with a contact impulse."""
        transform = self.body.getWorldTransform()
        if self.spec.frame == "parent" and self.parent is not None:
            rotation = self.parent.getWorldTransform().rotation()
        elif self.spec.frame == "sensor":
            rotation = transform.rotation() @ self.spec.pose[:3, :3]
        else:
            rotation = transform.rotation()
        mean = [v / self._count for v in self._sum] if self._count else self.values
        self._sum, self._count = [0.0] * 6, 0
        values = np.asarray(mean) * self.sign
        return np.asarray(transform.translation()), rotation @ values[:3], rotation @ values[3:]


@dataclass
class ContactPoint:
    """One contact of a contact sensor's link (world frame)."""

    position: tuple[float, float, float]
    normal: tuple[float, float, float]
    force: tuple[float, float, float]
    depth: float
    other: str                 # the other body, ``model::link``


class ContactSensor(_Sensor):
    """The contacts of a link's collision shapes in the last step, each with a share of the link's contact force.

    DART's collision result carries no forces (its constraint solver keeps the impulses), so the link's total
    contact force comes from Newton's law on the link: m a = m g + (the parent joint's force on it) + contacts,
    with a the centre of mass's acceleration averaged over the sensor period (one step's swings with a contact
    impulse, as the IMU's does). Each contact point gets a share in proportion to its penetration depth."""

    channels = ()

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.contacts: list[ContactPoint] = []
        self._contacts_of: Callable[[], list] = list
        self._com_velocity: np.ndarray | None = None

    def reset(self) -> None:
        super().reset()
        self._com_velocity = None

    def _contact_force(self, t: float, gravity: np.ndarray) -> np.ndarray:
        """The world force on the link from everything it touches."""
        body = self.body
        velocity = np.asarray(body.getCOMLinearVelocity())
        dt = t - self.stamp
        if self._com_velocity is not None and dt > _EPS:
            acceleration = (velocity - self._com_velocity) / dt
        else:
            acceleration = np.asarray(body.getCOMLinearAcceleration())
        self._com_velocity = velocity
        joint = body.getParentJoint()
        on_parent = np.zeros(3)
        if joint is not None and joint.getParentBodyNode() is not None:
            # what this link applies to its parent through the joint ([torque, force] in the link frame, as the
            # force/torque sensor reads it): the joint's force on the link is its opposite
            on_parent = body.getWorldTransform().rotation() @ np.asarray(joint.getWrenchToChildBodyNode())[3:]
        return body.getMass() * (acceleration - gravity) + on_parent

    def measure(self, t: float, gravity: np.ndarray) -> list[float]:
        found = []
        for contact in self._contacts_of():
            first = contact.collisionObject1.getShapeFrame().getBodyNodePtr()
            second = contact.collisionObject2.getShapeFrame().getBodyNodePtr()
            if first is not None and first.getName() == self.body.getName() and \
                    first.getSkeleton().getName() == self.body.getSkeleton().getName():
                other, sign = second, 1.0
            elif second is not None and second.getName() == self.body.getName() and \
                    second.getSkeleton().getName() == self.body.getSkeleton().getName():
                other, sign = first, -1.0
            else:
                continue
            normal = sign * np.asarray(contact.normal)
            name = f"{other.getSkeleton().getName()}::{other.getName()}" if other is not None else ""
            found.append(ContactPoint(tuple(np.asarray(contact.point).tolist()), tuple(normal.tolist()),
                                      (0.0, 0.0, 0.0), float(contact.penetrationDepth), name))
        total = self._contact_force(t, gravity)
        if found:
            depths = np.array([max(c.depth, 0.0) for c in found])
            shares = depths / depths.sum() if depths.sum() > 0 else np.full(len(found), 1.0 / len(found))
            for contact, share in zip(found, shares, strict=True):
                contact.force = tuple((total * share).tolist())
        self.contacts = found
        return []


_MODELS: dict[str, type[_Sensor]] = {"imu": ImuSensor, "force_torque": ForceTorqueSensor, "contact": ContactSensor}


class SensorSuite:
    """Every sensor of one entity, sampled once per control period (each at its own rate)."""

    def __init__(self, specs: list[SensorSpec], skeleton: dart.dynamics.Skeleton, entity: str, seed: int = 0,
                 contacts: Callable[[], list] = list) -> None:
        self.sensors: list[_Sensor] = [_MODELS[spec.type](spec, skeleton, seed, entity) for spec in specs]
        for sensor in self.sensors:
            if isinstance(sensor, ContactSensor):
                sensor._contacts_of = contacts
        self.by_name = {sensor.name: sensor for sensor in self.sensors}
        # the ros2_control ones, whose values go into hardware/state frames
        self._reported = [s for s in self.sensors if s.interface_index]
        self.count = sum(len(s.interface_index) for s in self._reported)

    def sample(self, t: float, gravity: tuple[float, float, float]) -> None:
        g = None
        for sensor in self.sensors:
            if sensor.due(t):
                if g is None:
                    g = np.asarray(gravity, dtype=float)
                sensor.sample(t, g)

    def state_values(self) -> list[float]:
        """The ros2_control state interfaces of every sensor, in ``table()`` order."""
        out: list[float] = []
        for sensor in self._reported:
            values = sensor.values
            out += [values[i] for i in sensor.interface_index]
        return out

    def table(self) -> list[dict]:
        """The ``hardware/info`` sensor list (only sensors with ros2_control state interfaces)."""
        return [{"name": s.name, "type": s.spec.type, "frame_id": s.spec.link,
                 "state_interfaces": list(s.spec.state_interfaces)} for s in self._reported]

    def reset(self) -> None:
        for sensor in self.sensors:
            sensor.reset()

    def force_torque(self, links: set[str]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """World wrenches (``ForceTorqueSensor.world_wrench``) of the force/torque sensors on ``links``."""
        wrenches = [(s.spec.link, s.world_wrench()) for s in self.sensors if isinstance(s, ForceTorqueSensor)]
        return [wrench for link, wrench in wrenches if link in links]   # every mean restarts, loaded or not
