"""ros2_control's semantic components: a sensor's state interfaces read as what they mean.

A controller lists ``component.get_state_interface_names()`` in its ``state_interface_configuration()``, hands
its loans over in ``on_activate`` (``assign_loaned_state_interfaces(self.state_interfaces)``), and reads the
sensor in ``update``::

    imu = IMUSensor("imu_sensor")
    ...
    roll_rate = imu.get_angular_velocity()[0]

``IMUSensor`` reads ``<name>/orientation.{x,y,z,w}``, ``<name>/angular_velocity.{x,y,z}`` and
``<name>/linear_acceleration.{x,y,z}``; ``ForceTorqueSensor`` reads ``<name>/force.{x,y,z}`` and
``<name>/torque.{x,y,z}``, or any subset of per-axis interface names (a load cell measuring only force.z).
"""

from __future__ import annotations

from collections.abc import Sequence

from nodes.control.interfaces import LoanedStateInterface, read_values


class SemanticComponent:
    """A named group of state interfaces, read together."""

    def __init__(self, name: str, interface_names: Sequence[str]) -> None:
        self.name = name
        self.interface_names = list(interface_names)
        self._loans: list[LoanedStateInterface] = []

    def get_state_interface_names(self) -> list[str]:
        return list(self.interface_names)

    def assign_loaned_state_interfaces(self, loans: Sequence[LoanedStateInterface]) -> None:
        """Take this component's loans out of a controller's (any order; others are ignored)."""
        by_name = {loan.name: loan for loan in loans}
        missing = [n for n in self.interface_names if n not in by_name]
        if missing:
            raise KeyError(f"{self.name}: no loan for state interface(s) {missing}")
        self._loans = [by_name[n] for n in self.interface_names]

    def release_interfaces(self) -> None:
        self._loans = []

    def get_values(self) -> list[float]:
        """Every interface's value, in ``get_state_interface_names()`` order."""
        return read_values(self._loans)


class IMUSensor(SemanticComponent):
    QUANTITIES = (("orientation", "xyzw"), ("angular_velocity", "xyz"), ("linear_acceleration", "xyz"))

    def __init__(self, name: str) -> None:
        super().__init__(name, [f"{name}/{q}.{a}" for q, axes in self.QUANTITIES for a in axes])

    def get_orientation(self) -> list[float]:
        """Quaternion (x, y, z, w) of the sensor frame in the world."""
        return read_values(self._loans[0:4])

    def get_angular_velocity(self) -> list[float]:
        """rad/s about the sensor's x, y, z axes."""
        return read_values(self._loans[4:7])

    def get_linear_acceleration(self) -> list[float]:
        """Specific force (m/s²) along the sensor's axes: +9.81 on the up axis at rest."""
        return read_values(self._loans[7:10])


AXES = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")


class ForceTorqueSensor(SemanticComponent):
    """Six axes named ``<name>/force.x``...; or ``interface_names`` per axis (``{"force.z": "cell/load"}``),
    an axis without one reads 0."""

    def __init__(self, name: str = "", interface_names: dict[str, str] | None = None) -> None:
        if interface_names:
            unknown = sorted(set(interface_names) - set(AXES))
            if unknown:
                raise ValueError(f"unknown axes {unknown} (axes: {', '.join(AXES)})")
            self.axes = [axis for axis in AXES if interface_names.get(axis)]
            names = [interface_names[axis] for axis in self.axes]
        else:
            self.axes = list(AXES)
            names = [f"{name}/{axis}" for axis in AXES]
        super().__init__(name, names)
        self._slot_of = [self.axes.index(axis) if axis in self.axes else -1 for axis in AXES]

    def _six(self) -> list[float]:
        values = read_values(self._loans)
        return [values[i] if i >= 0 else 0.0 for i in self._slot_of]

    def get_forces(self) -> list[float]:
        return self._six()[:3]

    def get_torques(self) -> list[float]:
        return self._six()[3:]

    def get_wrench(self) -> list[float]:
        """(force.x, force.y, force.z, torque.x, torque.y, torque.z)."""
        return self._six()
