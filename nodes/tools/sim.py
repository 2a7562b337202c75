"""``zenroid sim``: world control of the running simulator (Gazebo's pause/reset buttons, ``gz physics -g``)
and its models (gazebo_ros' entity services, ``gz model``).

    zenroid sim pause | unpause | reset [--time] | step N | gravity X Y Z | ground on|off
    zenroid sim mode lockstep|realtime|kinematic | info
    zenroid sim models
    zenroid sim get MODEL[::LINK] [--frame ENTITY]
    zenroid sim set MODEL[::LINK] X Y Z [ROLL PITCH YAW] [--twist VX VY VZ WX WY WZ] [--frame ENTITY]
    zenroid sim push MODEL[::LINK] FX FY FZ [--torque TX TY TZ] [--duration S] [--frame ENTITY]
"""

from __future__ import annotations

import argparse
import math

from nodes.core.endpoints import ServiceError
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common, cli_node, to_yaml

ACTIONS = ("pause", "unpause", "reset", "step", "gravity", "ground", "mode", "info", "models", "get", "set", "push")
ENTITY_ACTIONS = ("get", "set", "push")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=ACTIONS, help="what to do")
    parser.add_argument("values", nargs="*", help="step: N; gravity: X Y Z; ground: on|off; mode: NAME; "
                        "get: MODEL[::LINK]; set: MODEL[::LINK] X Y Z [R P Y]; push: MODEL[::LINK] FX FY FZ")
    parser.add_argument("--time", action="store_true", help="reset: also reset sim time (reset_simulation)")
    parser.add_argument("--frame", default="", help="get/set/push: relative to this entity (default: world)")
    parser.add_argument("--twist", nargs=6, default=None, metavar=("VX", "VY", "VZ", "WX", "WY", "WZ"),
                        help="set: linear (m/s) and angular (rad/s) velocity (default: at rest)")
    parser.add_argument("--torque", nargs=3, default=None, metavar=("TX", "TY", "TZ"), help="push: torque (N m)")
    parser.add_argument("--duration", type=float, default=0.1,
                        help="push: seconds of sim time (negative: until cleared; default 0.1)")
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
    if action in ("models", *ENTITY_ACTIONS):
        return _entity_request(args)
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


def _entity_request(args: argparse.Namespace):
    """(service key, type, request) of the entity verbs: models, get, set, push."""
    import msgs
    from nodes.sim.geometry import pose_from_xyz_rpy
    from nodes.sim.interfaces import ApplyLinkWrench, GetEntityState, GetModelList, SetEntityState

    action, values = args.action, args.values
    if action == "models":
        if values:
            raise UsageError("models takes no values")
        return "sim/get_model_list", GetModelList, GetModelList.Request()
    if not values:
        raise UsageError(f"{action} needs MODEL or MODEL::LINK")
    name, numbers = values[0], values[1:]
    if action == "get":
        if numbers:
            raise UsageError("get takes MODEL[::LINK] only")
        return "sim/get_entity_state", GetEntityState, GetEntityState.Request(name=name,
                                                                             reference_frame=args.frame)
    if action == "set":
        if len(numbers) not in (3, 6):
            raise UsageError(f"set takes X Y Z [ROLL PITCH YAW] after the name, got {len(numbers)} number(s)")
        xyzrpy = _floats(numbers, len(numbers), "set") + [0.0] * (6 - len(numbers))
        request = SetEntityState.Request()
        state = request.state
        state.name, state.reference_frame = name, args.frame
        position, orientation = pose_from_xyz_rpy(*xyzrpy)
        p, q = state.pose.position, state.pose.orientation
        p.x, p.y, p.z = position
        q.x, q.y, q.z, q.w = orientation
        if args.twist is not None:
            twist = _floats(args.twist, 6, "--twist")
            state.twist.linear.x, state.twist.linear.y, state.twist.linear.z = twist[:3]
            state.twist.angular.x, state.twist.angular.y, state.twist.angular.z = twist[3:]
        return "sim/set_entity_state", SetEntityState, request
    force = _floats(numbers, 3, "push")
    if not math.isfinite(args.duration) or args.duration == 0:
        raise UsageError("--duration: a finite number of seconds, not 0 (negative: until cleared)")
    request = ApplyLinkWrench.Request(link_name=name, reference_frame=args.frame)
    request.wrench.force.x, request.wrench.force.y, request.wrench.force.z = force
    if args.torque is not None:
        torque = _floats(args.torque, 3, "--torque")
        request.wrench.torque.x, request.wrench.torque.y, request.wrench.torque.z = torque
    request.duration = msgs.duration_from_sec(args.duration)
    return "sim/apply_link_wrench", ApplyLinkWrench, request


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
        if args.action == "models":
            print("\n".join(response.model_names))
            return 0
        if args.action == "get":
            if not response.success:
                print(f"zenroid sim get: no entity {args.values[0]!r} (or frame {args.frame!r}): see the "
                      "simulator's log (zenroid sim models lists the models)")
                return 1
            print(to_yaml(msgs.to_dict(response.state)))
            return 0
        if args.action == "set":
            if not response.success:
                print(f"zenroid sim set: refused for {args.values[0]!r}: the simulator's log says why")
                return 1
            print(f"set {args.values[0]!r}")
            return 0
        if hasattr(response, "success") and not response.success:
            print(f"zenroid sim {args.action}: {response.status_message}")
            return 1
        print(getattr(response, "status_message", "") or f"{args.action}: done")
        return 0
    finally:
        node.destroy()
