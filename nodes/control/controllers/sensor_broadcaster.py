"""What the two sensor broadcasters share: their sensor must be one the hardware has, of the right type."""

from __future__ import annotations

from nodes.control.controller import Controller, ControllerError


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
