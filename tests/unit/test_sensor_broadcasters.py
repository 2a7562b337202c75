"""The sensor broadcasters and semantic components in-process (no Zenoh): what they publish from the sensor
state interfaces, ros2_controllers' parameters, and a missing sensor failing configure while the rest runs."""

from __future__ import annotations

import math

import pytest
import yaml

from nodes.control.config import parse_config
from nodes.control.interfaces import HardwareInterfaces, JointInfo, SensorInfo
from nodes.control.manager import STRICT, ControllerManager, ManagerError
from nodes.control.semantic_components import ForceTorqueSensor, IMUSensor
from nodes.urdf.sensors import FORCE_TORQUE_INTERFACES, IMU_INTERFACES
from tests.support.control import FakeContext, ListLogger

CONFIG = """
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    imu_sensor_broadcaster: {type: imu_sensor_broadcaster/IMUSensorBroadcaster}
    left_foot_ft_broadcaster: {type: force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster}
    scaled_ft_broadcaster: {type: force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster}
    load_cell_broadcaster: {type: force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster}
    lost_imu_broadcaster: {type: imu_sensor_broadcaster/IMUSensorBroadcaster}
    wrong_type_broadcaster: {type: imu_sensor_broadcaster/IMUSensorBroadcaster}
    both_ft_broadcaster: {type: force_torque_sensor_broadcaster/ForceTorqueSensorBroadcaster}
imu_sensor_broadcaster:
  ros__parameters:
    sensor_name: imu_sensor
    frame_id: pelvis
    static_covariance_angular_velocity: [1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0]
left_foot_ft_broadcaster:
  ros__parameters: {sensor_name: left_foot_ft, frame_id: left_foot}
scaled_ft_broadcaster:
  ros__parameters:
    sensor_name: left_foot_ft
    frame_id: left_foot
    offset: {force: {z: -10.0}}
    multiplier: {force: {z: 0.5}, torque: {x: -1.0}}
load_cell_broadcaster:
  ros__parameters:
    interface_names: {force: {z: left_foot_ft/force.z}}
    frame_id: left_foot
lost_imu_broadcaster:
  ros__parameters: {sensor_name: chest_imu, frame_id: torso}
wrong_type_broadcaster:
  ros__parameters: {sensor_name: left_foot_ft, frame_id: left_foot}
both_ft_broadcaster:
  ros__parameters:
    sensor_name: left_foot_ft
    frame_id: left_foot
    interface_names: {force: {x: left_foot_ft/force.x}}
"""
IMU_VALUES = [0.0, 0.0, 0.0, 1.0, 0.01, -0.02, 0.03, 0.1, -0.2, 9.81]
FT_VALUES = [1.0, 2.0, 300.0, 4.0, 5.0, 6.0]


class Rig:
    def __init__(self) -> None:
        self.hw = HardwareInterfaces([JointInfo("ankle", ["position"])], [
            SensorInfo("imu_sensor", "imu", "pelvis", list(IMU_INTERFACES)),
            SensorInfo("left_foot_ft", "force_torque", "left_foot", list(FORCE_TORQUE_INTERFACES))])
        self.contexts: dict[str, FakeContext] = {}
        self.logger = ListLogger()
        self.manager = ControllerManager(self.hw, parse_config(yaml.safe_load(CONFIG)), 100, self._context,
                                         self.logger)

    def _context(self, name: str) -> FakeContext:
        self.contexts[name] = FakeContext(name)
        return self.contexts[name]

    def spawn(self, *names: str) -> None:
        for name in names:
            self.manager.load(name)
            self.manager.configure(name)
        ok, message = self.manager.switch(list(names), [], STRICT)
        assert ok, message

    def cycle(self, t: float, sensor_values=IMU_VALUES + FT_VALUES) -> None:
        self.hw.read_state(["ankle"], [0.1], [0.0], [0.0], sensor_values)
        self.manager.update(t, 0.01)

    def published(self, controller: str, topic: str) -> list:
        return self.contexts[controller].publishers[f"{controller}/{topic}"].messages


def test_imu_broadcaster_publishes_the_sensor_interfaces_as_imu_with_its_covariances():
    rig = Rig()
    rig.spawn("imu_sensor_broadcaster")
    rig.cycle(2.5)
    (msg,) = rig.published("imu_sensor_broadcaster", "imu")
    assert type(msg).__name__ == "Imu" and msg.header.frame_id == "pelvis"
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (2, 500_000_000)
    assert [msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w] == IMU_VALUES[:4]
    assert [msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z] == IMU_VALUES[4:7]
    assert [msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z] == IMU_VALUES[7:]
    assert list(msg.angular_velocity_covariance) == [1.0, 0, 0, 0, 2.0, 0, 0, 0, 3.0]
    assert list(msg.orientation_covariance) == [0.0] * 9


