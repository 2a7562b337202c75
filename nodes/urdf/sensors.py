"""Sensors declared in a URDF, as their users declare them for ros2_control and Gazebo.

Two places describe one sensor, matched by name as gazebo_ros2_control matches them:

- ``<ros2_control><sensor name="imu_sensor">`` lists the state interfaces a controller may read
  (``orientation.x`` ... ``linear_acceleration.z`` for an IMU, ``force.x`` ... ``torque.z`` for a
  force/torque sensor) and ``<param>``s;
- ``<gazebo reference="LINK_OR_JOINT"><sensor name="imu_sensor" type="imu|force_torque|contact">`` says where
  it is and how it measures: ``update_rate``, ``always_on``, ``pose``, ``<imu>`` noise per axis,
  ``<force_torque>`` ``frame`` and ``measure_direction``, ``<contact>``.

``parse_sensors`` reads both (refusing only what it cannot represent: text where a number belongs);
``sensor_problems`` checks what the simulator relies on and returns each problem with the sensor and the field
named: a reference that is neither a link nor a joint, an interface not in the type's list, an update rate
that is not positive or absurd, a negative noise deviation, a ros2_control sensor no Gazebo sensor describes.
"""

from __future__ import annotations

import math
from collections.abc import Container
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from lxml import etree

from nodes.urdf.rotation import rpy_matrix

IMU_INTERFACES = ("orientation.x", "orientation.y", "orientation.z", "orientation.w",
                  "angular_velocity.x", "angular_velocity.y", "angular_velocity.z",
                  "linear_acceleration.x", "linear_acceleration.y", "linear_acceleration.z")
FORCE_TORQUE_INTERFACES = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")
# The state interfaces of each sensor type this module simulates (a contact sensor has none in ros2_control).
SENSOR_INTERFACES: dict[str, tuple[str, ...]] = {
    "imu": IMU_INTERFACES, "force_torque": FORCE_TORQUE_INTERFACES, "contact": (),
}
# Gazebo sensor types that other parts of the simulator handle (or none yet): not an error here.
OTHER_SENSOR_TYPES = frozenset({
    "camera", "depth", "depth_camera", "multicamera", "rgbd_camera", "rgbd", "ray", "gpu_ray", "lidar",
    "gpu_lidar", "sonar", "gps", "navsat", "altimeter", "magnetometer", "air_pressure", "thermal_camera",
    "logical_camera", "boundingbox_camera", "segmentation_camera", "rfid", "rfidtag", "wireless_receiver",
    "wireless_transmitter", "transceiver",
})
FT_FRAMES = ("child", "parent", "sensor")
FT_DIRECTIONS = ("child_to_parent", "parent_to_child")
NOISE_TYPES = ("none", "gaussian", "gaussian_quantized")
# Above this a sensor rate is a typo (the physics itself runs at most at 100 kHz).
MAX_UPDATE_RATE = 100_000.0


class SensorDeclarationError(ValueError):
    """Text that cannot be a sensor declaration (a number that is not one); ``line`` when known."""

    def __init__(self, message: str, line: int | None = None) -> None:
        super().__init__(message)
        self.line = line


@dataclass(frozen=True)
class Noise:
    """Gazebo's gaussian noise: ``value + mean + bias + N(0, stddev)``, the bias drawn once from
    N(bias_mean, bias_stddev) with a random sign."""

    type: str = "none"
    mean: float = 0.0
    stddev: float = 0.0
    bias_mean: float = 0.0
    bias_stddev: float = 0.0
    line: int | None = None

    @property
    def active(self) -> bool:
        return self.type != "none" and any((self.mean, self.stddev, self.bias_mean, self.bias_stddev))


# gazebo_ros plugins the simulator runs itself, by the sensor type they belong in, and the topic each
# publishes on before remapping (gazebo_plugins' names: sensor_msgs/Imu, geometry_msgs/WrenchStamped,
# gazebo_msgs/ContactsState)
PLUGINS = {"libgazebo_ros_imu_sensor.so": "imu", "libgazebo_ros_ft_sensor.so": "force_torque",
           "libgazebo_ros_bumper.so": "contact"}
PLUGIN_TOPICS = {"libgazebo_ros_imu_sensor.so": "~/out", "libgazebo_ros_ft_sensor.so": "wrench",
                 "libgazebo_ros_bumper.so": "bumper_states"}


