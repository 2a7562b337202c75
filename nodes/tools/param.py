"""``zenroid param``: list, get, set, dump and load parameters of a running node (``ros2 param``).

``set`` reports what the node did: a parameter the node only reads at start-up is refused with the reason
(read-only), never answered "successful" while nothing changes.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import yaml

from msgs.zenroid_msgs import GetParameters as _Get
from msgs.zenroid_msgs import SetParameters as _Set
from nodes.core import ServiceError
from nodes.core.params import ParameterError, dump_value, load_params_file, parse_value
from nodes.tools.common import add_common, cli_node, require_node, write_line
from nodes.tools.errors import Failed, UsageError


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
