"""The Zenoh side of one spawned robot: its hardware frames, humanoid_state and hardware/info service.

A link gets what it works with: the node its endpoints live on (``nodes.core.Node``), the ``Simulation``
that holds the robot (mode, physics rate, balance) and the robot's ``HardwareInterface``.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import msgs
from msgs.classes import maker
from msgs.zenroid_msgs import HardwareJoint, HardwareSensor
from nodes.core import Node
from nodes.core.delivery import Pulled, Raw
from nodes.core.endpoints import SingleSender, source_label
from nodes.sim.hardware import CommandError, HardwareInterface
from nodes.sim.interfaces import (
    GetHardwareInfo,
    HardwareCommand,
    HardwareHeartbeat,
    HardwareState,
    HumanoidState,
)
from nodes.sim.plugins import SensorPlugins
from nodes.sim.simulation import Simulation
from nodes.sim.stepping import CommandInbox

# NaN passes the decoder: it is rejected per joint (and logged) when applied, so one bad joint does not
# cost the others their command.
_COMMAND_LIMITS = msgs.Limits(allow_nonfinite=True)
_pack_state = msgs.packer("zenroid_msgs/msg/HardwareState")
_make_state = maker(HardwareState)   # composed: our own values, stored without the setters' checks
_pack_humanoid_state = msgs.packer("humanoid_msgs/msg/HumanoidState")
_pack_heartbeat = msgs.packer("zenroid_msgs/msg/HardwareHeartbeat")
_Time = msgs.get_type("builtin_interfaces/msg/Time")
_header = msgs.builder("std_msgs/msg/Header")
_point = msgs.builder("geometry_msgs/msg/Point")

Command = HardwareCommand   # a decoded zenroid_msgs/HardwareCommand
# Commands kept in Zenoh's buffer between two control periods (the oldest go first): lockstep needs the
# last lockstep_delay + 1, realtime the newest.
COMMAND_BACKLOG = 64


def parse_command(payload: bytes | Any) -> Any:
    """Decode a HardwareCommand (once per control period); raises CommandError naming the field. A composed
    controller manager's command comes as the object it built (``objects=True``): taken as it is."""
    if not isinstance(payload, bytes):
        return payload
    try:
        return msgs.decode(HardwareCommand, payload, _COMMAND_LIMITS)
    except msgs.DecodeError as exc:
        raise CommandError(str(exc)) from None


