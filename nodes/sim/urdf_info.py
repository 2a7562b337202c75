"""What the simulator needs to know from a URDF before handing it to DART.

DART's loader prints warnings and returns None on bad input; parsing the XML first with the project's URDF
parser (``nodes.urdf.model``: entity declarations and external DTDs are refused, every number is checked) lets
every error name the line it comes from, and gives us the joint limits and the ``<ros2_control>`` block, which
DART ignores. This module adds what only the simulator refuses (negative sizes, mesh files that resolve nowhere, interface
names other than position/velocity/effort) and the derived per-joint bounds.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, field

import numpy as np
from lxml import etree

from nodes.control.interfaces import JointInfo
from nodes.urdf.control_setup import with_control_block
from nodes.urdf.frames import Lumped, check_inertias, lump_frames
from nodes.urdf.model import Joint, RobotModel, UrdfError
from nodes.urdf.model import parse_urdf as parse_model
from nodes.urdf.paths import PathError, resolve_uri
from nodes.urdf.rendered_sensors import RenderedSensorSpec, rendered_sensor_problems
from nodes.urdf.sensors import SensorSpec, sensor_problems
from nodes.urdf.xml_safety import parse_xml

INTERFACES = ("position", "velocity", "effort")


@dataclass
class RobotInfo:
    name: str
    root_link: str
    links: list[str]
    joints: list[JointInfo]            # movable joints, URDF order
    has_ros2_control: bool = False
    sensors: list[SensorSpec] = field(default_factory=list)   # checked, with their links and joints
    rendered_sensors: list[RenderedSensorSpec] = field(default_factory=list)   # cameras and range sensors
    # what the physics loads: frame links merged into their bodies (sensors above already moved onto them)
    physics: Lumped | None = None
    model: RobotModel | None = None                 # the URDF as written (every link, TF's frames)
    warnings: list[str] = field(default_factory=list)   # for the spawn's log: what was tolerated, and how

    @property
    def frames(self) -> list[str]:
        """Links merged into their parent body for the physics."""
        return list(self.physics.frames) if self.physics else []

    def joint(self, name: str) -> JointInfo:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(name)


def _error(line: int | None, message: str) -> UrdfError:
    """A UrdfError whose message starts with ``line N:`` when the line is known."""
    return UrdfError(f"line {line}: {message}" if line else message, line)


# DART's URDF loading time grows much faster than the link count (measured: 100 links 0.05 s, 200 links
# 0.5 s, 400 links 9.6 s, 10,000 links a crash), and the simulator serves nothing while it loads: a model
# beyond this is refused before DART sees it. Humanoids have 20-40 links.
MAX_LINKS = 128
# Sensors of one robot (IMU, force/torque, contact, cameras, range sensors): each is sampled or rendered every
# period of its own, so their number is work every step (the shipped humanoid has 8)
MAX_SENSORS = 64


def _check_size(model: RobotModel) -> None:
    if len(model.links) > MAX_LINKS:
        raise _error(model.line, f"robot {model.name!r} has {len(model.links)} links, over the simulator's limit "
                                 f"of {MAX_LINKS}")
    if len(model.joints) > MAX_LINKS:
        raise _error(model.line, f"robot {model.name!r} has {len(model.joints)} joints, over the simulator's "
                                 f"limit of {MAX_LINKS}")


def _check_shapes(model: RobotModel, base: str | None) -> dict[str, str]:
    """Sizes and masses DART cannot use (negative ones) and mesh files that resolve nowhere or outside their
    package (``nodes.urdf.paths``); returns each mesh reference with the file it resolves to."""
    meshes: dict[str, str] = {}
    for link in model.links.values():
        if link.inertial is not None and link.inertial.mass < 0:
            raise _error(link.inertial.line, f"<mass> value={link.inertial.mass:g} of link {link.name!r} "
                                             "must not be negative")
        visuals = {id(shape) for shape in link.visuals}
        for shape in (*link.visuals, *link.collisions):
            sizes = {"box": {"size": shape.size}, "cylinder": {"radius": (shape.radius,), "length": (shape.length,)},
                     "sphere": {"radius": (shape.radius,)}}.get(shape.kind, {})
            for attr, values in sizes.items():
                if any(v < 0 for v in values):
                    raise _error(shape.line, f"<{shape.kind}> {attr}={' '.join(f'{v:g}' for v in values)!r} "
                                             f"of link {link.name!r} must not be negative")
            if shape.kind == "mesh" and shape.filename not in meshes:
                try:
                    meshes[shape.filename] = str(resolve_uri(shape.filename, base))
                except PathError as exc:
                    if id(shape) in visuals and "does not exist" in str(exc):
                        continue   # a missing visual mesh: drawn without it, with a warning (nodes.meshes.urdf)
                    raise _error(shape.line, f"mesh of link {link.name!r}: {exc}") from None
    return meshes


def _joint_info(joint: Joint) -> JointInfo:
    info = JointInfo(name=joint.name, type=joint.type)
    if joint.lower is not None and joint.upper is not None:  # revolute/prismatic (never continuous)
        info.min_position, info.max_position = joint.lower, joint.upper
        if joint.lower > joint.upper:
            raise _error(joint.line, f"joint {joint.name!r} lower limit {joint.lower} > upper {joint.upper}")
    # URDF: velocity/effort <= 0 or absent means "no limit" in practice
    if joint.velocity is not None and joint.velocity > 0:
        info.max_velocity = joint.velocity
    if joint.effort is not None and joint.effort > 0:
        info.max_effort = joint.effort
    return info


_LINK_TAG = re.compile(r"<link[\s/>]")
_SENSOR_TAG = re.compile(r"<sensor[\s/>]")


def parse_urdf(xml: str, base: str | None = None) -> RobotInfo:
    """Parse and check a URDF string; raises ``UrdfError`` naming the offending line. ``base``: the robot's
    file (a path or ``file://`` URI), where its relative mesh paths and its own package start."""
    if not isinstance(xml, str) or not xml.strip():
        raise UrdfError("empty robot description")
    # before building anything of a huge model (parsing 10,000 links costs ~80 MB that is never returned)
    links = len(_LINK_TAG.findall(xml))
    if links > MAX_LINKS:
        raise UrdfError(f"the robot description has {links} <link> elements, over the simulator's limit of "
                        f"{MAX_LINKS}")
    # a sensor is declared twice at most (<gazebo> and <ros2_control>): count before parsing thousands of them
    sensors = len(_SENSOR_TAG.findall(xml))
    if sensors > 2 * MAX_SENSORS:
        raise UrdfError(f"the robot description has {sensors} <sensor> elements, over the simulator's limit of "
                        f"{MAX_SENSORS} sensors a robot")
    try:
        model = parse_model(xml)
        generated = not model.ros2_control
        if generated:   # the block zenroid setup_robot writes (nodes.urdf.control_setup): what runs is what is written
            xml = with_control_block(xml, model)
            model = parse_model(xml)
    except UrdfError as exc:
        raise _error(exc.line, str(exc)) from None
    _check_size(model)
    declared = len(model.sensors) + len(model.rendered_sensors)
    if declared > MAX_SENSORS:
        raise _error(model.line, f"robot {model.name!r} has {declared} sensors, over the simulator's limit of "
                                 f"{MAX_SENSORS} sensors a robot")
    meshes = _check_shapes(model, base)
    for (kind, name), line in model.duplicate_lines.items():
        raise _error(line, f"duplicate {kind} {name!r}")

    children: set[str] = set()
    joints: list[JointInfo] = []
    for joint in model.joints.values():
        for tag, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in model.links:
                raise _error(joint.line, f"joint {joint.name!r} <{tag}> link {link!r} is not a link of the robot")
        children.add(joint.child)
        if joint.movable:
            joints.append(_joint_info(joint))

    roots = [link for link in model.links if link not in children]
    if len(roots) != 1:
        raise _error(model.line, f"robot {model.name!r} must have exactly one root link, found {roots}")

    _apply_ros2_control(model, joints)
    has_block = not generated
    problems = sensor_problems(model.sensors, model.ros2_control_sensors, model.links, model.joints)
    problems += rendered_sensor_problems(model.rendered_sensors, model.links, taken={s.name for s in model.sensors})
    if problems:
        shown = problems[:5] + ([f"... and {len(problems) - 5} more"] if len(problems) > 5 else [])
        raise UrdfError("; ".join(shown))
    check_inertias(model)
    physics = lump_frames(xml, model)
    if meshes:
        physics.xml = _with_files(physics.xml, meshes)
    sensors, rendered = _mount_on_bodies(model, physics)
    warnings = list(model.warnings)
    if generated and (joints or model.ros2_control_sensors):   # a prop or a camera tripod has nothing to control
        warnings.append(f"no <ros2_control> block: generated one ({len(joints)} joints: position command, "
                        "position and velocity states; python -m nodes.tools.cli setup_robot FILE -o DIR writes it)")
    if physics.frames:
        warnings.append(f"{len(physics.frames)} link(s) without a usable inertia on fixed joints are frames, "
                        f"merged into their parent body for the physics (kept as TF frames and sensor mounts): "
                        f"{', '.join(physics.frames)}")
    return RobotInfo(name=model.name, root_link=roots[0], links=list(model.links), joints=joints,
                     has_ros2_control=has_block, sensors=sensors, rendered_sensors=rendered, physics=physics,
                     model=model, warnings=warnings)


def _with_files(xml: str, meshes: dict[str, str]) -> str:
    """The URDF with every mesh reference replaced by the file it resolved to (what DART loads)."""
    root = parse_xml(xml)
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "")
        if filename in meshes:
            mesh.set("filename", meshes[filename])
    return etree.tostring(root, encoding="unicode")


