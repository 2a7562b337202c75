"""The controller plug-ins, by their ros2_controllers type names (``<package>/<Class>``)."""

from __future__ import annotations

from nodes.control.controller import Controller
from nodes.control.controllers.forward_command_controller import (
    ForwardCommandController,
    JointGroupEffortController,
    JointGroupPositionController,
    JointGroupVelocityController,
)
from nodes.control.controllers.joint_state_broadcaster import JointStateBroadcaster
from nodes.control.controllers.joint_trajectory_controller import JointTrajectoryController
from nodes.control.controllers.pid_controller import PidController

CONTROLLER_TYPES: dict[str, type[Controller]] = {
    cls.type_name: cls
    for cls in (JointStateBroadcaster, JointTrajectoryController, ForwardCommandController,
                JointGroupPositionController, JointGroupVelocityController, JointGroupEffortController,
                PidController)
}


def controller_class(type_name: str) -> type[Controller]:
    cls = CONTROLLER_TYPES.get(type_name)
    if cls is None:
        raise KeyError(f"unknown controller type '{type_name}' (known: {', '.join(sorted(CONTROLLER_TYPES))})")
    return cls
