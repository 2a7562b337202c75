"""``zenroid param``: list, get, set, dump and load parameters of a running node (``ros2 param``).

``set`` reports what the node did: a parameter the node only reads at start-up is refused with the reason
(read-only), never answered "successful" while nothing changes. ``describe`` and ``delete`` ask rcl_interfaces'
parameter services on the ROS 2 wire, as ``ros2 param`` does; the others zenroid's YAML services.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import yaml

import msgs
from msgs.zenroid_msgs import GetParameters as _Get
from msgs.zenroid_msgs import SetParameters as _Set
from nodes.core import ServiceError
from nodes.core.params import ParameterError, dump_value, load_params_file, parse_value
from nodes.tools.common import add_common, cli_node, require_node, write_line
from nodes.tools.errors import Failed, UsageError

_Describe = msgs.get_type("rcl_interfaces/srv/DescribeParameters")
_RosSet = msgs.get_type("rcl_interfaces/srv/SetParameters")
_RosParameter = msgs.get_type("rcl_interfaces/msg/Parameter")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list", help="a node's parameters and their values")
    p.add_argument("node")
    add_common(p)
    p = sub.add_parser("get", help="one parameter's value")
    p.add_argument("node")
    p.add_argument("name")
    add_common(p)
    p = sub.add_parser("set", help="change a parameter at run time (refused with the reason when it cannot be)")
    p.add_argument("node")
    p.add_argument("name")
    p.add_argument("value", help="YAML value")
    add_common(p)
    p = sub.add_parser("describe", help="parameters' type, description and constraints (ROS 2 wire)")
    p.add_argument("node")
    p.add_argument("names", nargs="+")
    add_common(p)
    p = sub.add_parser("delete", help="undeclare a parameter (refused for a statically typed one; ROS 2 wire)")
    p.add_argument("node")
    p.add_argument("name")
    add_common(p)
    p = sub.add_parser("dump", help="every parameter as a ROS params file (YAML)")
    p.add_argument("node")
    p.add_argument("-o", "--output", default="", help="write to FILE instead of stdout")
    add_common(p)
    p = sub.add_parser("load", help="set the parameters of a ROS params file")
    p.add_argument("node")
    p.add_argument("file")
    add_common(p)


def run(args: argparse.Namespace) -> int:
    loaded: dict[str, Any] = {}
    if args.cmd == "load":
        path = Path(args.file)
        if not path.is_file():
            raise UsageError(f"no such file: {args.file}")
    node = cli_node(args, "param")
    try:
        target = require_node(node, args.node)
        ns, _, name = target.lstrip("/").rpartition("/")
        if args.cmd == "load":
            try:
                loaded = load_params_file(args.file, name, ns)
            except ParameterError as exc:
                raise UsageError(str(exc)) from None
        if args.cmd in ("describe", "delete"):
            return _over_ros2(node, target, args)
        try:
            get = node.create_client(_Get, f"{target}/get_parameters")
            if args.cmd == "set":
                return _set(node, target, {args.name: parse_value(args.value)}, verbose_name=False)
            if args.cmd == "load":
                current = _values(get.call(_Get.Request(names=[])))
                return _load(node, target, current, loaded)
            names = [args.name] if args.cmd == "get" else []
            values = _values(get.call(_Get.Request(names=names)))
        except ServiceError as exc:
            raise Failed(str(exc)) from None
    finally:
        node.destroy()
    if args.cmd == "get":
        if args.name not in values:
            raise Failed(f"parameter '{args.name}' is not declared by {target}")
        write_line(dump_value(values[args.name]))
        return 0
    if args.cmd == "dump":
        text = yaml.safe_dump({target: {"ros__parameters": values}}, sort_keys=True, default_flow_style=None,
                              width=100)
        if args.output:
            Path(args.output).write_text(text)
            write_line(f"wrote {len(values)} parameters of {target} to {args.output}")
        else:
            write_line(text.rstrip())
        return 0
    write_line(f"{target}:")
    for pname, value in values.items():
        write_line(f"  {pname}: {dump_value(value)}")
    return 0


_TYPE_NAMES = ("not set", "boolean", "integer", "double", "string", "byte array", "boolean array",
               "integer array", "double array", "string array")   # ros2param's spelling


def _over_ros2(node: Any, target: str, args: argparse.Namespace) -> int:
    """``describe`` and ``delete`` through rcl_interfaces' services, printed as ``ros2 param`` prints them."""
    try:
        if args.cmd == "describe":
            client = node.create_ros2_client(_Describe, f"{target}/describe_parameters")
            descriptors = client.call(_Describe.Request(names=list(args.names)), timeout=10.0).descriptors
            if not descriptors:
                raise Failed(f"{target} does not declare all of {', '.join(args.names)}")
            for d in descriptors:
                _print_descriptor(d)
            return 0
        client = node.create_ros2_client(_RosSet, f"{target}/set_parameters")
        request = _RosSet.Request(parameters=[_RosParameter(name=args.name)])   # NOT_SET: delete, as rclpy's
        results = client.call(request, timeout=10.0).results
    except (ServiceError, RuntimeError) as exc:
        raise Failed(str(exc)) from None
    if results and results[0].successful:
        write_line("Deleted parameter successfully")
        return 0
    reason = results[0].reason if results else "no answer"
    write_line(f"Deleting parameter failed: {reason}")
    return 1


