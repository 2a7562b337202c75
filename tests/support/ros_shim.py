"""``from std_msgs.msg import String`` for the rclpy tests' programs while the interface packages are not
importable under their ROS names: a folder of modules that hand out ``msgs`` classes (the same objects)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from bench.common import child_env

PACKAGES = ("std_msgs", "std_srvs", "sensor_msgs", "trajectory_msgs", "builtin_interfaces", "control_msgs",
            "example_interfaces", "action_tutorials_interfaces", "rcl_interfaces", "lifecycle_msgs",
            "geometry_msgs", "rosgraph_msgs", "action_msgs", "unique_identifier_msgs")
_MODULE = '''import msgs


def __getattr__(name):
    if name.startswith("__"):
        raise AttributeError(name)
    try:
        return msgs.get_type("{pkg}/{kind}/" + name)
    except Exception:
        if "{pkg}" == "rcl_interfaces" and name in ("ParameterDescriptor", "SetParametersResult"):
            import rclpy.node

            return getattr(rclpy.node, name)
        raise
'''
DEFINITIONS = Path(__file__).resolve().parents[1] / "data" / "ros_interfaces"


def ros_names_importable() -> bool:
    done = subprocess.run([sys.executable, "-c", "import std_msgs.msg"], env=child_env(), capture_output=True)
    return done.returncode == 0


def shim_env(folder: Path, pythonpath: str) -> dict[str, str]:
    """Environment for a program with ROS imports: the shim first on PYTHONPATH and the definitions of
    example_interfaces and action_tutorials_interfaces, while the interface packages lack them."""
    import os

    extra = shim_path(folder)
    if extra is None:
        return {}
    return {"PYTHONPATH": os.pathsep.join([extra, pythonpath]), "ZENROID_MSG_PATH": str(DEFINITIONS)}


def shim_path(folder: Path) -> str | None:
    """A PYTHONPATH entry giving the ROS module names, or None when they already import."""
    if ros_names_importable():
        return None
    for pkg in PACKAGES:
        (folder / pkg).mkdir(parents=True, exist_ok=True)
        (folder / pkg / "__init__.py").write_text("")
        for kind in ("msg", "srv", "action"):
            (folder / pkg / f"{kind}.py").write_text(_MODULE.format(pkg=pkg, kind=kind))
    return str(folder)