def test_force_torque_broadcaster_publishes_the_wrench_with_offsets_then_multipliers():
    rig = Rig()
    rig.spawn("left_foot_ft_broadcaster", "scaled_ft_broadcaster", "load_cell_broadcaster")
    rig.cycle(1.0)
    (plain,) = rig.published("left_foot_ft_broadcaster", "wrench")
    assert plain.header.frame_id == "left_foot"
    w = plain.wrench
    assert [w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z] == FT_VALUES
    (scaled,) = rig.published("scaled_ft_broadcaster", "wrench")
    assert scaled.wrench.force.z == pytest.approx((300.0 - 10.0) * 0.5) and scaled.wrench.torque.x == -4.0
    (cell,) = rig.published("load_cell_broadcaster", "wrench")   # one axis: the others read 0
    assert (cell.wrench.force.z, cell.wrench.force.x, cell.wrench.torque.z) == (300.0, 0.0, 0.0)


def test_no_message_before_the_first_state_frame():
    rig = Rig()
    rig.spawn("imu_sensor_broadcaster", "left_foot_ft_broadcaster")
    rig.manager.update(0.0, 0.01)    # slots still NaN
    assert rig.published("imu_sensor_broadcaster", "imu") == []
    assert rig.published("left_foot_ft_broadcaster", "wrench") == []


def test_nothing_is_built_while_nobody_subscribes_and_the_next_cycle_publishes_again():
    rig = Rig()
    rig.spawn("imu_sensor_broadcaster", "left_foot_ft_broadcaster")
    imu = rig.contexts["imu_sensor_broadcaster"].publishers["imu_sensor_broadcaster/imu"]
    wrench = rig.contexts["left_foot_ft_broadcaster"].publishers["left_foot_ft_broadcaster/wrench"]
    imu.has_subscribers = wrench.has_subscribers = False
    rig.cycle(1.0)
    assert imu.messages == [] and wrench.messages == []
    imu.has_subscribers = wrench.has_subscribers = True   # e.g. `zenroid topic echo` starts
    rig.cycle(1.01)
    assert len(imu.messages) == 1 and len(wrench.messages) == 1
    assert imu.messages[0].header.stamp.nanosec == 10_000_000


@pytest.mark.parametrize(("name", "reason"), [
    ("lost_imu_broadcaster", "parameter 'sensor_name': 'chest_imu' is not a sensor of the hardware"),
    ("wrong_type_broadcaster", "'left_foot_ft' is a force_torque sensor, not imu"),
    ("both_ft_broadcaster", "'sensor_name' and 'interface_names' cannot both be set"),
])
def test_a_broadcaster_whose_sensor_is_missing_fails_to_configure_and_the_others_keep_running(name, reason):
    rig = Rig()
    rig.spawn("imu_sensor_broadcaster")
    rig.manager.load(name)
    with pytest.raises(ManagerError, match="failed to configure") as caught:
        rig.manager.configure(name)
    assert reason in str(caught.value)
    assert rig.manager.controllers[name].state == "unconfigured"
    rig.cycle(0.5)
    assert len(rig.published("imu_sensor_broadcaster", "imu")) == 1


def test_semantic_components_read_what_a_controller_was_lent():
    hw = HardwareInterfaces([], [SensorInfo("imu_sensor", "imu", "pelvis", list(IMU_INTERFACES)),
                                 SensorInfo("ft", "force_torque", "foot", list(FORCE_TORQUE_INTERFACES))])
    imu, ft = IMUSensor("imu_sensor"), ForceTorqueSensor("ft")
    loans = [hw.loan_state(n) for n in imu.get_state_interface_names() + ft.get_state_interface_names()]
    imu.assign_loaned_state_interfaces(loans)
    ft.assign_loaned_state_interfaces(loans)
    assert all(math.isnan(v) for v in imu.get_orientation())
    hw.read_state([], [], [], [], IMU_VALUES + FT_VALUES)
    assert imu.get_orientation() == IMU_VALUES[:4] and imu.get_linear_acceleration() == IMU_VALUES[7:]
    assert imu.get_angular_velocity() == IMU_VALUES[4:7]
    assert ft.get_forces() == FT_VALUES[:3] and ft.get_torques() == FT_VALUES[3:]
    hw.read_state([], [], [], [], IMU_VALUES)   # a short frame: the missing values read NaN, not stale ones
    assert all(math.isnan(v) for v in ft.get_forces())
    with pytest.raises(KeyError, match="no loan"):
        IMUSensor("other").assign_loaned_state_interfaces(loans)
    with pytest.raises(ValueError, match="unknown axes"):
        ForceTorqueSensor("x", {"force.w": "x/force.w"})
