"""force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster: a force/torque sensor's state interfaces as
geometry_msgs/WrenchStamped on ``~/wrench``, once per update.

ros2_controllers' parameters: ``sensor_name`` (the six ``<sensor_name>/force.x`` ... ``torque.z``) or
``interface_names.force.x`` ... ``interface_names.torque.z`` (any subset; not both), ``frame_id``, and per axis
``offset.*`` (added) then ``multiplier.*`` (applied to the sum)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import msgs
from msgs.geometry_msgs import WrenchStamped
from nodes.control.controller import Controller, ControllerError
from nodes.control.controllers.sensor_broadcaster import require_sensor, require_text
from nodes.control.semantic_components import ForceTorqueSensor
from nodes.core.param_schema import namespace, param

_header = msgs.builder("std_msgs/msg/Header")
_vector3 = msgs.builder("geometry_msgs/msg/Vector3")
_wrench = msgs.builder("geometry_msgs/msg/Wrench")


@dataclass(frozen=True)
class AxisNames:
    x: str = param("", description="state interface of this axis ('': none)")
    y: str = param("", description="state interface of this axis ('': none)")
    z: str = param("", description="state interface of this axis ('': none)")


@dataclass(frozen=True)
class InterfaceNames:
    force: AxisNames = namespace(AxisNames)
    torque: AxisNames = namespace(AxisNames)


@dataclass(frozen=True)
class AxisNumbers:
    x: float = param(0.0, description="per axis")
    y: float = param(0.0, description="per axis")
    z: float = param(0.0, description="per axis")


@dataclass(frozen=True)
class AxisMultipliers:
    x: float = param(1.0, description="per axis")
    y: float = param(1.0, description="per axis")
    z: float = param(1.0, description="per axis")


@dataclass(frozen=True)
class Offsets:
    force: AxisNumbers = namespace(AxisNumbers)
    torque: AxisNumbers = namespace(AxisNumbers)


@dataclass(frozen=True)
class Multipliers:
    force: AxisMultipliers = namespace(AxisMultipliers)
    torque: AxisMultipliers = namespace(AxisMultipliers)


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


class ForceTorqueSensorBroadcaster(Controller):
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
        self.sensor = ForceTorqueSensor(p.sensor_name, names or None)
        self._offsets = _per_axis(p.offset)
        self._multipliers = _per_axis(p.multiplier)
        self._pub = self.context.create_publisher(WrenchStamped, "~/wrench")

    def state_interface_configuration(self) -> list[str]:
        return self.sensor.get_state_interface_names()

    def on_activate(self) -> None:
        self.sensor.assign_loaned_state_interfaces(self.state_interfaces)

    def on_deactivate(self) -> None:
        self.sensor.release_interfaces()

    def update(self, time: float, period: float) -> None:
        raw = self.sensor.get_wrench()
        if any(v != v for v in raw):   # NaN: no state has arrived yet
            return
        fx, fy, fz, tx, ty, tz = [(v + o) * m for v, o, m in zip(raw, self._offsets, self._multipliers, strict=True)]
        self._pub.publish_fields(
            header=_header(stamp=msgs.time_map(time), frame_id=self.params.frame_id),
            wrench=_wrench(force=_vector3(x=fx, y=fy, z=fz), torque=_vector3(x=tx, y=ty, z=tz)))
