"""Loaned hardware interfaces: the only way controllers see joints (ros2_control's resource manager).

The controller manager owns one value slot per ``joint/interface``. A controller gets *loans* for the
interfaces it declared; a state loan can only be read, a command loan read and written. Two active
controllers never hold a loan on the same command interface, nor on two command interfaces of one
joint (the manager refuses the switch, naming the owner).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

STATE_KINDS = ("position", "velocity", "effort")
COMMAND_KINDS = ("position", "velocity", "effort")


def interface_name(joint: str, kind: str) -> str:
    return f"{joint}/{kind}"


def split_interface(name: str) -> tuple[str, str]:
    """``"left_knee/position"`` -> ``("left_knee", "position")``; raises ValueError otherwise."""
    joint, sep, kind = name.rpartition("/")
    if not sep or not joint or not kind:
        raise ValueError(f"interface '{name}' is not of the form joint/interface")
    return joint, kind


@dataclass
class JointInfo:
    """One joint of the hardware: its interfaces and limits (on the wire: zenroid_msgs/HardwareJoint).

    The simulator fills it from the URDF (``<limit>``) and ``<ros2_control>`` (interfaces, min/max params),
    the controller manager from the simulator's ``hardware/info``. ``inf`` means "no limit".
    """

    name: str
    command_interfaces: list[str] = field(default_factory=lambda: ["position"])
    state_interfaces: list[str] = field(default_factory=lambda: list(STATE_KINDS))
    min_position: float = -math.inf
    max_position: float = math.inf
    max_velocity: float = math.inf
    max_effort: float = math.inf
    type: str = ""  # the URDF joint type ("revolute", "continuous", "prismatic") where known
    # <ros2_control> min/max params per command interface, on top of the limits above
    command_bounds: dict[str, tuple[float, float]] = field(default_factory=dict)

    def bounds(self, interface: str) -> tuple[float, float]:
        """The admissible range of a command on ``interface`` (the joint's limit ∩ ros2_control min/max)."""
        if interface == "position":
            lo, hi = self.min_position, self.max_position
        elif interface == "velocity":
            lo, hi = -self.max_velocity, self.max_velocity
        else:
            lo, hi = -self.max_effort, self.max_effort
        extra = self.command_bounds.get(interface)
        if extra:
            lo, hi = max(lo, extra[0]), min(hi, extra[1])
        return lo, hi


@dataclass
class SensorInfo:
    """One sensor as the hardware describes it (zenroid_msgs/HardwareSensor): its state interfaces
    (``imu_sensor/orientation.x``...), whose values come in every state frame's ``sensor_values``."""

    name: str
    type: str = ""
    frame_id: str = ""
    state_interfaces: list[str] = field(default_factory=list)


class _Slot:
    """A single float shared between the manager and a loan (a plain attribute: cheap at 1 kHz)."""

    __slots__ = ("value",)

    def __init__(self) -> None:
        self.value = math.nan


class LoanedStateInterface:
    __slots__ = ("name", "joint", "kind", "_slot")

    def __init__(self, name: str, slot: _Slot) -> None:
        self.name = name
        self.joint, self.kind = split_interface(name)
        self._slot = slot

    def get_value(self) -> float:
        return self._slot.value


class LoanedCommandInterface(LoanedStateInterface):
    __slots__ = ()

    def set_value(self, value: float) -> None:
        self._slot.value = float(value)


def read_values(loans: list[LoanedStateInterface]) -> list[float]:
    """Values of many loans at once (the per-cycle hot path: no method call per joint)."""
    return [loan._slot.value for loan in loans]


def write_values(loans: list[LoanedCommandInterface], values: list[float]) -> None:
    """Set many command loans at once; ``values`` must be plain floats (e.g. ``array.tolist()``)."""
    if len(values) != len(loans):
        raise ValueError(f"{len(values)} values for {len(loans)} command interfaces")
    for loan, value in zip(loans, values, strict=True):
        loan._slot.value = value


class HardwareInterfaces:
    """All state and command slots of one robot, filled from ``hardware/state`` frames.

    Every joint gets position/velocity/effort state interfaces (the state frame carries all three) and
    the command interfaces the hardware declares; every sensor its declared state interfaces
    (``<sensor>/<interface>``, as ros2_control names them), filled from the frame's ``sensor_values``. Command slots start as NaN: "no command", which the
    manager leaves out of ``hardware/command`` so the simulator keeps its previous one.
    """

    def __init__(self, joints: list[JointInfo], sensors: list[SensorInfo] | tuple[SensorInfo, ...] = ()) -> None:
        self.joints: dict[str, JointInfo] = {j.name: j for j in joints}
        self.sensors: dict[str, SensorInfo] = {s.name: s for s in sensors}
        self.joint_names = [j.name for j in joints]
        self._state: dict[str, _Slot] = {}
        self._command: dict[str, _Slot] = {}
        for joint in joints:
            for kind in STATE_KINDS:
                self._state[interface_name(joint.name, kind)] = _Slot()
            for kind in joint.command_interfaces:
                if kind not in COMMAND_KINDS:
                    raise ValueError(f"joint '{joint.name}': unknown command interface '{kind}'")
                self._command[interface_name(joint.name, kind)] = _Slot()
        # Sensor slots in frame order (the hardware's sensor list), so reading a frame is one pass.
        self._sensor_slots: list[_Slot] = []
        for sensor in sensors:
            for kind in sensor.state_interfaces:
                slot = _Slot()
                self._state[interface_name(sensor.name, kind)] = slot
                self._sensor_slots.append(slot)
        # Per-joint slot triples in frame order, rebuilt when the frame's name list changes.
        self._frame_names: list[str] | None = None
        self._frame_slots: list[tuple[_Slot, _Slot, _Slot] | None] = []
        # Command slots in a fixed order so building hardware/command is one pass.
        self._command_items = [(split_interface(n), s) for n, s in self._command.items()]
        self.has_state = False

    @property
    def state_interface_names(self) -> list[str]:
        return list(self._state)

    @property
    def command_interface_names(self) -> list[str]:
        return list(self._command)

    def loan_state(self, name: str) -> LoanedStateInterface:
        slot = self._state.get(name)
        if slot is None:
            raise KeyError(f"state interface '{name}' does not exist")
        return LoanedStateInterface(name, slot)

    def loan_command(self, name: str) -> LoanedCommandInterface:
        slot = self._command.get(name)
        if slot is None:
            raise KeyError(f"command interface '{name}' does not exist")
        return LoanedCommandInterface(name, slot)

    def command_slot(self, name: str) -> _Slot:
        """The slot behind a command interface (the manager reads claimed ones in one pass per cycle)."""
        return self._command[name]

    def read_state(self, names: list[str], position: list[float], velocity: list[float],
                   effort: list[float], sensor_values: list[float] = ()) -> None:
        """Copy one ``hardware/state`` frame into the state slots (unknown joints are ignored; sensor values
        beyond the declared interfaces too, missing ones read NaN)."""
        if names != self._frame_names:
            self._frame_names = list(names)
            self._frame_slots = []
            for joint in names:
                if joint in self.joints:
                    self._frame_slots.append(tuple(self._state[interface_name(joint, k)] for k in STATE_KINDS))
                else:
                    self._frame_slots.append(None)
        n_pos, n_vel, n_eff = len(position), len(velocity), len(effort)
        for i, slots in enumerate(self._frame_slots):
            if slots is None:
                continue
            slots[0].value = position[i] if i < n_pos else math.nan
            slots[1].value = velocity[i] if i < n_vel else 0.0
            slots[2].value = effort[i] if i < n_eff else 0.0
        sensor_slots = self._sensor_slots
        if sensor_slots:
            if len(sensor_values) == len(sensor_slots):
                for slot, value in zip(sensor_slots, sensor_values, strict=True):
                    slot.value = value
            else:
                for i, slot in enumerate(sensor_slots):
                    slot.value = sensor_values[i] if i < len(sensor_values) else math.nan
        self.has_state = True

    def commands(self, only: set[str] | None = None) -> tuple[list[str], list[str], list[float]]:
        """The finite command values as ``(name[], interface[], value[])`` for ``hardware/command``.

        ``only`` restricts the output to claimed interfaces (an unclaimed slot keeps a stale value)."""
        names: list[str] = []
        kinds: list[str] = []
        values: list[float] = []
        for (joint, kind), slot in self._command_items:
            value = slot.value
            if value == value and (only is None or f"{joint}/{kind}" in only):  # NaN != NaN: no command
                names.append(joint)
                kinds.append(kind)
                values.append(value)
        return names, kinds, values
