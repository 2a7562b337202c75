"""The Zenoh side of one spawned robot: its hardware frames, humanoid_state and hardware/info service."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import msgpack

import msgs
from nodes.sim.hardware import CommandError, HardwareInterface
from nodes.sim.interfaces import GetHardwareInfo, HardwareCommand, HardwareState, HumanoidState
from nodes.sim.stepping import CommandInbox

if TYPE_CHECKING:
    from nodes.sim.node import SimulatorNode

_HardwareJoint = msgs.get_type("zenroid_msgs/msg/HardwareJoint")


COMMAND_FIELDS = ("step", "update_rate", "name", "interface", "value")


@dataclass(slots=True)
class Command:
    """A decoded zenroid_msgs/HardwareCommand (values checked for finiteness when applied)."""

    step: int
    update_rate: int
    name: list[str]
    interface: list[str]
    value: list[float]


def parse_command(payload: bytes) -> Command:
    """Decode a HardwareCommand without the generic codec (this runs once per control period).

    Raises CommandError naming the field; NaN values pass here and are rejected per joint when applied.
    """
    try:
        obj = msgpack.unpackb(payload, raw=False)
    except Exception as exc:  # msgpack raises several types for garbage
        raise CommandError(f"not a msgpack payload ({type(exc).__name__})") from None
    if not isinstance(obj, dict):
        raise CommandError(f"expected a map, got {type(obj).__name__}")
    for key in obj:
        if key not in COMMAND_FIELDS:
            raise CommandError(f"unknown field {key!r}")
    fields: dict[str, Any] = {}
    for key in ("step", "update_rate"):
        value = obj.get(key, 0)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise CommandError(f"{key}: expected a non-negative integer, got {value!r}")
        fields[key] = value
    for key in ("name", "interface"):
        value = obj.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise CommandError(f"{key}: expected a list of strings")
        fields[key] = value
    value = obj.get("value", [])
    if not isinstance(value, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise CommandError("value: expected a list of numbers")
    fields["value"] = value
    return Command(**fields)


def time_map(t: float) -> dict[str, int]:
    """builtin_interfaces/Time as a plain map (hot path: no dataclass round trip)."""
    sec = math.floor(t)
    nanosec = int(round((t - sec) * 1e9))
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return {"sec": int(sec), "nanosec": nanosec}


class RobotLink:
    def __init__(self, node: SimulatorNode, hardware: HardwareInterface) -> None:
        self.node = node
        self.hardware = hardware
        self.namespace = hardware.entity.namespace
        self.inbox = CommandInbox()
        self.update_rate = 0.0          # learned from the controller manager's commands
        self.holding = True             # no controller commands in effect
        ns = "/" + self.namespace
        self.state_pub = node.create_publisher(HardwareState, f"{ns}/hardware/state", express=True)
        self.humanoid_pub = node.create_publisher(HumanoidState, f"{ns}/humanoid_state")
        # inline: commands go straight into the inbox from Zenoh's thread; the physics thread picks them up
        self.command_sub = node.create_subscription(HardwareCommand, f"{ns}/hardware/command", self._on_command,
                                                    inline=True, raw=True)
        self.info_srv = node.create_service(GetHardwareInfo, f"{ns}/hardware/info", self._on_info)
        self._endpoints = [self.state_pub, self.humanoid_pub, self.command_sub, self.info_srv]

    def destroy(self) -> None:
        for endpoint in self._endpoints:
            try:
                self.node.destroy_entity(endpoint)
            except Exception:  # noqa: BLE001 - already gone
                pass

    def _on_command(self, payload: bytes) -> None:
        try:
            command = parse_command(payload)
        except CommandError as exc:
            self.node.logger.warn_throttle(1.0, f"{self.namespace}/hardware/command: dropped a malformed "
                                           f"message: {exc}", key=f"cmdparse:{self.namespace}")
            return
        self.inbox.put(command)

    # -- hardware frames --------------------------------------------------------------------------------
    def publish_state(self, step: int, sim_time: float) -> None:
        hw = self.hardware
        payload = msgpack.packb({
            "step": step, "stamp": time_map(sim_time), "name": hw.names,
            "position": hw.positions().tolist(), "velocity": hw.velocities().tolist(),
            "effort": hw.efforts().tolist(),
        }, use_bin_type=True)
        self.state_pub.publish_raw(payload)

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

    def hold(self, reason: str) -> None:
        if not self.holding:
            self.node.logger.warn(f"{self.namespace}: {reason}; holding position")
        self.hardware.hold_position()
        self.holding = True

    # -- outputs ----------------------------------------------------------------------------------------
    def publish_humanoid_state(self, sim_time: float) -> None:
        """humanoid_msgs/HumanoidState, packed directly (same map the codec would produce)."""
        hw = self.hardware
        balance = self.node.sim.balance(self.namespace)
        com = balance.center_of_mass
        self.humanoid_pub.publish_raw(msgpack.packb({
            "header": {"stamp": time_map(sim_time), "frame_id": "world"},
            "joint_names": hw.names,
            "joint_positions": hw.positions().tolist(),
            "joint_velocities": hw.velocities().tolist(),
            "joint_efforts": hw.efforts().tolist(),
            "center_of_mass": {"x": com[0], "y": com[1], "z": com[2]},
            "support_polygon": [{"x": x, "y": y, "z": z} for x, y, z in balance.support_polygon],
            "zmp_x": balance.zmp[0], "zmp_y": balance.zmp[1], "is_balanced": balance.is_balanced,
        }, use_bin_type=True))

    def _on_info(self, _request) -> object:
        return GetHardwareInfo.Response(
            robot_name=self.hardware.entity.name, mode=self.node.sim.mode,
            physics_rate=self.node.world.physics_rate,
            joints=[_HardwareJoint(**row) for row in self.hardware.joint_table()],
        )