def _print_descriptor(d: Any) -> None:
    write_line(f"Parameter name: {d.name}")
    write_line(f"  Type: {_TYPE_NAMES[d.type] if d.type < len(_TYPE_NAMES) else d.type}")
    if d.description:
        write_line(f"  Description: {d.description}")
    write_line("  Constraints:")
    if d.read_only:
        write_line("    Read only: true")
    ranges = [*d.floating_point_range, *d.integer_range]
    if ranges:
        write_line(f"    Min value: {ranges[0].from_value}")
        write_line(f"    Max value: {ranges[0].to_value}")
        if ranges[0].step:
            write_line(f"    Step: {ranges[0].step}")
    if d.additional_constraints:
        write_line(f"    Additional constraints: {d.additional_constraints}")


def _values(response: Any) -> dict[str, Any]:
    return {n: parse_value(text) for n, text in zip(response.names, response.values_yaml)}


def _set(node: Any, target: str, values: dict[str, Any], verbose_name: bool = True) -> int:
    """Set ``values`` on ``target``; prints one line per parameter; 1 when any was refused."""
    names = list(values)
    response = node.create_client(_Set, f"{target}/set_parameters").call(
        _Set.Request(names=names, values_yaml=[dump_value(values[n]) for n in names]))
    failed = 0
    for i, pname in enumerate(names):
        ok = i < len(response.successful) and response.successful[i]
        what = f" {pname}" if verbose_name else ""
        if ok:
            write_line(f"Set parameter{what} successful")
        else:
            failed += 1
            reason = response.reasons[i] if i < len(response.reasons) and response.reasons[i] else "refused"
            write_line(f"Setting parameter{what} failed: {reason}")
    return 1 if failed else 0


def _load(node: Any, target: str, current: dict[str, Any], loaded: dict[str, Any]) -> int:
    """Set what differs from the running values. Nested maps also arrive flattened (``gains.j.p``): a dotted
    name under a declared map parameter is covered by that parameter."""
    if not loaded:
        raise Failed(f"the file has no parameters for {target}")
    changes: dict[str, Any] = {}
    for pname, value in loaded.items():
        covered = any(pname.startswith(parent + ".") and isinstance(current.get(parent), dict) for parent in current)
        if covered or (pname in current and current[pname] == value):
            continue
        changes[pname] = value
    unchanged = len(loaded) - len(changes)
    if not changes:
        write_line(f"all {len(loaded)} parameters already have these values")
        return 0
    code = _set(node, target, changes)
    if unchanged:
        write_line(f"({unchanged} parameters already had these values)")
    return code
