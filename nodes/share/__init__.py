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


# The legged robots of example-robot-data (``pip install -e '.[robots]'``), by name: their files in its package.
SHIPPED_ROBOTS = {
    "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf",
    "g1_with_hands": "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
    "talos": "talos_data/robots/talos_reduced.urdf",
    "talos_full": "talos_data/robots/talos_full_v2_box.urdf",
    "simple_humanoid": "simple_humanoid_description/urdf/simple_humanoid.urdf",
    "romeo": "romeo_description/urdf/romeo.urdf",
    "icub": "icub_description/robots/icub_reduced.urdf",
    "alexander": "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf",
    "bolt": "bolt_description/robots/bolt.urdf",
    "solo": "solo_description/robots/solo.urdf",
    "solo12": "solo_description/robots/solo12.urdf",
    "a1": "a1_description/urdf/a1.urdf",
    "go1": "go1_description/urdf/go1.urdf",
    "go2": "go2_description/urdf/go2.urdf",
    "b1": "b1_description/urdf/b1.urdf",
    "laikago": "laikago_description/urdf/laikago.urdf",
    "anymal": "anymal_c_simple_description/urdf/anymal.urdf",
    "anymal_b": "anymal_b_simple_description/robots/anymal.urdf",
    "hyq": "hyq_description/robots/hyq_no_sensors.urdf",
    "quadruped": "quadruped_description/urdf/quadruped.urdf",
}
SHIPPED_PACKAGE = "example-robot-data"


def shipped_robot(name: str) -> Path | None:
    """A robot of example-robot-data by name, when it is installed (the ``robots`` extra)."""
    if name not in SHIPPED_ROBOTS:
        return None
    from nodes.urdf.paths import PathError, package_root

    try:
        root, _ = package_root(SHIPPED_PACKAGE)
    except PathError:
        return None
    path = root / "robots" / SHIPPED_ROBOTS[name]
    return path if path.is_file() else None


def robot_file(name: str) -> Path:
    """``$(robot NAME)``: a path or a ``package://``, ``model://`` or ``file://`` URI as given, else
    ``robots/NAME``, ``robots/NAME.urdf`` or ``robots/NAME.urdf.xacro``, else a robot of example-robot-data by name (``g1``, ``talos``, ...: ``SHIPPED_ROBOTS``)."""
    if "://" in name:
        from nodes.urdf.paths import PathError, robot_uri_path

        try:
            path = robot_uri_path(name)
        except PathError as exc:
            raise FileNotFoundError(str(exc)) from None   # it names the URI and the places searched
        if path is not None:
            if not path.is_file():
                raise FileNotFoundError(f"{name!r}: {path} does not exist")
            return path
    try:
        return _find(name, ROBOTS_DIR, ROBOT_SUFFIXES, "robot")
    except FileNotFoundError as exc:
        shipped = shipped_robot(name)
        if shipped is not None:
            return shipped
        if name in SHIPPED_ROBOTS:
            raise FileNotFoundError(f"{exc}; robot {name!r} comes with example-robot-data: "
                                    "pip install -e '.[robots]'") from None
        raise


def config_file(name: str) -> Path:
    """``$(config NAME)``: a path as given, else ``config/NAME`` or ``config/NAME.yaml``."""
    return _find(name, CONFIG_DIR, ("", ".yaml"), "config file")


def world_file(name: str) -> Path:
    """``world:=NAME``: a path as given, else ``worlds/NAME``, ``worlds/NAME.world`` or ``worlds/NAME.sdf``."""
    return _find(name, WORLDS_DIR, ("", ".world", ".sdf"), "world")


def robot_names() -> list[str]:
    """The robots shipped in ``robots/`` (file names: ``humanoid.urdf``, ``humanoid.urdf.xacro``, ...)."""
    return sorted(p.name for p in ROBOTS_DIR.glob("*.urdf*"))
