"""The controller plug-ins, by their ros2_controllers type names (``<package>/<Class>``)."""

from __future__ import annotations

import importlib

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
    """A built-in type by its ros2_controllers name, or a user controller as ``python.module:ClassName``
    (pluginlib's role: the module is imported, never evaluated, and must define a Controller subclass)."""
    cls = CONTROLLER_TYPES.get(type_name)
    if cls is not None:
        return cls
    module_name, sep, class_name = type_name.partition(":")
    if sep and module_name and class_name.isidentifier():
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:
            raise KeyError(f"controller type '{type_name}': cannot import '{module_name}': {exc}") from None
        cls = getattr(module, class_name, None)
        if isinstance(cls, type) and issubclass(cls, Controller):
            return cls
        raise KeyError(f"controller type '{type_name}': '{class_name}' is not a Controller subclass")
    raise KeyError(f"unknown controller type '{type_name}' (known: {', '.join(sorted(CONTROLLER_TYPES))}, "
                   "or module.path:ClassName)")
