"""Simulator settings that are more than scalars: per-joint gains and the entities to spawn at start.

Both come from node parameters (``config/sim.yaml`` is a ROS params file) and are validated here so a
bad file fails with the parameter path and the reason instead of a traceback deep in DART.
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from nodes.share import CONFIG_DIR
from nodes.sim.robot_files import ConfigError

DEFAULT_CONFIG = CONFIG_DIR / "sim.yaml"


@dataclass(frozen=True)
class Gains:
    """Joint servo gains: spring stiffness (Nm/rad) and damping (Nms/rad)."""

    kp: float
    kd: float




def _number(where: str, value: Any, minimum: float = 0.0) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{where}: expected a finite number, got {value!r}")
    if value < minimum:
        raise ConfigError(f"{where}: must be >= {minimum}, got {value}")
    return float(value)


def parse_gains(table: Mapping[str, Any] | None) -> Callable[[str], Gains | None]:
    """``{pattern: {p: .., d: ..}}`` → a lookup; the first pattern (fnmatch) matching a joint wins; None when
    none does (the gains then come from the physics: nodes.sim.servo_gains)."""
    rules: list[tuple[str, Gains]] = []
    for pattern, entry in (table or {}).items():
        where = f"gains.{pattern}"
        if not isinstance(entry, Mapping):
            raise ConfigError(f"{where}: expected a map with p and d, got {entry!r}")
        unknown = set(entry) - {"p", "d"}
        if unknown:
            raise ConfigError(f"{where}: unknown keys {sorted(unknown)} (use p and d)")
        if "p" not in entry:
            raise ConfigError(f"{where}: missing p")
        rules.append((str(pattern), Gains(_number(f"{where}.p", entry["p"]), _number(f"{where}.d", entry.get("d", 0.0)))))

    def gains_for(joint: str) -> Gains | None:
        for pattern, gains in rules:
            if fnmatch.fnmatchcase(joint, pattern):
                return gains
        return None

    return gains_for


@dataclass
class StartupEntity:
    """One entry of the ``entities`` parameter: what to spawn when the simulator starts."""

    name: str
    file: str = ""
    topic: str = ""
    namespace: str = ""
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    fixed: bool = False
    joints: dict[str, float] = field(default_factory=dict)
    auto_z: bool = False           # z: auto: the lowest collision geometry on the ground
    initial_pose: str = ""         # an SRDF group_state of the robot


ENTITY_KEYS = {"name", "file", "topic", "namespace", "x", "y", "z", "R", "P", "Y", "fixed", "joints",
               "initial_pose"}


def parse_entities(items: Any) -> list[StartupEntity]:
    if items in (None, ""):
        return []
    if not isinstance(items, list):
        raise ConfigError(f"entities: expected a list, got {items!r}")
    result: list[StartupEntity] = []
    for i, item in enumerate(items):
        where = f"entities[{i}]"
        if not isinstance(item, Mapping):
            raise ConfigError(f"{where}: expected a map, got {item!r}")
        unknown = set(item) - ENTITY_KEYS
        if unknown:
            raise ConfigError(f"{where}: unknown keys {sorted(unknown)} (allowed: {sorted(ENTITY_KEYS)})")
        name = item.get("name")
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{where}.name: required, a non-empty string")
        file, topic = str(item.get("file") or ""), str(item.get("topic") or "")
        if bool(file) == bool(topic):
            raise ConfigError(f"{where}: give exactly one of file and topic")
        auto_z = item.get("z") in ("auto", "")
        coords = [_number(f"{where}.{k}", 0.0 if k == "z" and auto_z else item.get(k, 0.0), -math.inf)
                  for k in ("x", "y", "z", "R", "P", "Y")]
        joints = item.get("joints") or {}
        if not isinstance(joints, Mapping):
            raise ConfigError(f"{where}.joints: expected a map joint -> position, got {joints!r}")
        fixed = item.get("fixed", False)
        if not isinstance(fixed, bool):
            raise ConfigError(f"{where}.fixed: expected true or false, got {fixed!r}")
        result.append(StartupEntity(
            name=name, file=file, topic=topic, namespace=str(item.get("namespace") or ""),
            xyz=tuple(coords[:3]), rpy=tuple(coords[3:]), fixed=fixed,  # type: ignore[arg-type]
            joints={str(k): _number(f"{where}.joints.{k}", v, -math.inf) for k, v in joints.items()},
            auto_z=auto_z, initial_pose=str(item.get("initial_pose") or ""),
        ))
    return result
