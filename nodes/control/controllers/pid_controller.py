"""pid_controller/PidController: per-joint PID from a position reference to an effort (or velocity)
command, with integral clamping and anti-windup — the controller lab's PID exercise, on many joints.

Reference: ``<ns>/<name>/reference`` (std_msgs/Float64MultiArray, one position per joint). Until one
arrives the joints hold the position they had on activation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from nodes.control.controller import Controller, ControllerError
from nodes.control.pid import Gains, Pid
from nodes.core.param_schema import param, per_key


@dataclass(frozen=True)
class PidGains(Gains):
    """``gains.<joint>.*``, as control_toolbox's PID parameters."""

    i_clamp_max: float | None = param(None, allow_infinite=True,
                                      description="upper integral limit (default: i_clamp, else none)")
    i_clamp_min: float | None = param(None, allow_infinite=True,
                                      description="lower integral limit (default: -i_clamp, else none)")
    u_clamp_max: float = param(math.inf, allow_infinite=True, description="upper output limit")
    u_clamp_min: float = param(-math.inf, allow_infinite=True, description="lower output limit")
    antiwindup: bool = param(True, description="stop integrating while the output is saturated")

    def pid(self) -> Pid:
        symmetric = self.i_clamp if self.i_clamp > 0 else math.inf
        i_max = self.i_clamp_max if self.i_clamp_max is not None else symmetric
        i_min = self.i_clamp_min if self.i_clamp_min is not None else -symmetric
        return Pid(self.p, self.i, self.d, i_min, i_max, self.u_clamp_min, self.u_clamp_max, self.antiwindup)


@dataclass(frozen=True)
class PidParameters:
    joints: list[str] = param([], description="controlled joints")
    dof_names: list[str] = param([], description="ros2_controllers' name for 'joints' (used when 'joints' is empty)")
    command_interface: str = param("effort", choices=("effort", "velocity"), description="what the PID commands")
    reference_and_state_interfaces: list[str] = param(
        ["position"], choices=("position",), description="the reference is a position (the only kind here)")
    gains: dict[str, PidGains] = per_key(PidGains, keys=("joints", "dof_names"))


class PidController(Controller):
    type_name = "pid_controller/PidController"
    Params = PidParameters
    params: PidParameters

    def on_configure(self) -> None:
        joints = self.take_joints(list(self.params.joints) or list(self.params.dof_names))
        self.command_kind = self.params.command_interface
        self.pids: list[Pid] = []
        for joint in joints:
            gains = self.params.gains[joint]
            pid = gains.pid()
            if pid.i_min > pid.i_max or pid.u_min > pid.u_max:
                raise ControllerError(f"gains.{joint}: a *_clamp_min is above its *_clamp_max")
            if gains.all_zero:
                raise ControllerError(f"gains.{joint}: p, i and d are all zero")
            self.pids.append(pid)
        self._reference: list[float] | None = None
        self.subscribe_joint_values("~/reference", "reference", self._on_reference)

    def command_interface_configuration(self) -> list[str]:
        return [f"{j}/{self.command_kind}" for j in self.joints]

    def state_interface_configuration(self) -> list[str]:
        return [f"{j}/{k}" for j in self.joints for k in ("position", "velocity")]

    def _on_reference(self, values: list[float]) -> None:
        self._reference = values

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
