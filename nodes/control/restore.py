"""What a respawned controller manager brings back: the controllers its previous process had loaded,
their types, parameters and lifecycle states.

In ROS 2 a respawned controller_manager comes back empty (the spawners have long exited) and the robot
stays uncontrolled. Here the manager writes its controller set to a small JSON file whenever it changes
(atomically: write, then rename), in the directory the launcher gives every node
(``ZENROID_STATE_DIR``, inside the run's log directory, so a fresh launch starts empty). At start-up a
manager that finds the file loads, configures and activates the same controllers again. Activation
holds the joints where they are measured (JTC, PID), so the robot resumes without a jump.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from nodes.control.controller import ACTIVE, INACTIVE
from nodes.control.manager import BEST_EFFORT, ControllerManager, ManagerError

STATE_DIR_ENV = "ZENROID_STATE_DIR"
VERSION = 1


def state_file(fully_qualified_name: str) -> Path | None:
    """``$ZENROID_STATE_DIR/<ns>.<name>.controllers.json``, or None when no state directory is given."""
    directory = os.environ.get(STATE_DIR_ENV)
    if not directory:
        return None
    stem = ".".join(part for part in fully_qualified_name.split("/") if part)
    return Path(directory) / f"{stem}.controllers.json"


def snapshot(manager: ControllerManager) -> dict[str, Any]:
    with manager.lock:
        entries = []
        for name, entry in manager.controllers.items():
            cfg = manager.config.controllers.get(name)
            entries.append({"name": name, "type": entry.type_name, "state": entry.state,
                            "params": dict(cfg.params) if cfg is not None else {}})
        return {"version": VERSION, "controllers": entries}


def save(path: Path, manager: ControllerManager) -> None:
    """Write the snapshot atomically (a kill -9 mid-write leaves the previous file)."""
    text = json.dumps(snapshot(manager), default=str)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def load(path: Path) -> list[dict[str, Any]]:
    """The saved controllers; [] when there is no file. Raises ValueError for a file we cannot use."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return []
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: {exc}") from None
    if not isinstance(data, dict) or data.get("version") != VERSION or not isinstance(data.get("controllers"), list):
        raise ValueError(f"{path}: not a version {VERSION} controller snapshot")
    entries = []
    for item in data["controllers"]:
        if not (isinstance(item, dict) and isinstance(item.get("name"), str) and isinstance(item.get("type"), str)
                and isinstance(item.get("params", {}), dict)):
            raise ValueError(f"{path}: malformed entry {item!r}")
        entries.append(item)
    return entries


def restore(manager: ControllerManager, entries: list[dict[str, Any]]) -> tuple[list[str], list[str]]:
    """Load / configure each saved controller, then activate the ones that were active in one switch.
    Returns (active controllers now, problems)."""
    problems: list[str] = []
    to_activate: list[str] = []
    for item in entries:
        name = item["name"]
        try:
            manager.set_controller_params(name, {**item.get("params", {}), "type": item["type"]})
            manager.load(name)
            if item.get("state") in (INACTIVE, ACTIVE):
                manager.configure(name)
            if item.get("state") == ACTIVE:
                to_activate.append(name)
        except ManagerError as exc:
            problems.append(str(exc))
    if to_activate:
        ok, message = manager.switch(to_activate, [], BEST_EFFORT)
        if not ok:
            problems.append(message)
    active = [e.name for e in manager.controllers.values() if e.state == ACTIVE]
    return active, problems