def _mount_on_bodies(model: RobotModel, physics: Lumped) -> tuple[list[SensorSpec], list[RenderedSensorSpec]]:
    """Sensors on a merged frame sit on the body that carries it, at the frame's pose in that body."""
    if not physics.frames:
        return model.sensors, model.rendered_sensors
    sensors = []
    for sensor in model.sensors:
        if sensor.link in physics.frames:
            if sensor.type == "force_torque":
                raise _error(sensor.line, f"force/torque sensor {sensor.name!r} measures joint {sensor.joint!r}, "
                                          f"whose link {sensor.link!r} has no inertia and is merged into its "
                                          "parent: give the link an <inertial>")
            body, pose = physics.body_of(sensor.link)
            sensor = dataclasses.replace(sensor, link=body, pose=np.asarray(pose @ sensor.pose))
        sensors.append(sensor)
    rendered = []
    for spec in model.rendered_sensors:
        if spec.reference in physics.frames:
            body, pose = physics.body_of(spec.reference)
            spec = dataclasses.replace(spec, reference=body, pose=np.asarray(pose @ spec.pose),
                                       frame_id=spec.frame_id or spec.reference)
        rendered.append(spec)
    return sensors, rendered


def _apply_ros2_control(model: RobotModel, joints: list[JointInfo]) -> bool:
    """Interfaces from ``<ros2_control>``: joints it does not list become passive (no command interface)."""
    if not model.ros2_control:
        return False
    by_name = {joint.name: joint for joint in joints}
    for joint in joints:
        joint.command_interfaces = []
    for control in model.ros2_control:
        joint = by_name.get(control.name)
        if joint is None:
            raise _error(control.line, f"<ros2_control> joint {control.name!r} is not a movable joint of the robot")
        for kind, interfaces in (("command_interface", control.command_interfaces),
                                 ("state_interface", control.state_interfaces)):
            for interface in interfaces:
                if interface not in INTERFACES:
                    raise _error(control.line, f"joint {control.name!r} {kind} {interface!r} "
                                               f"is not one of {', '.join(INTERFACES)}")
        joint.command_interfaces = list(control.command_interfaces)
        joint.command_bounds.update(control.bounds)
        joint.state_interfaces = list(control.state_interfaces) or list(INTERFACES)
    return True
