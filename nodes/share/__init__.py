"""The one place that finds the project's shared files: robot models (``robots/``), configuration
(``config/``) and SDF worlds (``worlds/``), the ``share/<package>`` directory of a ROS package.

``robots``, ``config`` and ``worlds`` here are links to the top-level folders of the checkout, so the same lookup works
from a checkout, an editable install and a wheel (the build copies the linked files in as package data).
"""

from __future__ import annotations

from pathlib import Path

_HERE = Path(__file__).parent
ROBOTS_DIR = (_HERE / "robots").resolve()
CONFIG_DIR = (_HERE / "config").resolve()
WORLDS_DIR = (_HERE / "worlds").resolve()
ROBOT_SUFFIXES = ("", ".urdf", ".urdf.xacro")


def _find(name: str, folder: Path, suffixes: tuple[str, ...], what: str) -> Path:
    path = Path(name).expanduser()
    if path.is_file():
        return path.resolve()
    for suffix in suffixes:
        candidate = folder / f"{name}{suffix}"
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"{what} {name!r} not found (neither a path nor a file in {folder})")


def robot_file(name: str) -> Path:
    """``$(robot NAME)``: a path as given, else ``robots/NAME``, ``robots/NAME.urdf`` or ``robots/NAME.urdf.xacro``."""
    return _find(name, ROBOTS_DIR, ROBOT_SUFFIXES, "robot")


def config_file(name: str) -> Path:
    """``$(config NAME)``: a path as given, else ``config/NAME`` or ``config/NAME.yaml``."""
    return _find(name, CONFIG_DIR, ("", ".yaml"), "config file")


def world_file(name: str) -> Path:
    """``world:=NAME``: a path as given, else ``worlds/NAME``, ``worlds/NAME.world`` or ``worlds/NAME.sdf``."""
    return _find(name, WORLDS_DIR, ("", ".world", ".sdf"), "world")


def robot_names() -> list[str]:
    """The robots shipped in ``robots/`` (file names: ``humanoid.urdf``, ``humanoid.urdf.xacro``, ...)."""
    return sorted(p.name for p in ROBOTS_DIR.glob("*.urdf*"))