def resolve_topic(namespace: str, node: str, topic: str, remappings: dict[str, str], out_alias: bool = False) -> str:
    """A plugin's topic as ROS 2 resolves it: remapped (by its written or its ``~/`` form; with ``out_alias``,
    ``~/out`` also remaps a sensor plugin's own topic name, as users write it for every sensor plugin), ``~/``
    is the plugin node's name, a relative name goes under the namespace; the key has no leading slash."""
    aliases = ("~/out", "out") if out_alias else ()
    for source in (topic, f"~/{topic}", topic.removeprefix("~/"), *aliases):
        if source in remappings:
            topic = remappings[source]
            break
    if topic.startswith("/"):
        return topic.strip("/")
    if topic.startswith("~/"):
        topic = f"{node}/{topic[2:]}"
    namespace = namespace.strip("/")
    return f"{namespace}/{topic}" if namespace else topic


@dataclass
class GazeboRosPlugin:
    """A gazebo_ros sensor plugin: publishes the sensor on its topic (``PLUGIN_TOPICS``) of a node named
    after the plugin, in its ``<ros><namespace>`` (else the robot's, as spawn_entity's -robot_namespace
    sets it), unless a ``<remapping>`` says otherwise."""

    filename: str
    name: str
    namespace: str = ""
    remappings: dict[str, str] = field(default_factory=dict)
    frame_name: str = ""       # header.frame_id; the sensor's link when empty

    def key(self, robot_namespace: str = "") -> str:
        """The Zenoh key it publishes on (a ROS name without the leading slash)."""
        return resolve_topic(self.namespace or robot_namespace, self.name, PLUGIN_TOPICS[self.filename],
                             self.remappings, out_alias=True)


@dataclass
class Ros2ControlSensor:
    """``<ros2_control><sensor>``: its state interfaces and params."""

    name: str
    state_interfaces: list[str]
    params: dict[str, str] = field(default_factory=dict)
    line: int | None = None


@dataclass
class SensorSpec:
    """One sensor: the Gazebo declaration, merged with its ros2_control entry (if any) by the checks."""

    name: str
    type: str
    reference: str                      # the <gazebo reference> (a link, or a joint for force_torque)
    update_rate: float | None = None    # Hz; None: every control period
    always_on: bool = True
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))   # sensor frame in the link frame
    frame: str = "child"                # force_torque: the frame the wrench is expressed in
    measure_direction: str = "child_to_parent"
    noise: dict[str, Noise] = field(default_factory=dict)   # by channel: "angular_velocity.x", "force.z", ...
    collision: str = ""                 # contact: the <contact><collision> name (informative)
    plugin: GazeboRosPlugin | None = None   # a gazebo_ros plugin publishing it without ros2_control
    line: int | None = None
    update_rate_text: str | None = None   # as written, for the checks' messages
    # filled by the checks:
    link: str = ""                      # the link it is attached to (F/T: the child link of its joint)
    joint: str = ""                     # force_torque: the measured joint
    parent_link: str = ""               # force_torque: the parent link of that joint
    state_interfaces: list[str] = field(default_factory=list)   # from <ros2_control>; empty: not in ros2_control
    params: dict[str, str] = field(default_factory=dict)


def sensor_where(sensor_name: str, line: int | None) -> str:
    if len(sensor_name) <= 60:
        shown = f"'{sensor_name}'"
    else:
        from nodes.core import names  # here: the launcher checks robots without importing Zenoh

        shown = names.shown(sensor_name)
    return f"sensor {shown}" + (f" (line {line})" if line else "")


def plugin_name_problems(where: str, node: str, namespace: str, remappings: dict[str, str],
                         frame: str = "") -> list[str]:
    """The names a gazebo_ros plugin writes, each checked as ROS checks it: its node name, its
    ``<ros><namespace>``, both sides of each ``<remapping>``, its ``<frame_name>``."""
    from nodes.core import names  # here: the launcher checks robots without importing Zenoh

    problems = []
    if (problem := names.node_name_problem(node)) is not None:
        problems.append(f"{where} <plugin name> {names.shown(node)}: {problem}")
    if namespace and (problem := names.namespace_problem(namespace)) is not None:
        problems.append(f"{where} <plugin> <ros><namespace> {names.shown(namespace)}: {problem}")
    for source, target in remappings.items():
        for side, name in (("from", source), ("to", target)):
            if (problem := names.topic_problem(name)) is not None:
                problems.append(f"{where} <plugin> <remapping> {names.shown(f'{source}:={target}')}: {side} "
                                f"{names.shown(name, 40)} {problem}")
                break
    if frame and (problem := names.frame_problem(frame)) is not None:
        problems.append(f"{where} <plugin> <frame_name> {names.shown(frame)}: {problem}")
    return problems


