"""force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster: a force/torque sensor's state interfaces as
geometry_msgs/WrenchStamped on ``~/wrench``, once per update.

ros2_controllers' parameters: ``sensor_name`` (the six ``<sensor_name>/force.x`` ... ``torque.z``) or
``interface_names.force.x`` ... ``interface_names.torque.z`` (any subset; not both), ``frame_id``, and per axis
``offset.*`` (added) then ``multiplier.*`` (applied to the sum)."""

from __future__ import annotations

from dataclasses import dataclass, fields, make_dataclass

import msgs
from msgs.geometry_msgs import WrenchStamped
from nodes.control.controller import ControllerError
from nodes.control.controllers.sensor_broadcaster import SensorBroadcaster, require_sensor, require_text
from nodes.control.semantic_components import ForceTorqueSensor
from nodes.core.param_schema import namespace, param

_header = msgs.builder("std_msgs/msg/Header")
_vector3 = msgs.builder("geometry_msgs/msg/Vector3")
_wrench = msgs.builder("geometry_msgs/msg/Wrench")


def _per_axis_schema(name: str, kind: type, default: object, description: str) -> type:
    """A parameter group ``force.{x,y,z}`` + ``torque.{x,y,z}``, each axis of ``kind`` with ``default``."""
    axes = make_dataclass(f"{name}Axes", [(axis, kind, param(default, description=description)) for axis in "xyz"],
                          frozen=True)
    return make_dataclass(name, [(quantity, axes, namespace(axes)) for quantity in ("force", "torque")], frozen=True)


InterfaceNames = _per_axis_schema("InterfaceNames", str, "", "state interface of this axis ('': none)")
Offsets = _per_axis_schema("Offsets", float, 0.0, "added to this axis")
Multipliers = _per_axis_schema("Multipliers", float, 1.0, "applied to this axis after the offset")


@dataclass(frozen=True)
class ForceTorqueSensorBroadcasterParameters:
    sensor_name: str = param("", description="the sensor: its interfaces are <sensor_name>/force.x, ... torque.z")
    interface_names: InterfaceNames = namespace(InterfaceNames)
    frame_id: str = param("", description="header.frame_id of the messages (a TF frame)")
    offset: Offsets = namespace(Offsets)
    multiplier: Multipliers = namespace(Multipliers)


def _per_axis(group) -> list:
    """(force.x, force.y, force.z, torque.x, torque.y, torque.z) of a force/torque parameter group."""
    return [getattr(getattr(group, quantity), f.name) for quantity in ("force", "torque")
            for f in fields(getattr(group, quantity))]


class ForceTorqueSensorBroadcaster(SensorBroadcaster):
    type_name = "force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster"
    Params = ForceTorqueSensorBroadcasterParameters
    params: ForceTorqueSensorBroadcasterParameters

    def on_configure(self) -> None:
        p = self.params
        names = dict(zip(("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z"),
                         _per_axis(p.interface_names), strict=True))
        names = {axis: name for axis, name in names.items() if name}
        if p.sensor_name and names:
            raise ControllerError("parameters 'sensor_name' and 'interface_names' cannot both be set")
        if not p.sensor_name and not names:
            raise ControllerError("'sensor_name' or at least one 'interface_names.[force|torque].[x|y|z]' parameter "
                                  "has to be set")
        require_text(p.frame_id, "frame_id")
        if p.sensor_name:
            require_sensor(self, p.sensor_name, "force_torque")
        self.component = self.sensor = ForceTorqueSensor(p.sensor_name, names or None)
        self._offsets = _per_axis(p.offset)
        self._multipliers = _per_axis(p.multiplier)
        self._pub = self.context.create_publisher(WrenchStamped, "~/wrench")

    def update(self, time: float, period: float) -> None:
        if not self._pub.has_subscribers:   # a message nobody reads is not even built (unlike rclcpp)
            return
        raw = self.sensor.get_wrench()
        if any(v != v for v in raw):   # NaN: no state has arrived yet
            return
        fx, fy, fz, tx, ty, tz = [(v + o) * m for v, o, m in zip(raw, self._offsets, self._multipliers, strict=True)]
        self._pub.publish_fields(
            header=_header(stamp=msgs.time_map(time), frame_id=self.params.frame_id),
            wrench=_wrench(force=_vector3(x=fx, y=fy, z=fz), torque=_vector3(x=tx, y=ty, z=tz)))
