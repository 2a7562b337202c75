"""ros2_control controller YAML (the tutorials' ``controllers.yaml``) -> what the manager loads.

    controller_manager:
      ros__parameters:
        update_rate: 1000
        joint_trajectory_controller:
          type: joint_trajectory_controller/JointTrajectoryController
    joint_trajectory_controller:
      ros__parameters:
        joints: [...]

Section keys may carry a namespace (``/humanoid/controller_manager``) or be the ``/**`` wildcard.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from nodes.core.params import load_untrusted_yaml

# a controller type as ros2_controllers spells it: <package>/<Class> (looked up in a registry, never imported)
TYPE_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*/[A-Za-z][A-Za-z0-9_]*")


class ConfigError(ValueError):
    """The controller YAML is malformed; the message names the file and the key."""


@dataclass
class ControllerConfig:
    name: str
    type: str = ""
    params: dict[str, Any] = field(default_factory=dict)


@dataclass
class ManagerConfig:
    update_rate: int | None = None
    controllers: dict[str, ControllerConfig] = field(default_factory=dict)
    shared_params: dict[str, Any] = field(default_factory=dict)  # from ``/**``

    def merge(self, other: ManagerConfig) -> None:
        """Later files win, parameter by parameter (like repeated ``--params-file``)."""
        if other.update_rate is not None:
            self.update_rate = other.update_rate
        self.shared_params.update(other.shared_params)
        for name, cfg in other.controllers.items():
            mine = self.controllers.setdefault(name, ControllerConfig(name))
            mine.type = cfg.type or mine.type
            mine.params.update(cfg.params)


def _section_name(key: str) -> str:
    return str(key).strip("/").rsplit("/", 1)[-1]


def parse_config(data: Any, source: str = "<yaml>", manager_name: str = "controller_manager") -> ManagerConfig:
    if data is None:
        return ManagerConfig()
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: the top level must be a map of node names")
    config = ManagerConfig()
    if not any(isinstance(v, dict) for v in data.values()):
        return config  # a flat map of node parameters (no controllers in it)
    sections: dict[str, dict[str, Any]] = {}
    for key, section in data.items():
        if not isinstance(section, dict) or not isinstance(section.get("ros__parameters", {}), dict):
            raise ConfigError(f"{source}: '{key}' must be a map with a 'ros__parameters' map")
        params = section.get("ros__parameters")
        if params is None:
            raise ConfigError(f"{source}: '{key}' has no 'ros__parameters'")
        name = _section_name(key)
        if name in ("**", "*"):
            config.shared_params.update(params)
        else:
            sections.setdefault(name, {}).update(params)
    manager = sections.pop(manager_name, {})
    for key, value in manager.items():
        if key == "update_rate":
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value <= 0 or value > 100_000:
                raise ConfigError(f"{source}: {manager_name}.update_rate must be a positive number of Hz, "
                                  f"got {value!r}")
            config.update_rate = int(value)
        elif isinstance(value, dict) and "type" in value:
            _add_type(config, source, key, value.get("type"))
        elif "." in key and key.endswith(".type"):  # flattened form: ``name.type: pkg/Class``
            _add_type(config, source, key[: -len(".type")], value)
    for name, params in sections.items():
        cfg = config.controllers.setdefault(name, ControllerConfig(name))
        cfg.params.update(params)
    return config


def _add_type(config: ManagerConfig, source: str, name: str, type_name: Any) -> None:
    if not isinstance(type_name, str) or not TYPE_NAME.fullmatch(type_name):
        raise ConfigError(f"{source}: controller_manager.{name}.type must be 'package/Class' (a registered "
                          f"controller type), got {type_name!r:.200}")
    config.controllers.setdefault(name, ControllerConfig(name)).type = type_name


def load_config_file(path: str | Path, manager_name: str = "controller_manager") -> ManagerConfig:
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: invalid YAML: {exc}") from None
    return parse_config(data, str(path), manager_name)


def parse_controller_yaml(text: str, source: str = "<yaml>") -> dict[str, Any]:
    """A controller's parameters sent over the wire as YAML (spawner ``--param-file``)."""
    try:
        data = load_untrusted_yaml(text) if text.strip() else {}
    except yaml.YAMLError as exc:
        raise ConfigError(f"{source}: invalid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a map of parameters")
    return data