def parse_number(text: str | None, what: str, line: int | None) -> float:
    try:
        value = float((text or "").strip())
    except ValueError:
        raise SensorDeclarationError(f"{what}: '{(text or '').strip()[:80]}' is not a number", line) from None
    if math.isnan(value):
        raise SensorDeclarationError(f"{what} is NaN", line)
    return value


def parse_flag(text: str | None, what: str, line: int | None) -> bool:
    value = (text or "").strip().lower()
    if value in ("1", "true"):
        return True
    if value in ("0", "false"):
        return False
    raise SensorDeclarationError(f"{what}: '{value[:80]}' is not true/false/1/0", line)


def child_text(element: etree._Element, path: str) -> str | None:
    found = element.find(path)
    return None if found is None else (found.text or "").strip()


def parse_pose(text: str, what: str, line: int | None) -> np.ndarray:
    parts = text.split()
    if len(parts) != 6:
        raise SensorDeclarationError(f"{what}: '{text[:80]}' needs 6 numbers (x y z roll pitch yaw)", line)
    values = [parse_number(p, what, line) for p in parts]
    if not all(math.isfinite(v) for v in values):
        raise SensorDeclarationError(f"{what}: '{text[:80]}' is not finite", line)
    transform = np.eye(4)
    transform[:3, 3] = values[:3]
    transform[:3, :3] = rpy_matrix(*values[3:])
    return transform


def parse_noise(element: etree._Element, what: str) -> Noise:
    line = element.sourceline
    kind = (element.get("type") or child_text(element, "type") or "gaussian").strip()
    numbers = {}
    for key in ("mean", "stddev", "bias_mean", "bias_stddev"):
        text = child_text(element, key)
        if text is not None:
            numbers[key] = parse_number(text, f"{what} <{key}>", line)
    return Noise(kind, line=line, **numbers)


def naming_problem(name: str, where: str, taken: Container[str]) -> str | None:
    """Why a ``<sensor>`` cannot be told apart from the robot's others (no name, or a name already taken), or None."""
    if not name:
        return f"{where}: <sensor> has no name attribute"
    if name in taken:
        return f"{where}: a second sensor named '{name}'"
    from nodes.core import names  # here: the launcher checks robots without importing Zenoh

    if (problem := names.node_name_problem(name)) is not None:
        return f"{where}: <sensor name> {problem}"
    return None


def read_sensor_basics(element: etree._Element, spec: Any, where: str, line: int | None) -> None:
    """What every ``<sensor>`` may carry, Gazebo's way: ``<update_rate>``, ``<always_on>`` and ``<pose>``,
    written onto ``spec`` (a body sensor's or a rendered sensor's); a bad value names the sensor and line."""
    rate_text = child_text(element, "update_rate")
    if rate_text is not None:
        spec.update_rate_text = rate_text
        spec.update_rate = parse_number(rate_text, f"{where} <update_rate>", line)
    always_on = child_text(element, "always_on")
    if always_on is not None:
        spec.always_on = parse_flag(always_on, f"{where} <always_on>", line)
    pose = child_text(element, "pose")
    if pose:
        spec.pose = parse_pose(pose, f"{where} <pose>", line)


