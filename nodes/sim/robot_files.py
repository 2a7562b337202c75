"""Getting a robot's URDF text: from a file (xacro expanded) or a latched ``robot_description`` key.

No DART here, and Zenoh only when a description is fetched: ``zenroid spawn`` and the launcher (checking the
robot before any process starts) use this too and must start quickly.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from nodes.share import robot_file

if TYPE_CHECKING:
    from nodes.core import Node


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
    import msgs
    from msgs.std_msgs import String
    from nodes.core.endpoints import ServiceError, call_raw

    resolved = node.resolve(key)
    data = call_raw(node.session, resolved, b"", timeout)
    try:
        text = msgs.decode(String, data).data
    except msgs.DecodeError as exc:
        raise ServiceError(f"{resolved}: not a std_msgs/String: {exc}") from None
    if not text.strip():
        raise ServiceError(f"{resolved}: empty robot description")
    return text


def checked_robot(path: Path):
    """A robot file read (xacro expanded) and checked as the simulator will check it at spawn (meshes resolve
    inside their package, moving links have inertia, sensors make sense), without DART: a launch refuses a
    bad robot before any process starts. Returns (the URDF model, its text); raises ConfigError naming the
    file and the reason."""
    from nodes.sim.urdf_info import parse_urdf as check
    from nodes.urdf.model import UrdfError
    from nodes.urdf.model import parse_urdf as parse_model

    xml = read_robot_xml(path)
    try:
        check(xml, path.resolve().as_uri())  # a relative path has no URI
        return parse_model(xml), xml
    except UrdfError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def shipped_controllers(robot: str) -> Path | None:
    """The controllers file that comes with a robot of ``robots/``: config/<robot>_controllers.yaml (our
    humanoid's is config/controllers.yaml)."""
    from nodes.share import CONFIG_DIR

    for name in ((["controllers.yaml"] if robot == "humanoid" else []) + [f"{robot}_controllers.yaml"]):
        if (CONFIG_DIR / name).is_file():
            return CONFIG_DIR / name
    return None


def _fits(config_file: Path, model) -> bool:
    """Whether a controllers file only names joints and sensors this robot has (a variant of the robot)."""
    import yaml

    from nodes.share.controllers import broadcasters

    try:
        config = yaml.safe_load(config_file.read_text()) or {}
    except (OSError, yaml.YAMLError):
        return False
    movable = {j.name for j in model.movable_joints()}
    sensors = {s.name for s in model.sensors}
    for name, section in config.items():
        params = (section or {}).get("ros__parameters") or {} if isinstance(section, dict) else {}
        if not set(params.get("joints") or []) <= movable:
            return False
        if name in broadcasters(config) and params.get("sensor_name") not in sensors:
            return False
    return True


def controllers_for(robot: str, file: str) -> tuple[Path, str | None]:
    """The controllers file a launch of ``robot`` from ``file`` loads: the robot's own from ``config/`` when
    it fits the file, else one derived from the URDF (its <ros2_control> block, or the block generated for
    it) and written, with the URDF and the block, to the user's cache. Returns the file and, when something
    was generated, the line to log. Raises ConfigError (file and reason) for a robot that cannot run."""
    path = resolve_robot_file(file)
    shipped = shipped_controllers(robot)
    if shipped is not None and path == robot_file(robot):
        return shipped, None   # a robot of robots/ with its own file: checked by the project's tests
    from nodes.urdf.control_setup import cache_directory, write_setup

    model, xml = checked_robot(path)
    if shipped is not None and _fits(shipped, model):
        return shipped, None
    written = write_setup(model, xml, cache_directory(xml))
    return written.controllers, written.describe(model, generated_block=not model.ros2_control)
