"""In-process stand-ins for the manager's Zenoh side (a fake ``ControllerContext``, goal handle, a toy
plant) and a controller that crashes on purpose: the controller tests drive controllers without any network.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nodes.control.controller import Controller
from nodes.control.interfaces import HardwareInterfaces, JointInfo
from nodes.core.param_schema import param


class ListLogger:
    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def _log(self, level: str, msg: str) -> None:
        self.lines.append((level, msg))

    def debug(self, msg: str) -> None:
        self._log("debug", msg)

    def info(self, msg: str) -> None:
        self._log("info", msg)

    def warn(self, msg: str) -> None:
        self._log("warn", msg)

    def error(self, msg: str) -> None:
        self._log("error", msg)

    def warn_throttle(self, _period_s: float, msg: str, key: str | None = None) -> None:
        self._log("warn", msg)

    def text(self, level: str | None = None) -> str:
        return "\n".join(m for lvl, m in self.lines if level is None or lvl == level)


class FakePublisher:
    def __init__(self, topic: str, msg_type: Any = None) -> None:
        self.topic = topic
        self.msg_type = msg_type
        self.messages: list[Any] = []
        self.has_subscribers = True   # as the manager's publishers say (a test sets False: nobody listens)

    def publish(self, msg: Any) -> None:
        self.messages.append(msg)

    def publish_raw(self, payload: bytes) -> None:
        import msgs

        self.messages.append(msgs.decode(self.msg_type, payload))  # also proves the bytes decode as the type

    def publish_fields(self, **fields: Any) -> None:
        import msgs

        self.publish_raw(msgs.packer(self.msg_type._type)(**fields))


class FakeActionServer:
    def __init__(self, name: str, callbacks: dict[str, Any]) -> None:
        self.name = name
        self.callbacks = callbacks

    def send_goal(self, goal: Any) -> tuple[bool, str, FakeGoalHandle | None]:
        verdict = self.callbacks["goal_callback"](goal)
        accepted, reason = verdict if isinstance(verdict, tuple) else (bool(verdict), "")
        if not accepted:
            return False, reason, None
        handle = FakeGoalHandle(goal, self)
        self.callbacks["accepted_callback"](handle)
        return True, "", handle


class FakeGoalHandle:
    """Status codes as action_msgs/GoalStatus."""

    def __init__(self, goal: Any, server: FakeActionServer) -> None:
        self.goal = goal
        self.server = server
        self.status = 1
        self.result: Any = None
        self.feedback: list[Any] = []

    @property
    def is_active(self) -> bool:
        return self.status in (1, 2, 3)

    @property
    def is_cancel_requested(self) -> bool:
        return self.status == 3

    def cancel(self) -> None:
        if self.server.callbacks["cancel_callback"](self):
            self.status = 3

    def execute(self) -> None:
        self.status = 2

    def publish_feedback(self, fb: Any) -> None:
        self.feedback.append(fb)

    def _finish(self, status: int, result: Any) -> None:
        if self.is_active:
            self.status, self.result = status, result

    def succeed(self, result: Any = None) -> None:
        self._finish(4, result)

    def canceled(self, result: Any = None) -> None:
        self._finish(5, result)

    def abort(self, result: Any = None) -> None:
        self._finish(6, result)


class FakeContext:
    def __init__(self, name: str = "ctrl") -> None:
        self.name = name
        self.logger = ListLogger()
        self.time = 0.0
        self.publishers: dict[str, FakePublisher] = {}
        self.subscriptions: dict[str, Any] = {}
        self.services: dict[str, Any] = {}
        self.actions: dict[str, FakeActionServer] = {}
        self.destroyed = 0

    def _resolve(self, topic: str) -> str:
        return f"{self.name}/{topic[2:]}" if topic.startswith("~/") else topic

    def now(self) -> float:
        return self.time

    def create_publisher(self, msg_type: Any, topic: str) -> FakePublisher:
        pub = FakePublisher(self._resolve(topic), msg_type)
        self.publishers[pub.topic] = pub
        return pub

    def create_subscription(self, msg_type: Any, topic: str, callback: Any) -> Any:
        self.subscriptions[self._resolve(topic)] = callback
        return callback

    def create_service(self, srv_type: Any, name: str, handler: Any) -> Any:
        self.services[self._resolve(name)] = handler
        return handler

    def create_action_server(self, action_type: Any, name: str, **callbacks: Any) -> FakeActionServer:
        server = FakeActionServer(self._resolve(name), callbacks)
        self.actions[server.name] = server
        return server

    def destroy_all(self) -> None:
        self.destroyed += 1
        self.publishers.clear()
        self.subscriptions.clear()
        self.services.clear()
        self.actions.clear()


def make_hardware(joints: list[str], command_interfaces: tuple[str, ...] = ("position",),
                  limits: dict[str, dict[str, float]] | None = None) -> HardwareInterfaces:
    """Hardware with these joints; ``limits`` maps a joint to JointInfo fields (``max_velocity``...)."""
    limits = limits or {}
    return HardwareInterfaces([JointInfo(j, list(command_interfaces), **limits.get(j, {})) for j in joints])


class FirstOrderPlant:
    """A toy joint model for unit tests: position follows a position command with time constant ``tau``,
    integrates a velocity command, or accelerates under an effort command with inertia ``inertia``."""

    def __init__(self, hardware: HardwareInterfaces, tau: float = 0.02, inertia: float = 0.05) -> None:
        self.hw = hardware
        self.tau = tau
        self.inertia = inertia
        self.names = list(hardware.joint_names)
        self.pos = {j: 0.0 for j in self.names}
        self.vel = {j: 0.0 for j in self.names}

    def publish_state(self) -> None:
        self.hw.read_state(self.names, [self.pos[j] for j in self.names], [self.vel[j] for j in self.names],
                           [0.0] * len(self.names))

    def apply(self, names: list[str], kinds: list[str], values: list[float], dt: float) -> None:
        commanded = dict(zip(names, zip(kinds, values, strict=True), strict=True))
        for j in self.names:
            kind, value = commanded.get(j, ("hold", self.pos[j]))
            if kind in ("position", "hold"):
                new = self.pos[j] + (value - self.pos[j]) * min(1.0, dt / self.tau)
                self.vel[j] = (new - self.pos[j]) / dt
                self.pos[j] = new
            elif kind == "velocity":
                self.vel[j] = value
                self.pos[j] += value * dt
            else:
                self.vel[j] += value / self.inertia * dt
                self.pos[j] += self.vel[j] * dt


@dataclass(frozen=True)
class CrashingParameters:
    joints: list[str] = param([], description="joints it claims")
    crash_after: float = param(0.5, min_value=0.0, description="s of sim time before update raises")
    interface: str = param("velocity", choices=("position", "velocity", "effort"), description="claimed interface")


class CrashingController(Controller):
    """A controller whose ``update`` raises after ``crash_after`` s of sim time (type
    ``test_controllers/CrashingController``, registered with ``plugin_dir``): shows the manager deactivating
    it while others run."""

    type_name = "test_controllers/CrashingController"
    Params = CrashingParameters
    params: CrashingParameters

    def on_configure(self) -> None:
        self.joints = list(self.params.joints)
        self.crash_after = self.params.crash_after
        self.started: float | None = None

    def command_interface_configuration(self) -> list[str]:
        return [f"{j}/{self.params.interface}" for j in self.joints]

    def on_activate(self) -> None:
        self.started = None

    def update(self, time: float, period: float) -> None:
        if self.started is None:
            self.started = time
        if time - self.started > self.crash_after:
            raise RuntimeError(f"deliberate crash after {self.crash_after} s")
        # Claims its interfaces but writes nothing (NaN): the hardware keeps the other controllers' commands.


def plugin_dir(root: Path, controllers: dict[str, str]) -> Path:
    """A directory holding an installed-distribution record (``*.dist-info``) that registers ``controllers``
    (type name -> ``module:Class``) in the ``zenroid.controllers`` entry-point group, as ``pip install`` of a
    plug-in package would: put it on a controller manager's ``PYTHONPATH``."""
    info = root / "zenroid_test_controllers-0.0.dist-info"
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: zenroid-test-controllers\nVersion: 0.0\n")
    lines = ["[zenroid.controllers]", *(f"{name} = {target}" for name, target in controllers.items())]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")
    return root


@dataclass(frozen=True)
class HangingParameters:
    hang_after: float = param(0.5, min_value=0.0, description="s of sim time before update never returns")


class HangingController(Controller):
    """A controller whose ``update`` never returns after ``hang_after`` s of sim time (type
    ``test_controllers/HangingController``, registered with ``plugin_dir``): a control cycle that never ends."""

    type_name = "test_controllers/HangingController"
    Params = HangingParameters
    params: HangingParameters

    def on_activate(self) -> None:
        self.started: float | None = None

    def command_interface_configuration(self) -> list[str]:
        return []

    def update(self, time: float, period: float) -> None:
        if self.started is None:
            self.started = time
        if time - self.started > self.params.hang_after:
            threading.Event().wait()   # forever
