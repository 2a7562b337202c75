"""Which launch format a file is, recognised by its content, and its inert description.

- Python (``.launch.py``, or any file defining ``generate_launch_description``): run as code, as ROS does;
- ROS XML (``<launch>`` root);
- YAML: ours (``launch: [- node: {name:, module:|exec:}]``, docs/launch.md) or ROS's (``- node: {pkg:, exec:}``,
  ``let``, ``executable``, ``push_ros_namespace``, ...; a file that uses any ROS-only tag or key is ROS's).
"""

from __future__ import annotations

from pathlib import Path

from launch.description import ACTION_KINDS, LaunchDescription, parse_file
from launch.yaml_source import LaunchError, LocatedDict, LocatedList, Source, loads_located

TRIED = "Python (generate_launch_description), ROS XML (<launch>), YAML (ours, or ROS's launch: [...])"
# Our YAML's keys per action; a key outside them (and any tag outside ours) marks ROS's YAML format
_ROS_ONLY = {"let", "executable", "push_ros_namespace", "set_env", "unset_env", "timer", "log", "set_parameter",
             "set_remap", "shutdown", "load_composable_node"}
_OURS = {"arg": {"name", "default", "description", "choices"}, "include": {"file", "args", "if", "unless"}}


def _is_ros_yaml(items: LocatedList) -> bool:
    for item in items:
        if not isinstance(item, dict) or len(item) != 1:
            return False
        (kind, body), = item.items()
        if kind not in ACTION_KINDS:
            if kind.replace("-", "_") in _ROS_ONLY:
                return True
            continue
        if isinstance(body, list):   # ROS's group: [actions]
            return True
        if not isinstance(body, dict):
            continue
        if kind == "node" and "pkg" in body:
            return True
        if kind in _OURS and set(body) - _OURS[kind]:
            return True
        if kind == "group" and ("children" in body or "scoped" in body):
            return True
    return False


def load_description(path: Path) -> LaunchDescription:
    """The file's inert description, in whichever of the four formats it is."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise LaunchError(f"launch file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise LaunchError(f"cannot read launch file {path}: {exc}") from None
    stripped = text.lstrip()
    if path.name.endswith(".py") or "def generate_launch_description" in text:
        from launch.python_source import load_python

        return load_python(path)
    if stripped.startswith("<"):
        from launch.frontend import load_xml

        return LaunchDescription(file=path, actions=load_xml(path, text), format="xml")
    try:
        data = loads_located(text, path)
    except LaunchError as exc:
        if path.suffix in (".yaml", ".yml"):
            raise
        raise LaunchError(f"not a launch file in any format this launcher reads (tried {TRIED}): {exc.message}",
                          exc.source) from None
    if not isinstance(data, LocatedDict) or not isinstance(data.get("launch"), LocatedList):
        if path.suffix in (".yaml", ".yml"):
            return parse_file(path)   # our format's own error for a malformed file
        raise LaunchError(f"not a launch file in any format this launcher reads (tried {TRIED}): a YAML launch "
                          "file is a mapping with one key 'launch' (a list of actions)", Source(path, 1))
    if _is_ros_yaml(data["launch"]):
        from launch.frontend import load_ros_yaml

        return LaunchDescription(file=path, actions=load_ros_yaml(path, data), format="ros-yaml")
    return parse_file(path)
