"""What the two sensor broadcasters share: their sensor must be one the hardware has, of the right type, and
their state interfaces are a semantic component's."""

from __future__ import annotations

from nodes.control.controller import Controller, ControllerError
from nodes.control.semantic_components import SemanticComponent


class SensorBroadcaster(Controller):
    """A broadcaster reading one semantic component (``self.component``, made in ``on_configure``)."""

    component: SemanticComponent

    def state_interface_configuration(self) -> list[str]:
        return self.component.get_state_interface_names()

    def on_activate(self) -> None:
        self.component.assign_loaned_state_interfaces(self.state_interfaces)

    def on_deactivate(self) -> None:
        self.component.release_interfaces()


def covariance_problem(value: list[float]) -> str | None:
    """A ``static_covariance_*`` parameter: nine numbers, row-major about x, y, z."""
    return None if len(value) == 9 else f"needs 9 values (row-major 3x3), got {len(value)}"


def require_sensor(controller: Controller, name: str, sensor_type: str) -> None:
    """Refuse to configure (as ros2_control does) when the hardware has no sensor ``name`` of ``sensor_type``."""
    sensors = getattr(controller, "hardware_sensors", {})   # set by the manager before on_configure
    sensor = sensors.get(name)
    if sensor is None:
        raise ControllerError(f"parameter 'sensor_name': '{name}' is not a sensor of the hardware (its sensors: "
                              f"{sorted(sensors) or 'none'})")
    if sensor.type and sensor.type != sensor_type:
        raise ControllerError(f"parameter 'sensor_name': '{name}' is a {sensor.type} sensor, not {sensor_type}")


def require_text(value: str, parameter: str) -> None:
    if not value.strip():
        raise ControllerError(f"parameter '{parameter}' must not be empty")
