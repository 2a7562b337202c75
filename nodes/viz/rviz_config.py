"""An RViz 2 display config (``rviz2 -d FILE.rviz``) read for what maps onto our viewer.

Mapped: the fixed frame (the scene's root frame), RobotModel (its description topic's namespace is a robot to
show), TF, Grid (the ground), Marker and MarkerArray (their topics), Image, PointCloud2 and LaserScan (shown
when they are a robot's sensors). Everything else is listed once, so the user knows what the viewer leaves out.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

SHOWN_BY_SENSORS = {"Image", "PointCloud2", "LaserScan", "Camera", "DepthCloud"}
ALWAYS_SHOWN = {"TF", "Grid", "Axes"}


class RvizConfigError(ValueError):
    """A .rviz file that cannot be read (names the file and the reason)."""


@dataclass
class RvizMapping:
    fixed_frame: str | None = None
    robots: list[str] = field(default_factory=list)           # namespaces of RobotModel description topics
    marker_topics: list[tuple[str, str]] = field(default_factory=list)   # (topic, "Marker" | "MarkerArray")
    ground: bool = True
    mapped: list[str] = field(default_factory=list)           # "RobotModel (/robot_description)" ...
    not_mapped: list[str] = field(default_factory=list)

    def viewer_params(self) -> list[str]:
        """Our viewer's ``--param`` options for this config."""
        params: list[str] = []
        if self.fixed_frame:
            frames = [self.fixed_frame, *(f for f in ("world", "map", "odom") if f != self.fixed_frame)]
            params.append(f"world_frames:={yaml.safe_dump(frames, default_flow_style=True).strip()}")
        robots = [r for r in self.robots if r]
        if robots:
            params.append(f"robots:={yaml.safe_dump(robots, default_flow_style=True).strip()}")
        if not self.ground:
            params.append("ground:=false")
        return params


def _value(display: dict, key: str) -> str:
    """A display property: RViz writes ``Topic: {Value: /x}`` (rviz2) or ``Topic: /x``."""
    item = display.get(key)
    if isinstance(item, dict):
        item = item.get("Value")
    return str(item).strip() if item is not None else ""


def _kind(display: dict) -> str:
    return str(display.get("Class", "")).rpartition("/")[2]


def _displays(items: Any) -> list[dict]:
    """Every display, groups flattened."""
    found: list[dict] = []
    for item in items if isinstance(items, list) else []:
        if not isinstance(item, dict):
            continue
        if _kind(item) == "Group":
            found += _displays(item.get("Displays"))
        else:
            found.append(item)
    return found


def read_rviz(path: str | Path) -> RvizMapping:
    file = Path(path)
    try:
        data = yaml.safe_load(file.read_text(encoding="utf-8"))
    except OSError as exc:
        raise RvizConfigError(f"{file}: cannot read it ({exc.strerror or exc})") from None
    except yaml.YAMLError as exc:
        raise RvizConfigError(f"{file}: not an RViz config (YAML): {exc}") from None
    manager = data.get("Visualization Manager") if isinstance(data, dict) else None
    if not isinstance(manager, dict):
        raise RvizConfigError(f"{file}: no 'Visualization Manager' section (not an RViz config)")
    out = RvizMapping()
    options = manager.get("Global Options") or {}
    if isinstance(options, dict) and options.get("Fixed Frame"):
        out.fixed_frame = str(options["Fixed Frame"]).strip().lstrip("/")
        out.mapped.append(f"fixed frame '{out.fixed_frame}'")
    grid_enabled = None
    for display in _displays(manager.get("Displays")):
        kind, enabled = _kind(display), display.get("Enabled", True) is not False
        name = display.get("Name") or kind
        if not enabled:
            continue
        topic = _value(display, "Topic")
        if kind == "RobotModel":
            source = _value(display, "Description Source") or "Topic"
            description = _value(display, "Description Topic") or "/robot_description"
            if source == "File":
                out.not_mapped.append(f"{name}: a RobotModel from a file (publish it with robot_state_publisher)")
                continue
            out.robots.append(description.strip("/").rpartition("/")[0])
            out.mapped.append(f"{name} ({description})")
        elif kind in ("Marker", "MarkerArray") and topic:
            out.marker_topics.append((topic.lstrip("/"), kind))
            out.mapped.append(f"{name} ({topic})")
        elif kind == "Grid":
            grid_enabled = True
            out.mapped.append(name)
        elif kind in ALWAYS_SHOWN:
            out.mapped.append(name)
        elif kind in SHOWN_BY_SENSORS:
            out.mapped.append(f"{name} ({topic or kind}: shown when it is a sensor of a robot's URDF)")
        else:
            out.not_mapped.append(f"{name} ({kind}{', ' + topic if topic else ''})")
    if grid_enabled is None:
        out.ground = True   # our ground grid stays: an RViz config without a Grid still has a floor in Gazebo
    return out
