"""Getting a robot's URDF text: from a file (xacro expanded) or a latched ``robot_description`` key.

No DART here: ``zenroid spawn`` uses this too and must start quickly.
"""

from __future__ import annotations

from pathlib import Path

import msgs
from msgs.std_msgs import String
from nodes.core import Node
from nodes.core.endpoints import ServiceError, call_raw
from nodes.share import robot_file


class ConfigError(ValueError):
    """A simulator setting or robot source that cannot be used; the message names it."""


def resolve_robot_file(file: str) -> Path:
    """A path as given, else a robot name from ``robots/`` (``humanoid`` → robots/humanoid.urdf)."""
    try:
        return robot_file(file)
    except FileNotFoundError as exc:
        raise ConfigError(str(exc)) from None


def read_robot_xml(path: Path) -> str:
    """URDF text of a file; xacro files are expanded first. Like every URDF entry point, the text goes through
    the XML safety check (entity declarations and external DTDs refused), before xacro runs and after."""
    from nodes.urdf.description import load_robot_description  # numpy/lxml: only paid when a file is read
    from nodes.urdf.model import UrdfError

    try:
        return load_robot_description(path)
    except UrdfError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def read_model_xml(path: Path) -> str:
    """A robot (URDF or xacro, as ``read_robot_xml``) or an SDF model file (``.sdf``): the SDF text is passed
    on as it is, the simulator checks it (nodes/sim/sdf.py)."""
    if path.suffix == ".sdf":
        from nodes.sim.sdf import MAX_FILE_BYTES, WorldError, read_limited

        try:
            return read_limited(path, MAX_FILE_BYTES, "model file").decode("utf-8", errors="replace")
        except WorldError as exc:
            raise ConfigError(str(exc)) from None
    return read_robot_xml(path)


def fetch_robot_description(node: Node, key: str, timeout: float = 2.0) -> str:
    """The URDF from a latched ``robot_description`` (a queryable answering std_msgs/String)."""
    resolved = node.resolve(key)
    data = call_raw(node.session, resolved, b"", timeout)
    try:
        text = msgs.decode(String, data).data
    except msgs.DecodeError as exc:
        raise ServiceError(f"{resolved}: not a std_msgs/String: {exc}") from None
    if not text.strip():
        raise ServiceError(f"{resolved}: empty robot description")
    return text
