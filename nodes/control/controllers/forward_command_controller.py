"""forward_command_controller/ForwardCommandController and the joint-group position / velocity / effort
controllers: ``<ns>/<name>/commands`` (std_msgs/Float64MultiArray, one value per joint) written straight
to one command interface of each joint."""

from __future__ import annotations

from dataclasses import dataclass

from nodes.control.controller import Controller
from nodes.core.param_schema import param


@dataclass(frozen=True)
class JointGroupParameters:
    joints: list[str] = param([], description="commanded joints, in the order of the commands' data")


@dataclass(frozen=True)
class ForwardCommandParameters(JointGroupParameters):
    interface_name: str = param("", choices=("position", "velocity", "effort"),
                                description="the command interface every joint is commanded through")


class ForwardCommandController(Controller):
    type_name = "forward_command_controller/ForwardCommandController"
    Params = ForwardCommandParameters
    #: fixed interface of the joint-group variants; None: the ``interface_name`` parameter decides
    fixed_interface: str | None = None

    def on_configure(self) -> None:
        self.take_joints(list(self.params.joints))
        self.interface = self.fixed_interface or self.params.interface_name
        self._latest: list[float] | None = None
        self.subscribe_joint_values("~/commands", "command", self._on_commands)

    def command_interface_configuration(self) -> list[str]:
        return [f"{j}/{self.interface}" for j in self.joints]

    def _on_commands(self, values: list[float]) -> None:
        self._latest = values  # one assignment: atomic hand-over to update()

    def on_activate(self) -> None:
        self._latest = None  # commands sent while inactive are not replayed

    def update(self, time: float, period: float) -> None:
        latest = self._latest
        if latest is None:
            return  # nothing commanded yet: the hardware keeps its previous command
        for loan, value in zip(self.command_interfaces, latest, strict=True):
            loan.set_value(value)


class JointGroupPositionController(ForwardCommandController):
    type_name = "position_controllers/JointGroupPositionController"
    Params = JointGroupParameters
    fixed_interface = "position"


class JointGroupVelocityController(ForwardCommandController):
    type_name = "velocity_controllers/JointGroupVelocityController"
    Params = JointGroupParameters
    fixed_interface = "velocity"


class JointGroupEffortController(ForwardCommandController):
    type_name = "effort_controllers/JointGroupEffortController"
    Params = JointGroupParameters
    fixed_interface = "effort"
