"""pid_controller/PidController: per-joint PID from a position reference to an effort (or velocity)
command, with integral clamping and anti-windup — the controller lab's PID exercise, on many joints.

Reference: ``<ns>/<name>/reference`` (std_msgs/Float64MultiArray, one position per joint). Until one
arrives the joints hold the position they had on activation.
"""

from __future__ import annotations

import math

from nodes.control.controller import Controller, ControllerError
from nodes.control.messages import msg_type


class Pid:
    """One PID loop. Derivative on the measured velocity (no kick when the reference steps)."""

    def __init__(self, p: float, i: float, d: float, i_min: float, i_max: float, u_min: float,
                 u_max: float, antiwindup: bool) -> None:
        self.p, self.i, self.d = p, i, d
        self.i_min, self.i_max = i_min, i_max
        self.u_min, self.u_max = u_min, u_max
        self.antiwindup = antiwindup
        self.i_term = 0.0

    def reset(self) -> None:
        self.i_term = 0.0

    def compute(self, error: float, error_rate: float, dt: float) -> float:
        unsaturated = self.p * error + self.i_term + self.d * error_rate
        saturated = min(max(unsaturated, self.u_min), self.u_max)
        # Anti-windup: stop integrating while the output is saturated in the direction of the error.
        winding = self.antiwindup and saturated != unsaturated and (unsaturated - saturated) * error > 0
        if dt > 0.0 and not winding:
            self.i_term = min(max(self.i_term + self.i * error * dt, self.i_min), self.i_max)
        return min(max(self.p * error + self.i_term + self.d * error_rate, self.u_min), self.u_max)


class PidController(Controller):
    type_name = "pid_controller/PidController"

    def on_init(self) -> None:
        self.declare_parameter("joints", [], type=list, element_type=str)
        self.declare_parameter("dof_names", [], type=list, element_type=str,
                               description="ros2_controllers' name for 'joints'")
        self.declare_parameter("command_interface", "effort", choices=("effort", "velocity"))
        self.declare_parameter("reference_and_state_interfaces", ["position"], element_type=str,
                               choices=("position", "velocity"))

    def on_configure(self) -> None:
        joints = list(self.get_parameter("joints")) or list(self.get_parameter("dof_names"))
        if not joints:
            raise ControllerError("parameter 'joints' is empty")
        if len(set(joints)) != len(joints):
            raise ControllerError(f"parameter 'joints' lists a joint twice: {joints}")
        self.joints = joints
        self.command_kind = self.get_parameter("command_interface")
        self.pids: list[Pid] = []
        for joint in joints:
            g = f"gains.{joint}."
            p = self.declare_parameter(g + "p", 0.0, min_value=0.0)
            i = self.declare_parameter(g + "i", 0.0, min_value=0.0)
            d = self.declare_parameter(g + "d", 0.0, min_value=0.0)
            i_clamp = self.declare_parameter(g + "i_clamp", 0.0, min_value=0.0,
                                             description="symmetric integral limit (0: none)")
            i_max = self.declare_parameter(g + "i_clamp_max", i_clamp if i_clamp > 0 else math.inf)
            i_min = self.declare_parameter(g + "i_clamp_min", -i_clamp if i_clamp > 0 else -math.inf)
            u_max = self.declare_parameter(g + "u_clamp_max", math.inf)
            u_min = self.declare_parameter(g + "u_clamp_min", -math.inf)
            antiwindup = self.declare_parameter(g + "antiwindup", True)
            self.declare_parameter(g + "feedforward_gain", 0.0)
            if i_min > i_max or u_min > u_max:
                raise ControllerError(f"gains.{joint}: a *_clamp_min is above its *_clamp_max")
            if p == 0.0 and i == 0.0 and d == 0.0:
                raise ControllerError(f"gains.{joint}: p, i and d are all zero")
            self.pids.append(Pid(p, i, d, i_min, i_max, u_min, u_max, antiwindup))
        unknown = self.params.undeclared()
        if unknown:
            self.logger.warn(f"{self.name}: ignoring unknown parameters {unknown}")
        self._reference: list[float] | None = None
        self.rejected_count = 0
        self.context.create_subscription(msg_type("std_msgs/msg/Float64MultiArray"), "~/reference",
                                         self._on_reference)

    def command_interface_configuration(self) -> list[str]:
        return [f"{j}/{self.command_kind}" for j in self.joints]

    def state_interface_configuration(self) -> list[str]:
        return [f"{j}/{k}" for j in self.joints for k in ("position", "velocity")]

    def _on_reference(self, msg) -> None:
        data = list(msg.data)
        if len(data) != len(self.joints):
            self.rejected_count += 1
            self.logger.error(f"{self.name}: reference rejected: data has {len(data)} values, expected "
                              f"{len(self.joints)} (joints {self.joints})")
            return
        if not all(math.isfinite(v) for v in data):
            self.rejected_count += 1
            self.logger.error(f"{self.name}: reference rejected: data holds a NaN or infinity")
            return
        self._reference = data

    def on_activate(self) -> None:
        _, state = self.loans_by_name()
        self._pos = [state[f"{j}/position"] for j in self.joints]
        self._vel = [state[f"{j}/velocity"] for j in self.joints]
        self._reference = None
        self._hold: list[float] | None = None
        for pid in self.pids:
            pid.reset()

    def update(self, time: float, period: float) -> None:
        reference = self._reference
        if reference is None:
            if self._hold is None:
                positions = [s.get_value() for s in self._pos]
                if not all(math.isfinite(v) for v in positions):
                    return
                self._hold = positions
            reference = self._hold
        for k, pid in enumerate(self.pids):
            error = reference[k] - self._pos[k].get_value()
            output = pid.compute(error, -self._vel[k].get_value(), period)
            self.command_interfaces[k].set_value(output)
