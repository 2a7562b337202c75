"""``zenroid control``: talk to the controller manager (``ros2 control`` verbs) and the spawner.

    zenroid control list_controllers [--ns humanoid]
    zenroid control list_hardware_interfaces
    zenroid control load_controller NAME [--set-state inactive|active]
    zenroid control set_controller_state NAME inactive|active
    zenroid control switch_controllers --activate A ... --deactivate B ... [--strict]
    zenroid control unload_controller NAME
    zenroid control spawner NAME ... [--inactive | --load-only] [--param-file F] [-t TYPE]
                                     [--controller-manager-timeout S]

Exit status: 0 done, 1 the manager declined or could not be reached, 2 bad input.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Any

import yaml

import msgs
from nodes.core import ServiceError
from nodes.core.endpoints import Client
from nodes.tools.cli import UsageError
from nodes.tools.common import ROUTER_WAIT, add_common, cli_node, snapshot

_SRV = {
    "list_controllers": "controller_manager_msgs/srv/ListControllers",
    "list_hardware_interfaces": "controller_manager_msgs/srv/ListHardwareInterfaces",
    "load_controller": "controller_manager_msgs/srv/LoadController",
    "configure_controller": "controller_manager_msgs/srv/ConfigureController",
    "switch_controller": "controller_manager_msgs/srv/SwitchController",
    "unload_controller": "controller_manager_msgs/srv/UnloadController",
    "set_controller_parameters": "zenroid_msgs/srv/SetParameters",
}
STRICT, BEST_EFFORT = 2, 1


class Failed(Exception):
    """The manager declined or is unreachable: printed, exit status 1."""


def _manager_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--ns", "--namespace", dest="namespace", default=os.environ.get("ZENROID_NS", "humanoid"),
                   help="robot namespace (default: $ZENROID_NS or humanoid)")
    p.add_argument("-c", "--controller-manager", default="controller_manager", help="controller manager node name")
    p.add_argument("--timeout", type=float, default=5.0, help="service call timeout (s)")
    add_common(p)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list_controllers", help="loaded controllers, their type, state and claimed interfaces")
    p.add_argument("-v", "--verbose", action="store_true", help="also required interfaces")
    _manager_args(p)
    p = sub.add_parser("list_hardware_interfaces", help="command and state interfaces, claimed or not")
    _manager_args(p)
    p = sub.add_parser("load_controller", help="load a controller named in the manager's YAML")
    p.add_argument("name")
    p.add_argument("--set-state", choices=["inactive", "active"], help="then configure (and activate) it")
    _manager_args(p)
    p = sub.add_parser("set_controller_state", help="configure / activate / deactivate a loaded controller")
    p.add_argument("name")
    p.add_argument("state", help="inactive or active")
    _manager_args(p)
    p = sub.add_parser("switch_controllers", help="activate and deactivate controllers in one switch")
    p.add_argument("--activate", nargs="*", default=[], metavar="NAME")
    p.add_argument("--deactivate", nargs="*", default=[], metavar="NAME")
    p.add_argument("--strict", action="store_true", help="refuse the whole switch on any problem")
    _manager_args(p)
    p = sub.add_parser("unload_controller", help="unload an inactive controller")
    p.add_argument("name")
    _manager_args(p)
    p = sub.add_parser("spawner", help="wait for the controller manager, load, configure and activate controllers")
    p.add_argument("names", nargs="+", metavar="NAME")
    state = p.add_mutually_exclusive_group()
    state.add_argument("--inactive", action="store_true", help="configure only, do not activate")
    state.add_argument("--load-only", action="store_true", help="load only: leave the controllers unconfigured")
    p.add_argument("-p", "--param-file", help="ros2_control YAML with the controllers' type and parameters")
    p.add_argument("-t", "--controller-type", help="the controllers' type (package/Class), instead of the YAML's")
    p.add_argument("--controller-manager-timeout", type=float, default=10.0,
                   help="s to wait for the controller manager (the ros2_control startup race)")
    _manager_args(p)


class ManagerClient:
    def __init__(self, args: argparse.Namespace) -> None:
        # the spawner may start before the router (docker-compose): it waits as long as for the manager
        self.node = cli_node(args, "control", router_wait=getattr(args, "controller_manager_timeout", ROUTER_WAIT))
        self.prefix = "/".join(p for p in (args.namespace.strip("/"), args.controller_manager.strip("/")) if p)
        self.timeout = args.timeout
        self._clients: dict[str, Client] = {}

    def call(self, service: str, timeout: float | None = None, **fields: Any) -> Any:
        srv = msgs.get_type(_SRV[service])
        client = self._clients.get(service)
        if client is None:
            client = self._clients[service] = Client(self.node, srv, f"{self.prefix}/{service}")
        try:
            return client.call(srv.Request(**fields), timeout=timeout or self.timeout)
        except ServiceError as exc:
            raise Failed(str(exc)) from None

    def controllers(self, timeout: float | None = None) -> dict[str, Any]:
        return {c.name: c for c in self.call("list_controllers", timeout).controller}

    def close(self) -> None:
        self.node.destroy()

    # --- composite operations (ros2 control semantics) ---------------------------------------------------
    def load(self, name: str) -> None:
        if not self.call("load_controller", name=name).ok:
            raise Failed(f"could not load controller '{name}' (see the controller manager's log)")

    def configure(self, name: str) -> None:
        if not self.call("configure_controller", name=name).ok:
            raise Failed(f"could not configure controller '{name}' (see the controller manager's log)")

    def switch(self, activate: list[str], deactivate: list[str], strict: bool = True) -> str:
        response = self.call("switch_controller", activate_controllers=activate, deactivate_controllers=deactivate,
                             strictness=STRICT if strict else BEST_EFFORT)
        if not response.ok:
            raise Failed(f"switch refused: {response.message}")
        return response.message

    def set_state(self, name: str, target: str) -> None:
        current = self.controllers().get(name)
        if current is None:
            raise Failed(f"controller '{name}' is not loaded")
        state = current.state
        if target == "inactive":
            if state == "active":
                self.switch([], [name])
            elif state == "unconfigured":
                self.configure(name)
        elif target == "active":
            if state == "unconfigured":
                self.configure(name)
            if state != "active":
                self.switch([name], [])


def _print_controllers(controllers: dict[str, Any], verbose: bool) -> None:
    width = max((len(n) for n in controllers), default=0)
    type_width = max((len(c.type) for c in controllers.values()), default=0)
    for name, c in controllers.items():
        print(f"{name:<{width}}  {c.type:<{type_width}}  {c.state}")
        if verbose or c.claimed_interfaces:
            print("\tclaimed interfaces:")
            for iface in c.claimed_interfaces:
                print(f"\t\t{iface}")
        if verbose:
            print("\trequired command interfaces:")
            for iface in c.required_command_interfaces:
                print(f"\t\t{iface}")
            print("\trequired state interfaces:")
            for iface in c.required_state_interfaces:
                print(f"\t\t{iface}")


def _spawner(client: ManagerClient, args: argparse.Namespace) -> None:
    # Wait for the manager: it only answers once the simulator's hardware is known (startup race).
    deadline = time.monotonic() + args.controller_manager_timeout
    while True:
        try:
            controllers = client.controllers(timeout=min(2.0, max(0.2, deadline - time.monotonic())))
            break
        except Failed as exc:
            if time.monotonic() >= deadline:
                raise Failed(f"controller manager '{client.prefix}' not available after "
                             f"{args.controller_manager_timeout:g} s: {exc}") from None
            time.sleep(0.2)
    if args.param_file or args.controller_type:
        from nodes.control.config import ConfigError, load_config_file

        try:
            config = load_config_file(args.param_file) if args.param_file else None
        except ConfigError as exc:
            raise UsageError(str(exc)) from None
        names, values = [], []
        for name in args.names:
            cfg = config.controllers.get(name) if config is not None else None
            if cfg is None and not args.controller_type:
                continue
            params = dict(cfg.params) if cfg is not None else {}
            if cfg is not None and cfg.type:
                params["type"] = cfg.type
            if args.controller_type:   # as ROS's spawner: -t sets the type of every controller named
                params["type"] = args.controller_type
            names.append(name)
            values.append(yaml.safe_dump(params))
        if names:
            response = client.call("set_controller_parameters", names=names, values_yaml=values)
            problems = [f"{n}: {r}" for n, ok, r in zip(names, response.successful, response.reasons, strict=True)
                        if not ok]
            if problems:
                raise Failed("parameters refused: " + "; ".join(problems))
    for name in args.names:
        if name not in controllers:
            client.load(name)
            state = "unconfigured"
        else:
            state = controllers[name].state
        if args.load_only:
            print(f"Loaded {name}")
            continue
        if state == "unconfigured":
            client.configure(name)
        if args.inactive:
            print(f"Configured {name}")
            continue
        if state != "active":
            client.switch([name], [])
        print(f"Configured and activated {name}")


def _namespace_hint(client: ManagerClient) -> str:
    """"; controller managers running: /simple_robot/controller_manager (--ns simple_robot)" when the asked one
    is not there (the default namespace is humanoid)."""
    try:
        managers = sorted({e.node for e in snapshot(client.node) if e.kind == "node"
                           and e.node.rsplit("/", 1)[-1] == client.prefix.rsplit("/", 1)[-1]})
    except Exception:  # noqa: BLE001 - only a hint
        return ""
    if not managers or "/" + client.prefix in managers:
        return ""
    shown = ", ".join(f"{m} (--ns {m.strip('/').rpartition('/')[0] or '/'})" for m in managers)
    return f"; controller managers running: {shown}"


def run(args: argparse.Namespace) -> int:
    if args.cmd == "set_controller_state" and args.state not in ("inactive", "active"):
        raise UsageError(f"state must be 'inactive' or 'active', got '{args.state}'")
    if args.cmd == "switch_controllers" and not (args.activate or args.deactivate):
        raise UsageError("nothing to switch: give --activate and/or --deactivate")
    client = ManagerClient(args)
    try:
        if args.cmd == "list_controllers":
            _print_controllers(client.controllers(), args.verbose)
        elif args.cmd == "list_hardware_interfaces":
            response = client.call("list_hardware_interfaces")
            print("command interfaces")
            for i in response.command_interfaces:
                print(f"\t{i.name} [{'available' if i.is_available else 'unavailable'}] "
                      f"[{'claimed' if i.is_claimed else 'unclaimed'}]")
            print("state interfaces")
            for i in response.state_interfaces:
                print(f"\t{i.name}")
        elif args.cmd == "load_controller":
            client.load(args.name)
            if args.set_state:
                client.set_state(args.name, args.set_state)
            print(f"Successfully loaded controller {args.name}" +
                  (f" into state {args.set_state}" if args.set_state else ""))
        elif args.cmd == "set_controller_state":
            client.set_state(args.name, args.state)
            print(f"Successfully set {args.name} to {args.state}")
        elif args.cmd == "switch_controllers":
            message = client.switch(args.activate, args.deactivate, args.strict)
            print(f"Successfully switched controllers ({message})")
        elif args.cmd == "unload_controller":
            if not client.call("unload_controller", name=args.name).ok:
                raise Failed(f"could not unload controller '{args.name}' (is it active or not loaded?)")
            print(f"Successfully unloaded controller {args.name}")
        elif args.cmd == "spawner":
            _spawner(client, args)
    except Failed as exc:
        print(f"zenroid control {args.cmd}: {exc}{_namespace_hint(client)}", file=sys.stderr)
        return 1
    finally:
        client.close()
    return 0