def _parse_gazebo_sensor(element: etree._Element, reference: str) -> SensorSpec | None:
    name = element.get("name") or ""
    kind = element.get("type") or ""
    line = element.sourceline
    where = sensor_where(name, line)
    if kind in OTHER_SENSOR_TYPES:
        return None
    spec = SensorSpec(name=name, type=kind, reference=reference, line=line)
    read_sensor_basics(element, spec, where, line)
    if kind == "imu":
        imu = element.find("imu")
        if imu is not None:
            for quantity in ("angular_velocity", "linear_acceleration"):
                for axis in "xyz":
                    noise = imu.find(f"{quantity}/{axis}/noise")
                    if noise is not None:
                        spec.noise[f"{quantity}.{axis}"] = parse_noise(noise, f"{where} <imu><{quantity}><{axis}><noise>")
    elif kind == "force_torque":
        ft = element.find("force_torque")
        shared = element.find("noise")
        if ft is not None:
            spec.frame = child_text(ft, "frame") or spec.frame
            spec.measure_direction = child_text(ft, "measure_direction") or spec.measure_direction
            shared = ft.find("noise") if ft.find("noise") is not None else shared
        if shared is not None:   # one <noise> for all six axes (Gazebo Classic's)
            noise = parse_noise(shared, f"{where} <noise>")
            for channel in FORCE_TORQUE_INTERFACES:
                spec.noise[channel] = noise
        if ft is not None:
            for quantity in ("force", "torque"):
                for axis in "xyz":
                    noise = ft.find(f"{quantity}/{axis}/noise")
                    if noise is not None:
                        spec.noise[f"{quantity}.{axis}"] = parse_noise(
                            noise, f"{where} <force_torque><{quantity}><{axis}><noise>")
    elif kind == "contact":
        spec.collision = child_text(element, "contact/collision") or ""
    for plugin in element.findall("plugin"):
        filename = plugin.get("filename") or ""
        if filename in PLUGINS:
            remappings = {}
            for remap in plugin.findall("ros/remapping"):
                source, sep, target = (remap.text or "").strip().partition(":=")
                if not sep or not source or not target:
                    raise SensorDeclarationError(f"{where} <plugin> <remapping> '{(remap.text or '')[:80]}' is not "
                                                 "from:=to", remap.sourceline)
                remappings[source] = target
            spec.plugin = GazeboRosPlugin(filename, plugin.get("name") or filename.removesuffix(".so"),
                                          child_text(plugin, "ros/namespace") or "", remappings,
                                          child_text(plugin, "frame_name") or "")
    return spec


def parse_ros2_control_sensors(root: etree._Element) -> list[Ros2ControlSensor]:
    """The ``<sensor>`` entries of every ``<ros2_control>`` block."""
    out = []
    for block in root.findall("ros2_control"):
        for element in block.findall("sensor"):
            out.append(Ros2ControlSensor(
                element.get("name", ""), [si.get("name", "") for si in element.findall("state_interface")],
                {p.get("name", ""): (p.text or "").strip() for p in element.findall("param")}, element.sourceline))
    return out


def parse_gazebo_sensors(root: etree._Element) -> list[SensorSpec]:
    """The ``<sensor>`` elements of every ``<gazebo reference=...>`` block (types other code handles skipped)."""
    out = []
    for block in root.findall("gazebo"):
        reference = block.get("reference") or ""
        for element in block.findall("sensor"):
            spec = _parse_gazebo_sensor(element, reference)
            if spec is not None:
                out.append(spec)
    return out


def _rate_problem(spec: SensorSpec) -> str | None:
    rate = spec.update_rate
    if rate is None:
        return None
    if not math.isfinite(rate) or rate <= 0:
        return (f"{sensor_where(spec.name, spec.line)} <update_rate> {spec.update_rate_text}: must be a positive number "
                "of Hz (leave it out to sample every control period)")
    if rate > MAX_UPDATE_RATE:
        return (f"{sensor_where(spec.name, spec.line)} <update_rate> {spec.update_rate_text}: over {MAX_UPDATE_RATE:g} Hz, "
                "faster than any physics rate")
    return None


def _noise_problems(spec: SensorSpec) -> list[str]:
    problems = []
    for channel, noise in spec.noise.items():
        where = f"{sensor_where(spec.name, noise.line or spec.line)} noise of {channel}"
        if noise.type not in NOISE_TYPES:
            problems.append(f"{where}: type '{noise.type}' is not one of {', '.join(NOISE_TYPES)}")
        for key in ("stddev", "bias_stddev"):
            value = getattr(noise, key)
            if value < 0:
                problems.append(f"{where}: <{key}> {value:g} must not be negative")
        for key in ("mean", "stddev", "bias_mean", "bias_stddev"):
            if math.isinf(getattr(noise, key)):
                problems.append(f"{where}: <{key}> must be finite")
    return problems


