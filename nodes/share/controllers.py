"""What a ros2_control controllers file says about sensors, read without the URDF machinery: the launcher asks
it for every launch of the main job and must stay quick."""

from __future__ import annotations

# sensor type (nodes.urdf.sensors) -> the broadcaster that publishes it
BROADCASTER_TYPES = {"imu": "imu_sensor_broadcaster/IMUSensorBroadcaster",
                     "force_torque": "force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster"}


def broadcasters(config: dict) -> list[str]:
    """The sensor broadcasters of a controllers file (what the launch spawns after joint_state_broadcaster)."""
    manager = (config.get("controller_manager") or {}).get("ros__parameters") or {}
    return [name for name, value in manager.items()
            if isinstance(value, dict) and value.get("type") in BROADCASTER_TYPES.values()]
