"""The controller manager's logic without Zenoh: load / configure / switch / unload controllers, claim
interfaces, run ``update`` of every active controller, collect the hardware command.

The Zenoh node (``nodes.control.node``) wraps this and serialises access with ``self.lock``: services run
on the executor thread, updates on the thread that delivers ``hardware/state``.
"""

from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from nodes.control.config import TYPE_NAME, ControllerConfig, ManagerConfig
from nodes.control.controller import (
    ACTIVE,
    INACTIVE,
    UNCONFIGURED,
    Controller,
    ControllerContext,
    ControllerLogger,
)
from nodes.control.controllers import controller_class
from nodes.control.interfaces import HardwareInterfaces, split_interface
from nodes.core.params import ParameterError

BEST_EFFORT = 1
STRICT = 2
MAX_CONFIGURED = 256   # controllers with a configuration (requests add them; each costs memory for good)


class ManagerError(RuntimeError):
    """A request the manager declines; the message is the reason given to the caller."""


@dataclass
class ControllerEntry:
    name: str
    type_name: str
    controller: Controller
    context: ControllerContext
    claimed: list[str] = field(default_factory=list)
    last_error: str = ""

    @property
    def state(self) -> str:
        return self.controller.state


class ControllerManager:
    def __init__(self, hardware: HardwareInterfaces, config: ManagerConfig, update_rate: int,
                 make_context: Callable[[str], ControllerContext], logger: ControllerLogger) -> None:
        self.hardware = hardware
        self.config = config
        self.update_rate = update_rate
        self.make_context = make_context
        self.logger = logger
        self.lock = threading.RLock()
        self.controllers: dict[str, ControllerEntry] = {}  # load order = update order
        self.claims: dict[str, str] = {}  # command interface -> controller name
        self._active: list[ControllerEntry] = []
        self._claimed_slots: list[tuple[str, str, Any]] = []
        self._claimed_names: list[str] = []
        self._last_update: float | None = None  # sim time of the last update()
        self._last_tick: float | None = None  # sim time of the last hardware state
        self._claimed_kinds: list[str] = []
        # Called (under the lock) after the controller set or a state changed: the node persists it so a
        # respawned manager restores it (nodes.control.restore).
        self.on_change: Callable[[], None] | None = None

    def _changed(self) -> None:
        if self.on_change is not None:
            try:
                self.on_change()
            except Exception as exc:  # noqa: BLE001 - persisting must never break a switch
                self.logger.warn(f"could not save the controller state: {exc}")

    # --- lifecycle --------------------------------------------------------------------------------
    def set_controller_params(self, name: str, params: dict[str, Any]) -> None:
        """Parameters (and optionally ``type``) for a controller not loaded yet (spawner --param-file)."""
        with self.lock:
            params = dict(params)
            type_name = params.pop("type", None)
            if type_name is not None and (not isinstance(type_name, str) or not TYPE_NAME.fullmatch(type_name)):
                raise ManagerError(f"controller '{name}': type must be 'package/Class', got {type_name!r:.200}")
            if name not in self.config.controllers and len(self.config.controllers) >= MAX_CONFIGURED:
                raise ManagerError(f"controller '{name}': {MAX_CONFIGURED} controllers are configured already "
                                   "(the limit)")
            cfg = self.config.controllers.setdefault(name, ControllerConfig(name))
            if type_name is not None:
                cfg.type = type_name
            cfg.params.update(params)
            self._changed()

    def load(self, name: str) -> ControllerEntry:
        with self.lock:
            if name in self.controllers:
                raise ManagerError(f"controller '{name}' is already loaded")
            cfg = self.config.controllers.get(name)
            if cfg is None or not cfg.type:
                raise ManagerError(f"controller '{name}' has no type: add '{name}: type: <package/Class>' "
                                   "under controller_manager ros__parameters")
            try:
                cls = controller_class(cfg.type)
            except KeyError as exc:
                raise ManagerError(str(exc.args[0])) from None
            context = self.make_context(name)
            controller = cls(name, context)
            controller.update_rate = float(self.update_rate)
            try:
                params = {**{k: v for k, v in self.config.shared_params.items() if k != "use_sim_time"},
                          **cfg.params}
                controller.load_parameters(params)
                controller.on_init()
            except (ParameterError, ValueError) as exc:
                context.destroy_all()
                raise ManagerError(f"controller '{name}' failed to initialise: {exc}") from None
            entry = ControllerEntry(name, cfg.type, controller, context)
            self.controllers[name] = entry
            self.logger.info(f"loaded controller '{name}' ({cfg.type})")
            self._changed()
            return entry

    def configure(self, name: str) -> None:
        with self.lock:
            entry = self._get(name)
            controller = entry.controller
            if entry.state == ACTIVE:
                raise ManagerError(f"controller '{name}' is active: deactivate it before configuring")
            if entry.state == INACTIVE:  # reconfigure, as ros2_control does: cleanup first
                self._cleanup(entry)
            controller.hardware_joints = list(self.hardware.joint_names)  # type: ignore[attr-defined]
            controller.hardware_sensors = dict(self.hardware.sensors)  # type: ignore[attr-defined]
            controller.joint_info = dict(self.hardware.joints)  # limits, as the hardware describes them
            try:
                controller.on_configure()
                missing = [n for n in controller.command_interface_configuration()
                           if n not in self.hardware.command_interface_names]
                missing += [n for n in controller.state_interface_configuration()
                            if n not in self.hardware.state_interface_names]
                if missing:
                    raise ManagerError(f"the hardware has no interface(s) {missing}")
            except Exception as exc:  # a failing configure leaves the controller unconfigured
                entry.context.destroy_all()
                entry.last_error = f"{type(exc).__name__}: {exc}" if not isinstance(exc, ManagerError) else str(exc)
                raise ManagerError(f"controller '{name}' failed to configure: {exc}") from None
            controller.state = INACTIVE
            entry.last_error = ""
            self.logger.info(f"configured controller '{name}'")
            self._changed()

    def unload(self, name: str) -> None:
        with self.lock:
            entry = self._get(name)
            if entry.state == ACTIVE:
                raise ManagerError(f"controller '{name}' is active: deactivate it before unloading")
            if entry.state == INACTIVE:
                self._cleanup(entry)
            entry.context.destroy_all()
            del self.controllers[name]
            self.logger.info(f"unloaded controller '{name}'")
            self._changed()

    def switch(self, activate: list[str], deactivate: list[str], strictness: int = STRICT) -> tuple[bool, str]:
        """Deactivate then activate controllers atomically between two updates.

        STRICT: any problem refuses the whole switch. BEST_EFFORT: problem controllers are skipped (the
        reasons are returned and ``ok`` is false if a requested activation was refused)."""
        strict = strictness == STRICT
        with self.lock:
            problems: list[str] = []
            to_deactivate: list[ControllerEntry] = []
            to_activate: list[ControllerEntry] = []
            for name in deactivate:
                entry = self.controllers.get(name)
                if entry is None:
                    problems.append(f"cannot deactivate '{name}': not loaded")
                elif entry.state != ACTIVE:
                    problems.append(f"cannot deactivate '{name}': it is {entry.state}")
                else:
                    to_deactivate.append(entry)
            for name in activate:
                entry = self.controllers.get(name)
                if entry is None:
                    problems.append(f"cannot activate '{name}': not loaded")
                elif entry.state == ACTIVE and name not in deactivate:
                    problems.append(f"cannot activate '{name}': it is already active")
                elif entry.state == UNCONFIGURED:
                    problems.append(f"cannot activate '{name}': it is unconfigured (configure it first)")
                else:
                    to_activate.append(entry)
            if problems and strict:
                return False, "; ".join(problems)
            # Interface claims after the deactivations, then each activation in order.
            leaving = {e.name for e in to_deactivate}
            claims = {iface: owner for iface, owner in self.claims.items() if owner not in leaving}
            accepted: list[ControllerEntry] = []
            refused = False
            for entry in to_activate:
                wanted = entry.controller.command_interface_configuration()
                conflicts = [f"{iface} (claimed by '{claims[iface]}')" for iface in wanted if iface in claims]
                # One joint takes one controller's commands (the hardware's mode-switch check in
                # ros2_control): a velocity controller on a joint a position controller drives is refused.
                joint_owner = {split_interface(iface)[0]: (iface, owner) for iface, owner in claims.items()}
                for iface in wanted:
                    joint = split_interface(iface)[0]
                    held, owner = joint_owner.get(joint, (iface, entry.name))
                    if iface not in claims and owner != entry.name:
                        conflicts.append(f"{iface} (joint '{joint}' is commanded through {held} by '{owner}')")
                if len(set(wanted)) != len(wanted):
                    conflicts.append("the controller claims an interface twice")
                if conflicts:
                    problems.append(f"cannot activate '{entry.name}': interface conflict: {', '.join(conflicts)}")
                    refused = True
                    continue
                for iface in wanted:
                    claims[iface] = entry.name
                accepted.append(entry)
            if refused and strict:
                return False, "; ".join(problems)
            for entry in to_deactivate:
                self._deactivate(entry)
            activated: list[str] = []
            for entry in accepted:
                try:
                    self._activate(entry)
                    activated.append(entry.name)
                except Exception as exc:  # noqa: BLE001 - reported to the caller
                    problems.append(f"'{entry.name}' failed to activate: {exc}")
                    refused = True
            self._rebuild_active()
            message = "; ".join(problems) if problems else "ok"
            for problem in problems:
                self.logger.warn(f"switch_controller: {problem}")
            if activated or to_deactivate:
                self.logger.info(f"switched controllers: activated {activated}, deactivated "
                                 f"{[e.name for e in to_deactivate]}")
                self._changed()
            return not refused, message

    def restart_active(self, reason: str) -> None:
        """Deactivate and re-activate every active controller (claims kept): after the hardware was
        replaced or reset, they re-read the joints and hold where they are instead of replaying old goals."""
        with self.lock:
            for entry in list(self._active):
                self._deactivate(entry)
                try:
                    self._activate(entry)
                except Exception as exc:  # noqa: BLE001 - it stays inactive, the others go on
                    entry.last_error = f"re-activation failed: {exc}"
                    self.logger.error(f"controller '{entry.name}' {entry.last_error}")
            self._rebuild_active()
            self.logger.info(f"controllers restarted ({reason}): {[e.name for e in self._active]}")
            self._changed()

    def _activate(self, entry: ControllerEntry) -> None:
        controller = entry.controller
        commands = controller.command_interface_configuration()
        states = controller.state_interface_configuration()
        controller.command_interfaces = [self.hardware.loan_command(n) for n in commands]
        controller.state_interfaces = [self.hardware.loan_state(n) for n in states]
        try:
            controller.on_activate()
        except Exception:
            controller.command_interfaces, controller.state_interfaces = [], []
            raise
        for iface in commands:
            self.claims[iface] = entry.name
        entry.claimed = list(commands)
        controller.state = ACTIVE
        entry.last_error = ""

    def _deactivate(self, entry: ControllerEntry) -> None:
        controller = entry.controller
        try:
            controller.on_deactivate()
        except Exception as exc:  # noqa: BLE001 - the loans are returned anyway
            self.logger.error(f"controller '{entry.name}' on_deactivate failed: {exc}")
        for iface in entry.claimed:
            if self.claims.get(iface) == entry.name:
                del self.claims[iface]
        entry.claimed = []
        controller.command_interfaces, controller.state_interfaces = [], []
        controller.state = INACTIVE

    def _cleanup(self, entry: ControllerEntry) -> None:
        try:
            entry.controller.on_cleanup()
        except Exception as exc:  # noqa: BLE001
            self.logger.error(f"controller '{entry.name}' on_cleanup failed: {exc}")
        entry.context.destroy_all()
        entry.controller.state = UNCONFIGURED

    def _rebuild_active(self) -> None:
        self._active = [e for e in self.controllers.values() if e.state == ACTIVE]
        slots = []
        for iface in self.claims:
            joint, kind = split_interface(iface)
            slots.append((joint, kind, self.hardware.command_slot(iface)))
        self._claimed_slots = slots
        self._claimed_names = [joint for joint, _, _ in slots]
        self._claimed_kinds = [kind for _, kind, _ in slots]

    def _get(self, name: str) -> ControllerEntry:
        entry = self.controllers.get(name)
        if entry is None:
            raise ManagerError(f"controller '{name}' is not loaded")
        return entry

    # --- real-time loop -----------------------------------------------------------------------------
    def reset_clock(self) -> None:
        self._last_update = None
        self._last_tick = None

    def tick(self, time: float) -> bool:
        """Called for every hardware state (sim ``time``): runs ``update`` when a control period is due.

        The simulator may step faster than this manager's ``update_rate`` (another robot's manager asked
        for more); in between, the previous commands are sent again. An update is due once the time since
        the last one, plus half a state interval, reaches the period, so a state rate that does not divide
        the update rate evenly does not halve it. Returns whether ``update`` ran."""
        with self.lock:
            last, previous_tick = self._last_update, self._last_tick
            self._last_tick = time
            control_period = 1.0 / self.update_rate
            if last is None or time < last:
                period = control_period
            else:
                period = time - last
                half_interval = 0.5 * (time - previous_tick) if previous_tick is not None else 0.0
                if period + half_interval < control_period - 1e-9:
                    return False
            self._last_update = time
            self.update(time, period)
            return True

    def update(self, time: float, period: float) -> None:
        """One control cycle: every active controller's ``update``; a raising controller is deactivated."""
        with self.lock:
            failed = None
            for entry in self._active:
                try:
                    entry.controller.update(time, period)
                except Exception as exc:  # noqa: BLE001 - one bad controller must not stop the others
                    tb = traceback.extract_tb(exc.__traceback__)
                    where = f" at {tb[-1].filename}:{tb[-1].lineno}" if tb else ""
                    entry.last_error = f"update raised {type(exc).__name__}: {exc}{where}"
                    self.logger.error(f"controller '{entry.name}' deactivated: {entry.last_error}")
                    failed = failed or []
                    failed.append(entry)
            if failed:
                for entry in failed:
                    self._deactivate(entry)
                self._rebuild_active()
                self._changed()

    def command(self) -> tuple[list[str], list[str], list[float]]:
        """Finite values of claimed command interfaces, for ``hardware/command``."""
        values = [slot.value for _, _, slot in self._claimed_slots]
        if all(v == v for v in values):  # the usual case: every claimed interface commanded
            return self._claimed_names, self._claimed_kinds, values
        keep = [i for i, v in enumerate(values) if v == v]  # NaN: not commanded yet, leave it out
        return ([self._claimed_names[i] for i in keep], [self._claimed_kinds[i] for i in keep],
                [values[i] for i in keep])

    # --- introspection ------------------------------------------------------------------------------
    def list_controllers(self) -> list[dict[str, Any]]:
        with self.lock:
            out = []
            for entry in self.controllers.values():
                c = entry.controller
                configured = entry.state != UNCONFIGURED
                out.append({
                    "name": entry.name, "state": entry.state, "type": entry.type_name,
                    "claimed_interfaces": list(entry.claimed),
                    "required_command_interfaces": c.command_interface_configuration() if configured else [],
                    "required_state_interfaces": c.state_interface_configuration() if configured else [],
                    "last_error": entry.last_error,
                })
            return out

    def list_interfaces(self) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
        with self.lock:
            commands = [{"name": n, "is_available": True, "is_claimed": n in self.claims}
                        for n in self.hardware.command_interface_names]
            states = [{"name": n, "is_available": True, "is_claimed": False}
                      for n in self.hardware.state_interface_names]
            return commands, states
