"""imu_sensor_broadcaster/IMUSensorBroadcaster: an IMU's state interfaces as sensor_msgs/Imu on ``~/imu``,
once per update (ros2_controllers' parameters: ``sensor_name``, ``frame_id``, ``static_covariance_*``)."""

from __future__ import annotations

from dataclasses import dataclass

import msgs
from msgs.sensor_msgs import Imu
from nodes.control.controllers.sensor_broadcaster import (
    SensorBroadcaster,
    covariance_problem,
    require_sensor,
    require_text,
)
from nodes.control.semantic_components import IMUSensor
from nodes.core.param_schema import param

_header = msgs.builder("std_msgs/msg/Header")
_quaternion = msgs.builder("geometry_msgs/msg/Quaternion")
_vector3 = msgs.builder("geometry_msgs/msg/Vector3")
_ZERO_COVARIANCE = [0.0] * 9


@dataclass(frozen=True)
class ImuSensorBroadcasterParameters:
    sensor_name: str = param("", description="the sensor: its interfaces are <sensor_name>/orientation.x, ...")
    frame_id: str = param("", description="header.frame_id of the messages (a TF frame)")
    static_covariance_orientation: list[float] = param(
        _ZERO_COVARIANCE, validator=covariance_problem, description="row-major about x, y, z")
    static_covariance_angular_velocity: list[float] = param(
        _ZERO_COVARIANCE, validator=covariance_problem, description="row-major about x, y, z")
    static_covariance_linear_acceleration: list[float] = param(
        _ZERO_COVARIANCE, validator=covariance_problem, description="row-major x, y, z")


class IMUSensorBroadcaster(SensorBroadcaster):
    type_name = "imu_sensor_broadcaster/IMUSensorBroadcaster"
    Params = ImuSensorBroadcasterParameters
    params: ImuSensorBroadcasterParameters

    def on_configure(self) -> None:
        require_text(self.params.sensor_name, "sensor_name")
        require_text(self.params.frame_id, "frame_id")
        require_sensor(self, self.params.sensor_name, "imu")
        self.component = self.imu = IMUSensor(self.params.sensor_name)
        self._pub = self.context.create_publisher(Imu, "~/imu")
        p = self.params
        self._covariances = (list(p.static_covariance_orientation), list(p.static_covariance_angular_velocity),
                             list(p.static_covariance_linear_acceleration))

    def update(self, time: float, period: float) -> None:
        if not self._pub.has_subscribers:   # a message nobody reads is not even built (unlike rclcpp)
            return
        qx, qy, qz, qw, wx, wy, wz, ax, ay, az = self.imu.get_values()
        if qw != qw:   # NaN: no state has arrived yet
            return
        orientation_cov, angular_cov, linear_cov = self._covariances
        self._pub.publish_fields(
            header=_header(stamp=msgs.time_map(time), frame_id=self.params.frame_id),
            orientation=_quaternion(x=qx, y=qy, z=qz, w=qw), orientation_covariance=orientation_cov,
            angular_velocity=_vector3(x=wx, y=wy, z=wz), angular_velocity_covariance=angular_cov,
            linear_acceleration=_vector3(x=ax, y=ay, z=az), linear_acceleration_covariance=linear_cov)
