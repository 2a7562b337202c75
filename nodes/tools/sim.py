"""``zenroid sim``: world control of the running simulator (Gazebo's pause/reset buttons, ``gz physics -g``).

    zenroid sim pause | unpause | reset [--time] | step N | gravity X Y Z | ground on|off
    zenroid sim mode lockstep|realtime|kinematic | info
"""

from __future__ import annotations

import argparse
import math

from nodes.core.endpoints import ServiceError
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common, cli_node, to_yaml

ACTIONS = ("pause", "unpause", "reset", "step", "gravity", "ground", "mode", "info")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=ACTIONS, help="what to do")
    parser.add_argument("values", nargs="*", help="step: N; gravity: X Y Z; ground: on|off; mode: NAME")
    parser.add_argument("--time", action="store_true", help="reset: also reset sim time (reset_simulation)")
    parser.add_argument("--timeout", type=float, default=5.0, help="service call timeout (s)")
    add_common(parser)


def _floats(values: list[str], count: int, what: str) -> list[float]:
    if len(values) != count:
        raise UsageError(f"{what} takes {count} number(s), got {len(values)}")
    try:
        numbers = [float(v) for v in values]
    except ValueError:
        raise UsageError(f"{what}: {' '.join(values)} are not numbers") from None
    if not all(math.isfinite(v) for v in numbers):
        raise UsageError(f"{what}: values must be finite")
    return numbers


def _request(args: argparse.Namespace):
    """(service key, type, request) for the action; validates the values before connecting."""
    from nodes.sim.interfaces import MODES, Empty, GetPhysicsProperties, SetPhysicsProperties, StepSimulation

    action, values = args.action, args.values
    if action in ("pause", "unpause", "reset", "info") and values:
        raise UsageError(f"{action} takes no values")
    if action == "pause":
        return "sim/pause_physics", Empty, Empty.Request()
    if action == "unpause":
        return "sim/unpause_physics", Empty, Empty.Request()
    if action == "reset":
        return ("sim/reset_simulation" if args.time else "sim/reset_world"), Empty, Empty.Request()
    if action == "info":
        return "sim/get_physics_properties", GetPhysicsProperties, GetPhysicsProperties.Request()
    if action == "step":
        (steps,) = _floats(values, 1, "step")
        if steps != int(steps) or not 1 <= steps <= 1_000_000:
            raise UsageError(f"step: N must be an integer in 1..1000000, got {values[0]}")
        return "sim/step", StepSimulation, StepSimulation.Request(steps=int(steps))
    request = SetPhysicsProperties.Request()
    if action == "gravity":
        request.gravity.x, request.gravity.y, request.gravity.z = _floats(values, 3, "gravity")
        request.set_gravity = True
    elif action == "ground":
        if values not in (["on"], ["off"]):
            raise UsageError("ground takes 'on' or 'off'")
        request.add_ground, request.remove_ground = values[0] == "on", values[0] == "off"
    else:
        if len(values) != 1 or values[0] not in MODES:
            raise UsageError(f"mode takes one of {', '.join(MODES)}")
        request.mode = values[0]
    return "sim/set_physics_properties", SetPhysicsProperties, request


def run(args: argparse.Namespace) -> int:
    import msgs

    key, srv_type, request = _request(args)
    node = cli_node(args, "sim")
    try:
        try:
            response = node.create_client(srv_type, "/" + key).call(request, timeout=args.timeout)
        except ServiceError as exc:
            print(f"zenroid sim {args.action}: {exc}")
            return 1
        if args.action == "info":
            print(to_yaml(msgs.to_dict(response)))
            return 0
        if hasattr(response, "success") and not response.success:
            print(f"zenroid sim {args.action}: {response.status_message}")
            return 1
        print(getattr(response, "status_message", "") or f"{args.action}: done")
        return 0
    finally:
        node.destroy()
