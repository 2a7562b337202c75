"""``zenroid spawn``: put a robot (URDF) or a model (SDF) into the running simulator, like gazebo_ros'
``spawn_entity.py``.

    zenroid spawn -entity humanoid -file robots/humanoid.urdf -z 1.0
    zenroid spawn -entity humanoid -topic robot_description -x 0 -y 0 -z 1.0 -Y 1.57
    zenroid spawn -entity crate -file crate.sdf -x 2 -z 0.5
"""

from __future__ import annotations

import argparse
import math
import time

from nodes.core.endpoints import ServiceError
from nodes.tools.cli import UsageError
from nodes.tools.common import add_common, cli_node


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-entity", required=True, help="name of the entity in the simulator")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("-file", help="URDF (or .xacro) file, a robot name from robots/, or an SDF model (.sdf)")
    source.add_argument("-topic", help="latched robot_description key (e.g. humanoid/robot_description)")
    for axis in ("x", "y", "z"):
        parser.add_argument(f"-{axis}", type=float, default=0.0, help=f"initial {axis} position (m)")
    for axis, name in (("R", "roll"), ("P", "pitch"), ("Y", "yaw")):
        parser.add_argument(f"-{axis}", type=float, default=0.0, help=f"initial {name} (rad)")
    parser.add_argument("-robot_namespace", default="", help="namespace of the robot's keys (default: entity)")
    parser.add_argument("-reference_frame", default="", help="pose relative to this entity (default: world)")
    parser.add_argument("-fixed", action="store_true", help="weld the root link to the world")
    parser.add_argument("-J", nargs=2, action="append", default=[], metavar=("JOINT", "POSITION"),
                        help="initial joint position (repeatable)")
    parser.add_argument("-unpause", action="store_true", help="unpause physics after spawning")
    parser.add_argument("-timeout", type=float, default=30.0, help="seconds to wait for the simulator/topic")
    add_common(parser)


def _initial_joints(pairs: list[list[str]]) -> tuple[list[str], list[float]]:
    names, values = [], []
    for name, raw in pairs:
        try:
            value = float(raw)
        except ValueError:
            raise UsageError(f"-J {name} {raw}: position is not a number") from None
        if not math.isfinite(value):
            raise UsageError(f"-J {name} {raw}: position must be finite")
        names.append(name)
        values.append(value)
    return names, values


def run(args: argparse.Namespace) -> int:
    from nodes.sim.interfaces import Empty, SpawnEntity
    from nodes.sim.robot_files import ConfigError, fetch_robot_description, read_model_xml, resolve_robot_file

    pose_values = [args.x, args.y, args.z, args.R, args.P, args.Y]
    if not all(math.isfinite(v) for v in pose_values):
        raise UsageError(f"pose must be finite, got {pose_values}")
    if args.timeout <= 0:
        raise UsageError("-timeout must be positive")
    joint_names, joint_values = _initial_joints(args.J)
    xml = ""
    if args.file:
        try:
            xml = read_model_xml(resolve_robot_file(args.file))
        except ConfigError as exc:
            raise UsageError(str(exc)) from None

    from nodes.sim.geometry import pose_from_xyz_rpy

    node = cli_node(args, "spawn")
    try:
        deadline = time.monotonic() + args.timeout
        if args.topic:
            key = args.topic.strip().strip("/")
            while True:
                try:
                    xml = fetch_robot_description(node, "/" + key, timeout=min(2.0, args.timeout))
                    break
                except ServiceError as exc:
                    if time.monotonic() >= deadline:
                        print(f"zenroid spawn: no robot description on '{key}': {exc}")
                        return 1
                    time.sleep(0.2)
        client = node.create_client(SpawnEntity, "/sim/spawn_entity")
        if not client.wait_for_service(max(0.1, deadline - time.monotonic())):
            print(f"zenroid spawn: service 'sim/spawn_entity' not available after {args.timeout:g} s "
                  "(is the simulator running?)")
            return 1
        position, orientation = pose_from_xyz_rpy(*pose_values)
        request = SpawnEntity.Request(
            name=args.entity, xml=xml, robot_namespace=args.robot_namespace,
            reference_frame=args.reference_frame, fixed=args.fixed,
            initial_joint_names=joint_names, initial_joint_positions=joint_values,
        )
        p, q = request.initial_pose.position, request.initial_pose.orientation
        p.x, p.y, p.z = position
        q.x, q.y, q.z, q.w = orientation
        try:
            response = client.call(request, timeout=max(5.0, args.timeout))
        except ServiceError as exc:
            print(f"zenroid spawn: {exc}")
            return 1
        if not response.success:
            print(f"zenroid spawn: spawn of '{args.entity}' failed: {response.status_message}")
            return 1
        print(response.status_message)
        if args.unpause:
            node.create_client(Empty, "/sim/unpause_physics").call(timeout=5.0)
            print("physics unpaused")
        return 0
    finally:
        node.destroy()
