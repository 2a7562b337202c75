"""The controller plug-ins, by their ros2_controllers type names (``<package>/<Class>``).

A controller type is looked up in a registry, never imported from a name a request carries (pluginlib's
role, without its ``dlopen`` of whatever is asked): the built-in controllers below, plus the controllers
other installed distributions declare in the ``zenroid.controllers`` entry-point group::

    [project.entry-points."zenroid.controllers"]
    "my_controllers/GraspController" = "my_package.grasp:GraspController"

Only an entry point whose *name* equals the requested type is loaded, so an unknown type (``os:system``,
``this:Nope``) imports nothing and is refused with the list of known types.
"""

from __future__ import annotations

from importlib import metadata

from nodes.control.config import TYPE_NAME
from nodes.control.controller import Controller
from nodes.control.controllers.force_torque_sensor_broadcaster import ForceTorqueSensorBroadcaster
from nodes.control.controllers.forward_command_controller import (
    ForwardCommandController,
    JointGroupEffortController,
    JointGroupPositionController,
    JointGroupVelocityController,
)
from nodes.control.controllers.imu_sensor_broadcaster import IMUSensorBroadcaster
from nodes.control.controllers.joint_state_broadcaster import JointStateBroadcaster
from nodes.control.controllers.joint_trajectory_controller import JointTrajectoryController
from nodes.control.controllers.pid_controller import PidController

ENTRY_POINT_GROUP = "zenroid.controllers"
_MAX_SHOWN = 200  # characters of a refused type name quoted back

CONTROLLER_TYPES: dict[str, type[Controller]] = {
    cls.type_name: cls
    for cls in (JointStateBroadcaster, JointTrajectoryController, ForwardCommandController,
                JointGroupPositionController, JointGroupVelocityController, JointGroupEffortController,
                PidController, IMUSensorBroadcaster, ForceTorqueSensorBroadcaster)
}


def _entry_points() -> list[metadata.EntryPoint]:
    return list(metadata.entry_points(group=ENTRY_POINT_GROUP))


def known_types() -> list[str]:
    """Every type name a ``load_controller`` may ask for (built-in and installed plug-ins)."""
    return sorted(set(CONTROLLER_TYPES) | {ep.name for ep in _entry_points()})


def _shown(type_name: str) -> str:
    text = type_name if len(type_name) <= _MAX_SHOWN else f"{type_name[:_MAX_SHOWN]}… ({len(type_name)} characters)"
    return repr(text)


def controller_class(type_name: str) -> type[Controller]:
    """The registered controller class of ``type_name``; KeyError naming the known types otherwise."""
    cls = CONTROLLER_TYPES.get(type_name)
    if cls is not None:
        return cls
    if not isinstance(type_name, str) or not TYPE_NAME.fullmatch(type_name):
        raise KeyError(f"controller type {_shown(str(type_name))} is not of the form 'package/Class' "
                       f"(known: {', '.join(known_types())})")
    for ep in _entry_points():
        if ep.name != type_name:
            continue
        try:
            cls = ep.load()   # the module the installed distribution declared, never one named by the request
        except Exception as exc:  # noqa: BLE001 - a broken plug-in is refused, the manager lives on
            raise KeyError(f"controller type '{type_name}': its plug-in {ep.value!r} failed to load: "
                           f"{type(exc).__name__}: {exc}") from None
        if isinstance(cls, type) and issubclass(cls, Controller):
            return cls
        raise KeyError(f"controller type '{type_name}': entry point {ep.value!r} is not a Controller subclass")
    raise KeyError(f"unknown controller type '{type_name}' (known: {', '.join(known_types())}; plug-ins "
                   f"register more in the '{ENTRY_POINT_GROUP}' entry-point group)")
