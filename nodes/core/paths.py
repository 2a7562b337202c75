"""Where the project's shared files live (robots/, config/, launch/)."""

from __future__ import annotations

from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parents[2]
ROBOTS_DIR = PROJECT_ROOT / "robots"
CONFIG_DIR = PROJECT_ROOT / "config"
LAUNCH_DIR = PROJECT_ROOT / "launch"


def robot_path(name: str) -> Path:
    """``$(robot NAME)``: ``robots/NAME.urdf`` or ``robots/NAME.urdf.xacro`` (or NAME as given)."""
    for candidate in (ROBOTS_DIR / name, ROBOTS_DIR / f"{name}.urdf", ROBOTS_DIR / f"{name}.urdf.xacro"):
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"no robot '{name}' in {ROBOTS_DIR}")
