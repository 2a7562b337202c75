"""gazebo_ros' sensor plugins, run by the simulator for a robot without ros2_control in the loop: each publishes
its sensor's reading at the sensor's rate, on the plugin's topic, as gazebo_plugins lays it out.

- ``libgazebo_ros_imu_sensor.so``: sensor_msgs/Imu (covariance diagonals from the noise);
- ``libgazebo_ros_ft_sensor.so``: geometry_msgs/WrenchStamped (the joint wrench in the sensor's frame and
  direction, as the ros2_control interfaces carry it);
- ``libgazebo_ros_bumper.so``: gazebo_msgs/ContactsState (one state per touching body, with every contact's
  position, normal, force and depth, in the world frame or the ``frame_name`` link's).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

import msgs
from nodes.core import Node
from nodes.sim.sensors import ContactSensor, SensorSuite

_header = msgs.builder("std_msgs/msg/Header")
_quaternion = msgs.builder("geometry_msgs/msg/Quaternion")
_vector3 = msgs.builder("geometry_msgs/msg/Vector3")
_wrench = msgs.builder("geometry_msgs/msg/Wrench")
_contact_state = msgs.builder("gazebo_msgs/msg/ContactState")
MESSAGE_TYPES = {"imu": "sensor_msgs/msg/Imu", "force_torque": "geometry_msgs/msg/WrenchStamped",
                 "contact": "gazebo_msgs/msg/ContactsState"}


def _imu_covariances(spec) -> tuple[list[float], list[float]]:
    """Diagonal covariances from the noise stddevs (as gazebo_ros_imu_sensor fills them)."""
    def diagonal(quantity: str) -> list[float]:
        out = [0.0] * 9
        for i, axis in enumerate("xyz"):
            noise = spec.noise.get(f"{quantity}.{axis}")
            if noise is not None and noise.active:
                out[4 * i] = noise.stddev ** 2
        return out

    return diagonal("angular_velocity"), diagonal("linear_acceleration")


def _has_subscribers(publisher: Any) -> Callable[[], bool]:
    return lambda: publisher.has_subscribers


def _vector(values) -> Any:
    x, y, z = (float(v) for v in values)
    return _vector3(x=x, y=y, z=z)


class SensorPlugins:
    """The plugins of one robot's sensors: a publisher each, fed from the sensors the simulator samples."""

    def __init__(self, node: Node, sensors: SensorSuite, robot_namespace: str) -> None:
        self.entries: list[tuple[Any, Any, Any, str, Any]] = []   # sensor, publisher, packer, frame, extra
        for sensor in sensors.sensors:
            plugin = sensor.spec.plugin
            if plugin is None:
                continue
            type_name = MESSAGE_TYPES[sensor.spec.type]
            publisher = node.create_publisher(msgs.get_type(type_name), "/" + plugin.key(robot_namespace),
                                              reliable=False)
            frame = plugin.frame_name or (sensor.spec.link if sensor.spec.type != "contact" else "world")
            extra = _imu_covariances(sensor.spec) if sensor.spec.type == "imu" else None
            self.entries.append((sensor, publisher, msgs.packer(type_name), frame, extra))
            if isinstance(sensor, ContactSensor):   # its plugin is its only reader
                sensor.wanted = _has_subscribers(publisher)

    @property
    def publishers(self) -> list[Any]:
        return [publisher for _, publisher, _, _, _ in self.entries]

    def publish(self, sim_time: float) -> None:
        """Each plugin whose sensor was read at ``sim_time`` (sensors slower than the control rate skip)."""
        for sensor, publisher, pack, frame, extra in self.entries:
            if sensor.stamp != sim_time or not publisher.has_subscribers:   # nobody listens: nothing is built
                continue
            header = _header(stamp=msgs.time_map(sim_time), frame_id=frame)
            kind = sensor.spec.type
            if kind == "imu":
                qx, qy, qz, qw, wx, wy, wz, ax, ay, az = sensor.values
                payload = pack(header=header, orientation=_quaternion(x=qx, y=qy, z=qz, w=qw),
                               angular_velocity=_vector3(x=wx, y=wy, z=wz), angular_velocity_covariance=extra[0],
                               linear_acceleration=_vector3(x=ax, y=ay, z=az), linear_acceleration_covariance=extra[1])
            elif kind == "force_torque":
                values = sensor.values
                payload = pack(header=header, wrench=_wrench(force=_vector(values[:3]), torque=_vector(values[3:])))
            else:
                payload = pack(header=header, states=self._contact_states(sensor, frame))
            publisher.publish_raw(payload, droppable=True)

    @staticmethod
    def _contact_states(sensor: ContactSensor, frame: str) -> list[Any]:
        """One ContactState per body the link touches, in ``frame`` (the world, or a link of the robot)."""
        to_frame = None     # the world's: the values as the sensor has them
        if frame != "world":
            body = sensor.body.getSkeleton().getBodyNode(frame)
            if body is not None:
                to_frame = np.linalg.inv(body.getWorldTransform().matrix())
        mine = f"{sensor.entity}::{sensor.body.getName()}::collision"
        by_other: dict[str, list] = {}
        for contact in sensor.contacts:
            by_other.setdefault(contact.other, []).append(contact)
        states = []
        zero = _vector3(x=0.0, y=0.0, z=0.0)
        for other, contacts in by_other.items():
            if to_frame is None:
                forces = [contact.force for contact in contacts]
                positions = [contact.position for contact in contacts]
                normals = [contact.normal for contact in contacts]
            else:
                rotation, offset = to_frame[:3, :3], to_frame[:3, 3]
                forces = [rotation @ np.asarray(c.force) for c in contacts]
                positions = [rotation @ np.asarray(c.position) + offset for c in contacts]
                normals = [rotation @ np.asarray(c.normal) for c in contacts]
            total = [0.0, 0.0, 0.0]
            for force in forces:   # in contact order
                total = [total[0] + float(force[0]), total[1] + float(force[1]), total[2] + float(force[2])]
            states.append(_contact_state(
                info=f"{mine} touches {other}", collision1_name=mine, collision2_name=f"{other}::collision",
                wrenches=[_wrench(force=_vector(f), torque=zero) for f in forces],
                total_wrench=_wrench(force=_vector(total), torque=zero),
                contact_positions=[_vector(p) for p in positions],
                contact_normals=[_vector(n) for n in normals],
                depths=[float(c.depth) for c in contacts]))
        return states
