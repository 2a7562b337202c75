"""ros2_control's ``mock_components/GenericSystem`` as zenroid hardware: what ``ros2_control_node`` runs
against when the robot description's ``<ros2_control>`` names no simulator.

It speaks the simulator's side of the hardware interface (docs/architecture.md, Hardware interface):
answers ``hardware/info`` with the ``<ros2_control>`` joints and sensors, publishes ``hardware/state`` every
control period on the wall clock ("realtime" hardware) and takes ``hardware/command``. As GenericSystem does:

- every command is mirrored to the state interface of the same name (position -> position ...);
- ``<param name="calculate_dynamics">true</param>`` of ``<hardware>``: a velocity command integrates into the
  position, a position command sets the velocity from the change;
- ``mock_sensor_commands``: the sensors' state values stay where their ``initial_value`` put them (ours have no
  command interfaces to write them through, so this is accepted and logged);
- each state interface starts at its ``<param name="initial_value">`` (0 without one).
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import msgs
from msgs.zenroid_msgs import HardwareJoint, HardwareSensor
from nodes.core import Node
from nodes.sim.interfaces import GetHardwareInfo, HardwareCommand, HardwareState
from nodes.urdf import UrdfError, parse_urdf
from nodes.urdf.xml_safety import UnsafeXmlError, parse_xml

SIMULATOR_PLUGINS = ("gazebo_ros2_control/GazeboSystem", "gz_ros2_control/GazeboSimSystem",
                     "ign_ros2_control/IgnitionSystem")
_TRUE = {"true", "1", "yes", "on"}


@dataclass
class MockJoint:
    name: str
    commands: list[str]
    states: list[str]
    values: dict[str, float] = field(default_factory=dict)   # state interface -> value
    limits: tuple[float, float] = (0.0, 0.0)
    max_velocity: float = 0.0
    max_effort: float = 0.0


@dataclass
class MockSystem:
    plugin: str
    params: dict[str, str]
    joints: list[MockJoint]
    sensors: list[tuple[str, list[str], list[float]]]   # (name, state interfaces, initial values)

    @property
    def simulated(self) -> bool:
        """True when a simulator is the hardware (the <hardware> plugin is Gazebo's)."""
        return self.plugin in SIMULATOR_PLUGINS

    def flag(self, name: str) -> bool:
        return self.params.get(name, "").strip().lower() in _TRUE


def _number(text: str | None, what: str) -> float:
    try:
        value = float((text or "").strip())
    except ValueError:
        raise UrdfError(f"{what}: '{text}' is not a number") from None
    if not math.isfinite(value):
        raise UrdfError(f"{what}: '{text}' is not finite")
    return value


def read_system(urdf: str) -> MockSystem:
    """The ``<ros2_control>`` of a robot description: hardware plugin and params, joints, sensors."""
    model = parse_urdf(urdf)
    try:
        root = parse_xml(urdf)
    except (UnsafeXmlError, ValueError) as exc:
        raise UrdfError(str(exc)) from None
    blocks = root.findall("ros2_control")
    if not blocks:
        raise UrdfError(f"robot '{model.name}' has no <ros2_control> block: ros2_control_node has no hardware")
    plugin, params = "", {}
    joints: list[MockJoint] = []
    sensors: list[tuple[str, list[str], list[float]]] = []
    for block in blocks:
        hardware = block.find("hardware")
        if hardware is not None:
            plugin = plugin or (hardware.findtext("plugin") or "").strip()
            params.update({p.get("name", ""): (p.text or "").strip() for p in hardware.findall("param")})
        for element in block.findall("joint"):
            name = element.get("name", "")
            urdf_joint = model.joints.get(name)
            if urdf_joint is None:
                raise UrdfError(f"<ros2_control> joint '{name}' is not a joint of robot '{model.name}'")
            joint = MockJoint(name, [c.get("name", "") for c in element.findall("command_interface")],
                              [s.get("name", "") for s in element.findall("state_interface")])
            for state in element.findall("state_interface"):
                initial = next((p.text for p in state.findall("param") if p.get("name") == "initial_value"), None)
                joint.values[state.get("name", "")] = _number(initial, f"joint '{name}' initial_value") \
                    if initial is not None else 0.0
            if urdf_joint.lower is not None and urdf_joint.upper is not None:
                joint.limits = (urdf_joint.lower, urdf_joint.upper)
            joint.max_velocity = urdf_joint.velocity or 0.0
            joint.max_effort = urdf_joint.effort or 0.0
            joints.append(joint)
        for element in block.findall("sensor"):
            names = [s.get("name", "") for s in element.findall("state_interface")]
            initial = [_number(next((p.text for p in s.findall("param") if p.get("name") == "initial_value"), "0"),
                               f"sensor '{element.get('name')}' initial_value")
                       for s in element.findall("state_interface")]
            sensors.append((element.get("name", ""), names, initial))
    return MockSystem(plugin, params, joints, sensors)


class MockHardware(Node):
    """GenericSystem hardware for the controller manager in the same namespace."""

    default_name = "mock_hardware"

    def __init__(self, system: MockSystem, update_rate: float, robot_name: str = "robot", **kwargs: Any) -> None:
        super().__init__(self.default_name, **kwargs)
        self.system = system
        self.robot_name = robot_name
        self.period = 1.0 / update_rate
        self.dynamics = system.flag("calculate_dynamics")
        self.lock = threading.Lock()
        self.step = 0
        self.names = [j.name for j in system.joints]
        self.state_pub = self.create_publisher(HardwareState, "hardware/state", express=True)
        self.create_subscription(HardwareCommand, "hardware/command", self.on_command)
        self.create_service(GetHardwareInfo, "hardware/info", self.on_info)
        self.timer = self.create_timer(self.period, self.tick, sim_time=False)
        extra = ", mock_sensor_commands (sensor values stay at their initial_value)" \
            if system.flag("mock_sensor_commands") else ""
        self.logger.info(f"mock_components/GenericSystem: {len(self.names)} joints, {len(system.sensors)} sensors "
                         f"at {update_rate:g} Hz, commands mirrored to states"
                         f"{', calculate_dynamics' if self.dynamics else ''}{extra}")

    def on_info(self, _request: Any) -> Any:
        joints = [HardwareJoint(name=j.name, command_interfaces=list(j.commands), state_interfaces=list(j.states),
                                min_position=j.limits[0], max_position=j.limits[1], max_velocity=j.max_velocity,
                                max_effort=j.max_effort) for j in self.system.joints]
        sensors = [HardwareSensor(name=name, type="", frame_id="", state_interfaces=list(states))
                   for name, states, _ in self.system.sensors]
        return GetHardwareInfo.Response(robot_name=self.robot_name, mode="realtime", physics_rate=1.0 / self.period,
                                        joints=joints, sensors=sensors)

    def on_command(self, command: Any) -> None:
        by_name = {j.name: j for j in self.system.joints}
        with self.lock:
            for name, interface, value in zip(command.name, command.interface, command.value):
                joint = by_name.get(name)
                if joint is None or interface not in joint.commands or not math.isfinite(value):
                    continue
                if self.dynamics and interface == "position":
                    old = joint.values.get("position", 0.0)
                    joint.values["velocity"] = (value - old) / self.period
                if self.dynamics and interface == "velocity":
                    joint.values["velocity"] = value
                    continue  # integrated each period
                joint.values[interface] = value

    def tick(self) -> None:
        with self.lock:
            if self.dynamics:
                for joint in self.system.joints:
                    if "velocity" in joint.commands:
                        joint.values["position"] = joint.values.get("position", 0.0) + \
                            joint.values.get("velocity", 0.0) * self.period
            self.step += 1
            state = HardwareState(
                step=self.step, stamp=msgs.time_from_sec(time.time()), name=list(self.names),
                position=[j.values.get("position", 0.0) for j in self.system.joints],
                velocity=[j.values.get("velocity", 0.0) for j in self.system.joints],
                effort=[j.values.get("effort", 0.0) for j in self.system.joints],
                sensor_values=[v for _, _, values in self.system.sensors for v in values])
        self.state_pub.publish(state)
