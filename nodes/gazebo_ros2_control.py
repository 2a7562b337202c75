"""gazebo_ros2_control's plugin, served: a robot spawned with ``<gazebo><plugin
filename="libgazebo_ros2_control.so">`` in its URDF gets its controller manager, as Gazebo loads the plugin.

This node runs beside the simulator (``gazebo_ros``' ``gzserver.launch.py`` starts it). It reads every model's
URDF from the latched ``sim/scene`` and, for each one carrying the plugin, starts our controller manager
(``python -m nodes.control``) with what the plugin says:

- ``<parameters>`` (several allowed): the controllers files; none: the robot's shipped file
  (config/), else one derived from its ``<ros2_control>`` (nodes/urdf/control_setup.py);
- ``<ros><namespace>``: the manager's namespace (default: the entity's robot namespace); the hardware stays the
  entity's;
- ``<robot_param>``, ``<robot_param_node>``, ``<hold_joints>``: accepted (the simulator hands the hardware over
  directly and holds joints without commands).

The manager stops when its model is deleted and when this node stops. Each position state interface's
``initial_value`` is applied by the simulator when the robot is spawned (nodes.sim.entity), however the spawn
was asked for.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

import msgs
from nodes.core import Node, run_node
from nodes.urdf import UrdfError, parse_urdf
from nodes.urdf.xml_safety import UnsafeXmlError, parse_xml

PLUGIN_FILES = ("libgazebo_ros2_control.so", "gazebo_ros2_control", "libgz_ros2_control-system.so",
                "gz_ros2_control-system", "libign_ros2_control-system.so", "ign_ros2_control-system")
HARDWARE_KEYS = ("hardware/info", "hardware/state", "hardware/command", "hardware/heartbeat")
Scene = msgs.get_type("zenroid_msgs/msg/Scene")


@dataclass
class PluginConfig:
    parameters: list[str] = field(default_factory=list)
    namespace: str | None = None
    robot_param: str = "robot_description"
    robot_param_node: str = "robot_state_publisher"
    hold_joints: bool = True


def read_plugin(urdf: str) -> PluginConfig | None:
    """The gazebo_ros2_control plugin of a URDF, or None when it has none."""
    try:
        root = parse_xml(urdf)
    except (UnsafeXmlError, ValueError):
        return None
    for plugin in root.iter("plugin"):
        if plugin.getparent() is None or plugin.getparent().tag != "gazebo":
            continue
        if os.path.basename(plugin.get("filename", "")) not in PLUGIN_FILES:
            continue
        config = PluginConfig(parameters=[(p.text or "").strip() for p in plugin.findall("parameters")
                                          if (p.text or "").strip()])
        namespace = plugin.findtext("ros/namespace")
        config.namespace = namespace.strip().strip("/") if namespace is not None else None
        config.robot_param = (plugin.findtext("robot_param") or config.robot_param).strip()
        config.robot_param_node = (plugin.findtext("robot_param_node") or config.robot_param_node).strip()
        config.hold_joints = (plugin.findtext("hold_joints") or "true").strip().lower() != "false"
        return config
    return None


def default_controllers(urdf: str, folder: Path) -> Path:
    """A controllers file for a robot whose plugin names none: its shipped one, else one from its joints."""
    from nodes.sim.robot_files import shipped_controllers
    from nodes.urdf.control_setup import controllers_config

    model = parse_urdf(urdf)
    shipped = shipped_controllers(model.name)
    if shipped is not None:
        return shipped
    path = folder / f"{model.name}_controllers.yaml"
    path.write_text(yaml.safe_dump(controllers_config(model), sort_keys=False), encoding="utf-8")
    return path


class GazeboRos2Control(Node):
    default_name = "gazebo_ros2_control"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(self.default_name, **kwargs)
        self.managers: dict[str, subprocess.Popen] = {}
        self.refused: set[str] = set()
        self.folder = Path(tempfile.mkdtemp(prefix="zenroid-ros2-control-"))
        self.create_subscription(Scene, "/sim/scene", self.on_scene)
        latched = self.fetch_latched(Scene, "/sim/scene", timeout=1.0)
        if latched is not None:
            self.on_scene(latched)

    def on_scene(self, scene: Any) -> None:
        present = set(scene.models)
        for name in list(self.managers):
            if name not in present:
                self.stop(name, "its model was deleted")
        for name, namespace, urdf in zip(scene.models, scene.namespaces, scene.descriptions):
            if not urdf or name in self.managers or name in self.refused:
                continue
            plugin = read_plugin(urdf)
            if plugin is not None:
                self.start(name, namespace.strip("/"), urdf, plugin)

    def start(self, entity: str, entity_ns: str, urdf: str, plugin: PluginConfig) -> None:
        try:
            files = plugin.parameters or [str(default_controllers(urdf, self.folder))]
        except (UrdfError, ValueError, OSError) as exc:
            self.refused.add(entity)
            self.logger.error(f"{entity}: gazebo_ros2_control: no controllers file ({exc})")
            return
        missing = [f for f in files if not Path(f).is_file()]
        if missing:
            self.refused.add(entity)
            self.logger.error(f"{entity}: gazebo_ros2_control <parameters> not found: {', '.join(missing)}")
            return
        namespace = entity_ns if plugin.namespace is None else plugin.namespace
        argv = [sys.executable, "-m", "nodes.control", "--name", "controller_manager", "--ns", namespace]
        for path in files:
            argv += ["--params-file", path]
        if namespace != entity_ns:   # the hardware is the entity's, wherever the plugin puts the manager
            for key in HARDWARE_KEYS:
                argv += ["--remap", f"{key}:=/{entity_ns + '/' if entity_ns else ''}{key}"]
        self.managers[entity] = subprocess.Popen(argv)
        where = f"/{namespace}/controller_manager" if namespace else "/controller_manager"
        self.logger.info(f"{entity}: gazebo_ros2_control: controller manager {where} with {', '.join(files)}")

    def stop(self, entity: str, why: str) -> None:
        proc = self.managers.pop(entity)
        self.logger.info(f"{entity}: stopping its controller manager ({why})")
        for sig, wait in ((signal.SIGINT, 10.0), (signal.SIGKILL, 5.0)):
            if proc.poll() is not None:
                return
            proc.send_signal(sig)
            try:
                proc.wait(timeout=wait)
            except subprocess.TimeoutExpired:
                continue

    def on_process_exit(self) -> None:
        for entity in list(self.managers):
            self.stop(entity, "the simulator's plugin host stops")


def main(argv: list[str] | None = None) -> int:
    return run_node(GazeboRos2Control, argv)


if __name__ == "__main__":
    sys.exit(main())
