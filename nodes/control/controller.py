"""The controller base class, in the shape of ros2_controllers' ``ControllerInterface``.

A controller declares its parameters once, as a schema dataclass in ``Params`` (``nodes.core.param_schema``:
types, defaults, bounds, descriptions, per-joint maps such as ``gains.<joint>.p``), and reads them typed from
``self.params``; it claims ``joint/interface`` names through
``command_interface_configuration()`` / ``state_interface_configuration()``, and is driven by the
manager through the lifecycle ``unconfigured -> inactive -> active``. ``update(time, period)`` runs on
sim time (seconds) and may only touch its loaned interfaces; topics, services and actions are created
through the small ``ControllerContext`` handle the manager passes in, never through Zenoh directly.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

from msgs.std_msgs import Float64MultiArray
from nodes.control.interfaces import JointInfo, LoanedCommandInterface, LoanedStateInterface
from nodes.core.param_schema import load_parameters

UNCONFIGURED = "unconfigured"
INACTIVE = "inactive"
ACTIVE = "active"
FINALIZED = "finalized"


class ControllerError(RuntimeError):
    """A lifecycle transition failed; the message says why."""


class ControllerLogger(Protocol):
    def debug(self, msg: str) -> None: ...
    def info(self, msg: str) -> None: ...
    def warn(self, msg: str) -> None: ...
    def error(self, msg: str) -> None: ...


class ControllerContext(Protocol):
    """What the manager lends a controller to talk to the outside world.

    Topic names are resolved like a node's: ``"~/x"`` -> ``<ns>/<controller>/x``, ``"x"`` -> ``<ns>/x``.
    Subscription, service and action callbacks may run on another thread than ``update``: hand data
    to ``update`` through a single attribute assignment (atomic under the GIL) or a lock."""

    logger: ControllerLogger

    def now(self) -> float: ...
    def create_publisher(self, msg_type: Any, topic: str) -> Any: ...
    def create_subscription(self, msg_type: Any, topic: str, callback: Any) -> Any: ...
    def create_service(self, srv_type: Any, name: str, handler: Any) -> Any: ...
    def create_action_server(self, action_type: Any, name: str, **callbacks: Any) -> Any: ...
    def destroy_all(self) -> None: ...


@dataclass(frozen=True)
class NoParameters:
    """The schema of a controller without parameters."""


class Controller:
    """Base class; subclasses set ``Params`` and override the ``on_*`` hooks, the interface configurations
    and ``update``."""

    #: ros2_controllers plugin name, e.g. ``"joint_trajectory_controller/JointTrajectoryController"``
    type_name = ""
    #: the parameter schema (a dataclass of ``param``/``namespace``/``per_key`` fields); ``self.params`` holds
    #: its values once the manager has called ``load_parameters``
    Params: ClassVar[type] = NoParameters

    def __init__(self, name: str, context: ControllerContext) -> None:
        self.name = name
        self.context = context
        self.logger = context.logger
        self.params: Any = self.Params()
        self.joints: list[str] = []     # the joints it controls, known from on_configure
        self.rejected_count = 0         # commands refused (wrong length, not finite, ...): for tests and the CLI
        self.state = UNCONFIGURED
        self.command_interfaces: list[LoanedCommandInterface] = []
        self.state_interfaces: list[LoanedStateInterface] = []
        self.update_rate = 0.0  # set by the manager before on_configure
        # The hardware's joints with their limits (URDF + <ros2_control>), set before on_configure.
        self.joint_info: dict[str, JointInfo] = {}

    # --- parameters -------------------------------------------------------------------------------
    def load_parameters(self, given: Mapping[str, Any]) -> None:
        """``self.params`` from the controller's YAML block (nested or dotted names); raises ParameterError
        naming the parameter. Names the schema does not declare are logged and ignored (typos)."""
        loaded = load_parameters(self.Params, given, ignore=("type",))
        self.params = loaded.values
        if loaded.unknown:
            self.logger.warn(f"{self.name}: ignoring unknown parameters {loaded.unknown}")

    # --- hooks (ros2_controllers names) -------------------------------------------------------------
    def on_init(self) -> None:
        """Called once after the parameters are loaded; most controllers need nothing here."""

    def on_configure(self) -> None:
        """Read and check parameters, create topics/services/actions. Raise to refuse."""

    def on_activate(self) -> None:
        """Loans are in ``command_interfaces`` / ``state_interfaces`` now; take hold of the joints."""

    def on_deactivate(self) -> None:
        """Loans are about to be returned."""

    def on_cleanup(self) -> None:
        """Undo ``on_configure``."""

    def command_interface_configuration(self) -> list[str]:
        return []

    def state_interface_configuration(self) -> list[str]:
        return []

    def update(self, time: float, period: float) -> None:
        raise NotImplementedError

    # --- helpers ----------------------------------------------------------------------------------
    def take_joints(self, joints: list[str]) -> list[str]:
        """Keep ``joints`` (from a parameter) as ``self.joints``; raises ControllerError when it is empty or
        names a joint twice."""
        if not joints:
            raise ControllerError("parameter 'joints' is empty")
        if len(set(joints)) != len(joints):
            raise ControllerError(f"parameter 'joints' lists a joint twice: {joints}")
        self.joints = list(joints)
        return self.joints

    def subscribe_joint_values(self, topic: str, what: str, keep: Callable[[list[float]], None]) -> None:
        """Subscribe to a std_msgs/Float64MultiArray ``topic`` with one value per joint: ``keep(values)`` gets
        every accepted message's values; refused ones are logged as ``what`` and counted."""
        self.rejected_count = 0

        def on_message(msg: Any) -> None:
            values = self.one_value_per_joint(msg.data, what)
            if values is not None:
                keep(values)

        self.context.create_subscription(Float64MultiArray, topic, on_message)

    def one_value_per_joint(self, data: Any, what: str) -> list[float] | None:
        """``data`` (a Float64MultiArray's) as one finite value per joint of ``self.joints``; None when it
        is refused (logged with the reason, counted in ``rejected_count``)."""
        values = list(data)
        joints = self.joints
        if len(values) != len(joints):
            problem = f"data has {len(values)} values, expected {len(joints)} (joints {joints})"
        else:
            bad = next((i for i, v in enumerate(values) if not math.isfinite(v)), None)
            problem = None if bad is None else f"data[{bad}] is not finite"
        if problem is None:
            return values
        self.rejected_count += 1
        self.logger.error(f"{self.name}: {what} rejected: {problem}")
        return None

    def loans_by_name(self) -> tuple[dict[str, LoanedCommandInterface], dict[str, LoanedStateInterface]]:
        return ({c.name: c for c in self.command_interfaces}, {s.name: s for s in self.state_interfaces})
