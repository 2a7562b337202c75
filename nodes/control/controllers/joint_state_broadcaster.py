"""joint_state_broadcaster/JointStateBroadcaster: every joint's position, velocity and effort on
``<ns>/joint_states`` (sensor_msgs/JointState), once per update."""

from __future__ import annotations

import math
from dataclasses import dataclass

import msgs
from msgs.sensor_msgs import JointState
from nodes.control.controller import Controller, ControllerError
from nodes.control.interfaces import read_values
from nodes.core.param_schema import param

_header = msgs.builder("std_msgs/msg/Header")


@dataclass(frozen=True)
class JointStateBroadcasterParameters:
    joints: list[str] = param([], description="joints to publish, in this order (empty: all joints of the robot)")
    interfaces: list[str] = param(["position", "velocity", "effort"], choices=("position", "velocity", "effort"),
                                  description="the state interfaces published")
    use_local_topics: bool = param(False, description="publish on ~/joint_states instead of joint_states")
    publish_rate: float = param(0.0, min_value=0.0, description="Hz; 0 publishes at every update")
    frame_id: str = param("", description="header.frame_id of the messages")


class JointStateBroadcaster(Controller):
    type_name = "joint_state_broadcaster/JointStateBroadcaster"
    Params = JointStateBroadcasterParameters
    params: JointStateBroadcasterParameters

    def on_configure(self) -> None:
        self.joints: list[str] = list(self.params.joints) or list(self.available_joints)
        if not self.joints:
            raise ControllerError("no joints: the hardware has none and parameter 'joints' is empty")
        unknown = [j for j in self.joints if j not in self.available_joints]
        if unknown:
            raise ControllerError(f"parameter 'joints': unknown joints {unknown}")
        self.kinds = list(self.params.interfaces)
        topic = "~/joint_states" if self.params.use_local_topics else "joint_states"
        self._pub = self.context.create_publisher(JointState, topic)
        rate = self.params.publish_rate
        self._period = 1.0 / rate if rate > 0 else 0.0
        self._last_publish = -math.inf
        self.frame_id = self.params.frame_id

    @property
    def available_joints(self) -> list[str]:
        # Set by the manager from the hardware description before on_configure.
        return getattr(self, "hardware_joints", [])

    def state_interface_configuration(self) -> list[str]:
        return [f"{j}/{k}" for j in self.joints for k in self.kinds]

    def on_activate(self) -> None:
        _, state = self.loans_by_name()
        self._loans = {k: [state[f"{j}/{k}"] for j in self.joints] for k in self.kinds}
        self._last_publish = -math.inf

    def update(self, time: float, period: float) -> None:
        if self._period and time - self._last_publish < self._period - 1e-9:
            return
        self._last_publish = time
        values = {k: read_values(loans) for k, loans in self._loans.items()}
        if any(v != v for v in values.get("position", ())):  # NaN: no state has arrived yet
            return
        # every cycle: fields for the generated packer (after the hardware command), no message instances
        self._pub.publish_fields(
            header=_header(stamp=msgs.time_map(time), frame_id=self.frame_id), name=self.joints,
            position=values.get("position"), velocity=values.get("velocity"), effort=values.get("effort"))