class RobotLink:
    def __init__(self, node: Node, sim: Simulation, hardware: HardwareInterface, command_timeout: float) -> None:
        """``command_timeout`` (wall s): a command answering a state older than this is stale (ignored)."""
        self.node = node
        self.sim = sim
        self.hardware = hardware
        self.sensors = sim.sensors[hardware.entity.namespace]
        self.command_timeout = command_timeout
        self.namespace = hardware.entity.namespace
        self.inbox = CommandInbox()
        self.update_rate = 0.0          # learned from the controller manager's commands
        self.holding = True             # no controller commands in effect
        self._last_state_step: int | None = None  # step of the last hardware/state sent (stale commands)
        self.answer_due: deque[int] = deque()   # lockstep: published steps whose commands are still to apply
        self.gave_up = False            # lockstep timed out: free-run until a command arrives again
        ns = "/" + self.namespace
        # A subscriber behind a stalled link must never stall physics (Zenoh's BLOCK would, for seconds,
        # through the router): periodic streams drop instead, and so do hardware frames in realtime mode,
        # where the next frame supersedes a lost one. In lockstep every frame counts (a lost one costs a
        # lockstep_timeout), and the simulator waits for the controller manager anyway.
        self.state_pub = node.create_publisher(HardwareState, f"{ns}/hardware/state", express=True)
        self.humanoid_pub = node.create_publisher(HumanoidState, f"{ns}/humanoid_state", reliable=False)
        # while paused: "still here, only stopped", so a controller manager can tell a pause from a lost link
        self.heartbeat_pub = node.create_publisher(HardwareHeartbeat, f"{ns}/hardware/heartbeat", reliable=False)
        # one controller manager commands a robot (as one ros2_control hardware has one manager): commands from
        # a second source are ignored and reported while the first keeps commanding
        self._commander = SingleSender(takeover_after=command_timeout)
        # pulled: commands wait in Zenoh's buffer until the physics thread takes them (command_for,
        # newest_command), which holds the GIL while DART steps: a delivering thread would wait for it
        self.command_sub = node.create_subscription(HardwareCommand, f"{ns}/hardware/command", self._on_command,
                                                    delivery=Pulled(backlog=COMMAND_BACKLOG),
                                                    message=Raw(objects=True, with_source=True))
        self.info_srv = node.create_service(GetHardwareInfo, f"{ns}/hardware/info", self._on_info)
        # gazebo_ros sensor plugins (IMU, force/torque, bumper): published from here, at the sensor's rate
        self.plugins = SensorPlugins(node, self.sensors, self.namespace)
        self._endpoints = [self.state_pub, self.humanoid_pub, self.heartbeat_pub, self.command_sub, self.info_srv,
                           *self.plugins.publishers]

    def destroy(self) -> None:
        for endpoint in self._endpoints:
            try:
                self.node.destroy_entity(endpoint)
            except Exception:  # noqa: BLE001 - already gone
                pass

    def _on_command(self, payload: bytes, source: bytes | None = None) -> None:
        try:
            command = parse_command(payload)
        except CommandError as exc:
            self.node.logger.warn_throttle(1.0, f"{self.namespace}/hardware/command: dropped a malformed "
                                           f"message: {exc}", key=f"cmdparse:{self.namespace}")
            return
        if not self._commander.admit(source, time.monotonic()):
            self.node.logger.warn_throttle(
                1.0, f"{self.namespace}/hardware/command: two sources command this robot: "
                f"{source_label(self._commander.owner)} (in control) and {source_label(source)} (ignored, "
                f"{self._commander.refused} command(s) so far)", key=f"cmdsource:{self.namespace}")
            return
        last = self._last_state_step
        if last is not None and 0 <= command.step < last - self.command_timeout * self.sim.physics_rate:
            # Buffered in a network that was cut, or from a controller manager that fell far behind: its
            # controllers computed it from a state older than command_timeout (the simulator has been
            # holding position meanwhile). Applying it would replay stale trajectory points.
            self.node.logger.warn_throttle(1.0, f"{self.namespace}/hardware/command: ignored a stale command "
                                           f"for step {command.step} (now at step {last})",
                                           key=f"stale:{self.namespace}")
            return
        self.inbox.put(command)

    def command_for(self, step: int, timeout: float) -> Any:
        """Lockstep: the command answering ``step``, waiting up to ``timeout`` wall s; None if none came."""
        self.command_sub.take_pending()
        deadline = time.monotonic() + timeout
        while (command := self.inbox.take_step(step)) is None:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or self.command_sub.closed:
                return None
            self.command_sub.wait(remaining)
        return command

    def newest_command(self) -> Any:
        """Realtime (and lockstep before a controller manager answers): the newest command, or None."""
        self.command_sub.take_pending()
        return self.inbox.take()

    # -- hardware frames --------------------------------------------------------------------------------
    def publish_state(self, step: int, sim_time: float) -> None:
        hw = self.hardware
        fields = dict(step=step, name=hw.names, position=hw.positions().tolist(), velocity=hw.velocities().tolist(),
                      effort=hw.efforts().tolist(), sensor_values=self.sensors.state_values())
        if self.state_pub.local_subscriptions:
            # a controller manager in this process (composed): the frame as an object, never encoded for it
            self.state_pub.publish(_make_state(stamp=_Time(**msgs.time_map(sim_time)), **fields),
                                   droppable=self.sim.mode == "realtime")
        else:
            self.state_pub.publish_raw(_pack_state(stamp=msgs.time_map(sim_time), **fields),
                                       droppable=self.sim.mode == "realtime")
        self._last_state_step = step

    def publish_plugins(self, sim_time: float) -> None:
        """What the gazebo_ros sensor plugins publish: each sensor read at ``sim_time``, as its plugin would."""
        self.plugins.publish(sim_time)

    def publish_heartbeat(self, step: int, sim_time: float) -> None:
        self.heartbeat_pub.publish_raw(_pack_heartbeat(stamp=msgs.time_map(sim_time), step=step, paused=True),
                                       droppable=True)

    def apply(self, command) -> None:
        try:
            self.hardware.apply_command(command.name, command.interface, command.value)
        except CommandError as exc:
            self.node.logger.warn_throttle(1.0, f"{self.namespace}/hardware/command rejected: {exc}",
                                           key=f"cmd:{self.namespace}")
            return
        if command.update_rate > 0:
            self.update_rate = float(command.update_rate)
        self.holding = False

    def reset(self) -> None:
        """After a world or simulation reset: commands and pending lockstep answers mean nothing any more."""
        self.inbox.clear()
        self.answer_due.clear()
        self.holding = True

    def hold(self, reason: str) -> None:
        if not self.holding:
            self.node.logger.warn(f"{self.namespace}: {reason}; holding position")
        self.hardware.hold_position()
        self.holding = True

    # -- outputs ----------------------------------------------------------------------------------------
    def publish_humanoid_state(self, sim_time: float) -> None:
        """humanoid_msgs/HumanoidState."""
        hw = self.hardware
        balance = self.sim.balance(self.namespace)
        com, cop = balance.center_of_mass, balance.cop
        self.humanoid_pub.publish_raw(_pack_humanoid_state(
            header=_header(stamp=msgs.time_map(sim_time), frame_id="world"),
            joint_names=hw.names, joint_positions=hw.positions().tolist(),
            joint_velocities=hw.velocities().tolist(), joint_efforts=hw.efforts().tolist(),
            center_of_mass=_point(x=float(com[0]), y=float(com[1]), z=float(com[2])),
            support_polygon=[_point(x=float(x), y=float(y), z=float(z)) for x, y, z in balance.support_polygon],
            zmp_x=float(balance.zmp[0]), zmp_y=float(balance.zmp[1]), is_balanced=bool(balance.is_balanced),
            cop_measured=cop is not None, cop_x=float(cop[0]) if cop else 0.0, cop_y=float(cop[1]) if cop else 0.0,
            balance_source=balance.source))

    def _on_info(self, _request) -> object:
        return GetHardwareInfo.Response(
            robot_name=self.hardware.entity.name, mode=self.sim.mode,
            physics_rate=self.sim.physics_rate,
            joints=[HardwareJoint(**row) for row in self.hardware.joint_table()],
            sensors=[HardwareSensor(**row) for row in self.sensors.table()],
        )