def sensor_problems(gazebo: list[SensorSpec], ros2_control: list[Ros2ControlSensor], links: dict,
                    joints: dict) -> list[str]:
    """Check the declarations and complete the specs (link, joint, ros2_control interfaces); every problem
    found, each naming the sensor and the field. ``links``/``joints`` are the model's (by name)."""
    problems: list[str] = []
    by_name: dict[str, SensorSpec] = {}
    parent_joint = {j.child: j for j in joints.values()}
    for spec in gazebo:
        where = sensor_where(spec.name, spec.line)
        if (problem := naming_problem(spec.name, where, by_name)) is not None:
            problems.append(problem)
            continue
        if spec.type not in SENSOR_INTERFACES:
            problems.append(f"{where}: type '{spec.type}' is not one of {', '.join(SENSOR_INTERFACES)}")
            continue
        if spec.reference in links:
            spec.link = spec.reference
            if spec.type == "force_torque":   # on a link: the joint that carries it
                joint = parent_joint.get(spec.reference)
                if joint is None:
                    problems.append(f"{where}: <gazebo reference='{spec.reference}'> is the root link: a "
                                    "force_torque sensor measures a joint")
                    continue
                spec.joint, spec.parent_link = joint.name, joint.parent
        elif spec.reference in joints:
            joint = joints[spec.reference]
            if spec.type != "force_torque":
                problems.append(f"{where}: <gazebo reference='{spec.reference}'> is a joint; an {spec.type} sensor "
                                "goes on a link")
                continue
            spec.link, spec.joint, spec.parent_link = joint.child, joint.name, joint.parent
        else:
            problems.append(f"{where}: <gazebo reference='{spec.reference}'> is not a link"
                            f"{' or joint' if spec.type == 'force_torque' else ''} of the robot")
            continue
        if spec.type == "force_torque":
            if spec.frame not in FT_FRAMES:
                problems.append(f"{where} <force_torque><frame> '{spec.frame}' is not one of {', '.join(FT_FRAMES)}")
            if spec.measure_direction not in FT_DIRECTIONS:
                problems.append(f"{where} <force_torque><measure_direction> '{spec.measure_direction}' is not one "
                                f"of {', '.join(FT_DIRECTIONS)}")
        plugin = spec.plugin
        if plugin is not None:
            if PLUGINS[plugin.filename] != spec.type:
                problems.append(f"{where} <plugin filename='{plugin.filename}'> belongs in a "
                                f"{PLUGINS[plugin.filename]} sensor, not {spec.type}")
            problems += plugin_name_problems(where, plugin.name, plugin.namespace, plugin.remappings,
                                             plugin.frame_name)
            frames_allowed = ("world",) if spec.type == "contact" else ()   # the bumper's contacts: world frame
            if plugin.frame_name and plugin.frame_name not in links and plugin.frame_name not in frames_allowed:
                problems.append(f"{where} <plugin> <frame_name> '{plugin.frame_name}' is not a link of the robot (a "
                                "TF frame the state publisher publishes)")
        rate = _rate_problem(spec)
        if rate:
            problems.append(rate)
        problems += _noise_problems(spec)
        by_name[spec.name] = spec
    seen: set[str] = set()
    for control in ros2_control:
        where = f"<ros2_control> {sensor_where(control.name, control.line)}"
        if control.name in seen:
            problems.append(f"{where}: listed twice")
            continue
        seen.add(control.name)
        spec = by_name.get(control.name)
        if spec is None:
            problems.append(f"{where}: no <gazebo reference=...><sensor name='{control.name}'> says where it is and "
                            "what it measures (as gazebo_ros2_control matches them by name)")
            continue
        allowed = SENSOR_INTERFACES[spec.type]
        for interface in control.state_interfaces:
            if interface not in allowed:
                problems.append(f"{where}: state_interface '{interface}' is not one of the {spec.type} interfaces "
                                f"({', '.join(allowed) or 'none'})")
        if not control.state_interfaces and not allowed:
            problems.append(f"{where}: a {spec.type} sensor has no ros2_control state interfaces")
        spec.state_interfaces = list(control.state_interfaces) or list(allowed)
        spec.params = dict(control.params)
    return problems
