"""One PID loop (control_toolbox's ``Pid``): integral clamping, output clamping and anti-windup; and the gains
every controller with PIDs declares per joint (``gains.<joint>.p`` ...). Shared by the PID controller and the
trajectory controller's closed-loop adapter."""

from __future__ import annotations

from dataclasses import dataclass

from nodes.core.param_schema import param


@dataclass(frozen=True)
class Gains:
    """``gains.<joint>.*`` as control_toolbox declares them; controllers extend it with their own fields."""

    p: float = param(0.0, min_value=0.0, description="proportional gain")
    i: float = param(0.0, min_value=0.0, description="integral gain")
    d: float = param(0.0, min_value=0.0, description="derivative gain (on the velocity error)")
    i_clamp: float = param(0.0, min_value=0.0, description="symmetric integral limit (0: none)")

    @property
    def all_zero(self) -> bool:
        return self.p == 0.0 and self.i == 0.0 and self.d == 0.0


class Pid:
    """Derivative on the error rate the caller passes (the measured velocity: no kick when the reference steps)."""

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
