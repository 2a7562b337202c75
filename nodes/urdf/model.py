"""A small, strict URDF model: links (inertial, visual and collision geometry, material colours), joints,
mimic and the ``<ros2_control>`` block. The one URDF parser of the project: the state publisher, the URDF tools,
the viewer and the simulator all build on it, so every description goes through the XML safety check.

Why our own parser (and not only yourdfpy): the CLI must report *why* a broken file is broken (missing links,
bad numbers, limits), the input may be untrusted (entity attacks), and the kinematics code needs exactly the
joint origins/axes/mimic data in plain numpy form. Structural checks live in ``validate``; this module only
refuses what it cannot represent (bad numbers, unknown joint types, missing required elements). Elements carry
their source ``line`` so a consumer (the simulator) can point at the offending line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from lxml import etree

from nodes.core import names
from nodes.urdf.rendered_sensors import RenderedSensorSpec, parse_rendered_sensors
from nodes.urdf.rotation import rpy_matrix
from nodes.urdf.sensors import (
    Ros2ControlSensor,
    SensorDeclarationError,
    SensorSpec,
    parse_gazebo_sensors,
    parse_ros2_control_sensors,
)
from nodes.urdf.xml_safety import UnsafeXmlError, parse_xml

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
MOVABLE_TYPES = ("revolute", "continuous", "prismatic")
GEOMETRY_KINDS = ("box", "cylinder", "sphere", "mesh")
DEFAULT_RGBA = (0.7, 0.7, 0.7, 1.0)  # a visual without a usable material (RViz's grey)


class UrdfError(ValueError):
    """The robot description cannot be parsed; the message names the element and the reason.

    ``line`` is the source line of the offending element when known (None otherwise).
    """

    def __init__(self, message: str, line: int | None = None) -> None:
        super().__init__(message)
        self.line = line


@dataclass
class Inertial:
    mass: float
    origin: np.ndarray  # 4x4, centre of mass frame in the link frame
    inertia: np.ndarray  # 3x3 symmetric, about the centre of mass
    line: int | None = None  # of the <mass> element


@dataclass(frozen=True)
class Shape:
    """The geometry of a ``<visual>`` or ``<collision>``: ``kind`` is box / cylinder / sphere / mesh (metres)."""

    kind: str
    origin: np.ndarray  # 4x4, shape frame in the link frame
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)  # box
    radius: float = 0.0  # cylinder, sphere
    length: float = 0.0  # cylinder
    filename: str = ""  # mesh
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  # mesh
    line: int | None = None  # of the shape element (<box>, <mesh>, ...)


@dataclass(frozen=True)
class Visual(Shape):
    rgba: tuple[float, float, float, float] = DEFAULT_RGBA  # inline <color>, else the named material, else grey
    material: str | None = None  # the material's name, if any


@dataclass(frozen=True)
class Collision(Shape):
    pass


@dataclass
class Link:
    name: str
    inertial: Inertial | None = None
    has_visual: bool = False
    has_collision: bool = False
    visuals: list[Visual] = field(default_factory=list)
    collisions: list[Collision] = field(default_factory=list)
    line: int | None = None


@dataclass
class Mimic:
    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass
class Joint:
    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray  # 4x4 parent link frame -> joint frame at q = 0
    axis: np.ndarray  # unit 3-vector in the joint frame
    lower: float | None = None
    upper: float | None = None
    effort: float | None = None
    velocity: float | None = None
    mimic: Mimic | None = None
    line: int | None = None

    @property
    def movable(self) -> bool:
        return self.type in MOVABLE_TYPES


@dataclass
class Ros2ControlJoint:
    name: str
    command_interfaces: list[str]
    state_interfaces: list[str]
    params: dict[str, dict[str, str]] = field(default_factory=dict)  # interface -> {param: value}
    # <param name="min|max"> of each command interface as numbers (absent side = -inf / +inf)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    line: int | None = None


@dataclass
class RobotModel:
    name: str
    links: dict[str, Link]
    joints: dict[str, Joint]
    ros2_control: list[Ros2ControlJoint] = field(default_factory=list)
    duplicate_links: list[str] = field(default_factory=list)
    duplicate_joints: list[str] = field(default_factory=list)
    materials: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)  # top-level, with colour
    line: int | None = None  # of <robot>
    duplicate_lines: dict[tuple[str, str], int | None] = field(default_factory=dict)  # ("link"|"joint", name)
    # sensors as declared (nodes.urdf.sensors): <gazebo reference><sensor> and <ros2_control><sensor>
    sensors: list[SensorSpec] = field(default_factory=list)
    ros2_control_sensors: list[Ros2ControlSensor] = field(default_factory=list)
    # cameras and range sensors (nodes.urdf.rendered_sensors), their keys resolved without a namespace
    rendered_sensors: list[RenderedSensorSpec] = field(default_factory=list)
    # what ROS tools tolerate and we drop with a word (a sensor declared twice in one <gazebo> block)
    warnings: list[str] = field(default_factory=list)

    def roots(self) -> list[str]:
        children = {j.child for j in self.joints.values()}
        return [name for name in self.links if name not in children]

    @property
    def root(self) -> str:
        roots = self.roots()
        if len(roots) != 1:
            raise UrdfError(f"robot '{self.name}' has {len(roots)} root links ({', '.join(roots) or 'none'})")
        return roots[0]

    def children_of(self, link: str) -> list[Joint]:
        return [j for j in self.joints.values() if j.parent == link]

    def movable_joints(self) -> list[Joint]:
        return [j for j in self.joints.values() if j.movable]

    def total_mass(self) -> float:
        return sum(link.inertial.mass for link in self.links.values() if link.inertial)

    def leaf_links(self) -> list[str]:
        """Links that are no joint's parent: hands, feet, head (default end-effectors)."""
        parents = {j.parent for j in self.joints.values()}
        return [name for name in self.links if name not in parents]

    def visual_links(self) -> list[str]:
        return [name for name, link in self.links.items() if link.visuals]


def _where(element: etree._Element) -> str:
    tag = element.tag
    name = element.get("name")
    line = f" (line {element.sourceline})" if element.sourceline else ""
    return f"<{tag} name='{name}'>{line}" if name is not None else f"<{tag}>{line}"


def _floats(element: etree._Element, attribute: str, count: int, default: str | None, owner: str) -> list[float]:
    text = element.get(attribute, default)
    line = element.sourceline
    if text is None:
        raise UrdfError(f"{owner}: <{element.tag}> is missing attribute '{attribute}'", line)
    parts = text.split()
    if len(parts) != count:
        raise UrdfError(
            f"{owner}: <{element.tag} {attribute}='{text}'> needs {count} number(s), got {len(parts)}", line)
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise UrdfError(f"{owner}: <{element.tag} {attribute}='{text}'> is not a number", line) from None
    if not all(math.isfinite(v) for v in values):
        raise UrdfError(f"{owner}: <{element.tag} {attribute}='{text}'> is not finite", line)
    return values


def _origin(parent: etree._Element, owner: str) -> np.ndarray:
    transform = np.eye(4)
    element = parent.find("origin")
    if element is not None:
        transform[:3, 3] = _floats(element, "xyz", 3, "0 0 0", owner)
        transform[:3, :3] = rpy_matrix(*_floats(element, "rpy", 3, "0 0 0", owner))
    return transform


def _parse_inertial(element: etree._Element, owner: str) -> Inertial:
    mass_el = element.find("mass")
    if mass_el is None:
        raise UrdfError(f"{owner}: <inertial> has no <mass>", element.sourceline)
    mass = _floats(mass_el, "value", 1, None, owner)[0]
    inertia = np.zeros((3, 3))
    inertia_el = element.find("inertia")
    if inertia_el is None:
        raise UrdfError(f"{owner}: <inertial> has no <inertia>", element.sourceline)
    values = {k: _floats(inertia_el, k, 1, "0", owner)[0] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    inertia[0, 0], inertia[1, 1], inertia[2, 2] = values["ixx"], values["iyy"], values["izz"]
    inertia[0, 1] = inertia[1, 0] = values["ixy"]
    inertia[0, 2] = inertia[2, 0] = values["ixz"]
    inertia[1, 2] = inertia[2, 1] = values["iyz"]
    return Inertial(mass=mass, origin=_origin(element, owner), inertia=inertia, line=mass_el.sourceline)


def _shape_fields(element: etree._Element, owner: str) -> dict:
    """Origin and geometry of a <visual> or <collision>, as keyword arguments of Shape."""
    geometry = element.find("geometry")
    shapes = [] if geometry is None else [child for child in geometry if isinstance(child.tag, str)]
    if not shapes:
        raise UrdfError(f"{owner}: <{element.tag}> has no <geometry>", element.sourceline)
    shape = shapes[0]
    fields: dict = {"kind": shape.tag, "origin": _origin(element, owner), "line": shape.sourceline}
    if shape.tag == "box":
        fields["size"] = tuple(_floats(shape, "size", 3, None, owner))
    elif shape.tag == "cylinder":
        fields["radius"] = _floats(shape, "radius", 1, None, owner)[0]
        fields["length"] = _floats(shape, "length", 1, None, owner)[0]
    elif shape.tag == "sphere":
        fields["radius"] = _floats(shape, "radius", 1, None, owner)[0]
    elif shape.tag == "mesh":
        fields["filename"] = shape.get("filename", "")
        if not fields["filename"]:
            raise UrdfError(f"{owner}: <mesh> has no filename", shape.sourceline)
        fields["scale"] = tuple(_floats(shape, "scale", 3, "1 1 1", owner))
    else:
        raise UrdfError(f"{owner}: unknown geometry '{shape.tag}' (expected one of {', '.join(GEOMETRY_KINDS)})",
                        shape.sourceline)
    return fields


def _rgba(color: etree._Element, owner: str) -> tuple[float, float, float, float]:
    return tuple(_floats(color, "rgba", 4, None, owner))  # type: ignore[return-value]


def _parse_visual(element: etree._Element, materials: dict, owner: str) -> Visual:
    rgba, name = DEFAULT_RGBA, None
    material = element.find("material")
    if material is not None:
        name = material.get("name")
        color = material.find("color")
        # An inline colour wins; else a reference to a top-level <material>; unknown names stay grey, like RViz.
        rgba = _rgba(color, owner) if color is not None else materials.get(name or "", DEFAULT_RGBA)
    return Visual(**_shape_fields(element, owner), rgba=rgba, material=name)


def _parse_link(element: etree._Element, link_name: str, materials: dict) -> Link:
    owner = f"link '{link_name}'"
    inertial_el = element.find("inertial")
    visuals = [_parse_visual(v, materials, f"{owner}, visual {i}") for i, v in enumerate(element.findall("visual"))]
    collisions = [Collision(**_shape_fields(c, f"{owner}, collision {i}"))
                  for i, c in enumerate(element.findall("collision"))]
    return Link(
        link_name,
        _parse_inertial(inertial_el, owner) if inertial_el is not None else None,
        bool(visuals),
        bool(collisions),
        visuals,
        collisions,
        element.sourceline,
    )


def _parse_joint(element: etree._Element) -> Joint:
    owner = f"joint '{element.get('name')}'"
    joint_type = element.get("type")
    line = element.sourceline
    if joint_type not in JOINT_TYPES:
        raise UrdfError(f"{owner}: unknown type '{joint_type}' (expected one of {', '.join(JOINT_TYPES)})", line)
    ends: dict[str, str] = {}
    for end in ("parent", "child"):
        end_el = element.find(end)
        if end_el is None or not end_el.get("link"):
            raise UrdfError(f"{owner}: missing <{end} link='...'>", line)
        ends[end] = end_el.get("link")
    axis = np.array([1.0, 0.0, 0.0])
    axis_el = element.find("axis")
    if axis_el is not None:
        axis = np.array(_floats(axis_el, "xyz", 3, None, owner))
    norm = float(np.linalg.norm(axis))
    if joint_type in MOVABLE_TYPES and norm < 1e-12:
        raise UrdfError(f"{owner}: <axis xyz> is the zero vector", axis_el.sourceline)
    if norm > 0:
        axis = axis / norm
    joint = Joint(element.get("name"), joint_type, ends["parent"], ends["child"], _origin(element, owner), axis,
                  line=line)
    limit = element.find("limit")
    if limit is not None:
        joint.lower = _floats(limit, "lower", 1, "0", owner)[0]
        joint.upper = _floats(limit, "upper", 1, "0", owner)[0]
        joint.effort = _floats(limit, "effort", 1, None, owner)[0] if limit.get("effort") is not None else None
        joint.velocity = (
            _floats(limit, "velocity", 1, None, owner)[0] if limit.get("velocity") is not None else None
        )
        if joint_type == "continuous":
            joint.lower = joint.upper = None
    elif joint_type in ("revolute", "prismatic"):
        raise UrdfError(f"{owner}: a {joint_type} joint needs a <limit> element", line)
    mimic = element.find("mimic")
    if mimic is not None:
        if not mimic.get("joint"):
            raise UrdfError(f"{owner}: <mimic> has no joint attribute", mimic.sourceline)
        joint.mimic = Mimic(
            mimic.get("joint"),
            _floats(mimic, "multiplier", 1, "1", owner)[0],
            _floats(mimic, "offset", 1, "0", owner)[0],
        )
    return joint


def _param_number(element: etree._Element, owner: str) -> float:
    """A ``<param>`` value as a number; infinities are allowed (no bound), NaN and text are not."""
    text = (element.text or "").strip()
    where = f"{owner}: <param name='{element.get('name')}'>"
    try:
        value = float(text)
    except ValueError:
        raise UrdfError(f"{where} value '{text}' is not a number", element.sourceline) from None
    if math.isnan(value):
        raise UrdfError(f"{where} value is NaN", element.sourceline)
    return value


def _parse_ros2_control(root: etree._Element) -> list[Ros2ControlJoint]:
    out: list[Ros2ControlJoint] = []
    for block in root.findall("ros2_control"):
        for joint_el in block.findall("joint"):
            owner = f"<ros2_control> joint '{joint_el.get('name', '')}'"
            params: dict[str, dict[str, str]] = {}
            bounds: dict[str, tuple[float, float]] = {}
            commands = []
            for ci in joint_el.findall("command_interface"):
                interface = ci.get("name", "")
                commands.append(interface)
                params[interface] = {p.get("name", ""): (p.text or "").strip() for p in ci.findall("param")}
                numbers = {p.get("name"): _param_number(p, owner) for p in ci.findall("param")
                           if p.get("name") in ("min", "max")}
                if numbers:
                    bounds[interface] = (numbers.get("min", -math.inf), numbers.get("max", math.inf))
            states = [si.get("name", "") for si in joint_el.findall("state_interface")]
            out.append(Ros2ControlJoint(joint_el.get("name", ""), commands, states, params, bounds,
                                        joint_el.sourceline))
    return out


def parse_urdf(xml: str | bytes) -> RobotModel:
    """Parse URDF text into a RobotModel; raises UrdfError naming the element and the reason."""
    try:
        root = parse_xml(xml)
    except UnsafeXmlError as exc:
        raise UrdfError(str(exc)) from None
    except ValueError as exc:
        raise UrdfError(str(exc), getattr(exc, "line", None)) from None
    if root.tag != "robot":
        raise UrdfError(f"root element is <{root.tag}>, expected <robot>", root.sourceline)
    name = root.get("name")
    if not name:
        raise UrdfError("<robot> has no name attribute", root.sourceline)
    materials: dict[str, tuple[float, float, float, float]] = {}
    for element in root.findall("material"):
        color = element.find("color")
        if color is not None:
            materials[element.get("name", "")] = _rgba(color, f"material '{element.get('name')}'")
    links: dict[str, Link] = {}
    joints: dict[str, Joint] = {}
    duplicate_links: list[str] = []
    duplicate_joints: list[str] = []
    duplicate_lines: dict[tuple[str, str], int | None] = {}
    for element in root.findall("link"):
        link_name = element.get("name")
        if not link_name:
            raise UrdfError(f"{_where(element)}: link without a name", element.sourceline)
        # each link is a frame of tf, of the sensors mounted on it and of the viewer
        if (problem := names.frame_problem(link_name)) is not None:
            raise UrdfError(f"link {names.shown(link_name)}: {problem}", element.sourceline)
        if link_name in links:
            duplicate_links.append(link_name)
            duplicate_lines.setdefault(("link", link_name), element.sourceline)
            continue
        links[link_name] = _parse_link(element, link_name, materials)
    for element in root.findall("joint"):
        if not element.get("name"):
            raise UrdfError(f"{_where(element)}: joint without a name", element.sourceline)
        joint = _parse_joint(element)
        if joint.name in joints:
            duplicate_joints.append(joint.name)
            duplicate_lines.setdefault(("joint", joint.name), element.sourceline)
            continue
        joints[joint.name] = joint
    if not links:
        raise UrdfError(f"robot '{name}' has no links", root.sourceline)
    try:
        sensors, control_sensors = parse_gazebo_sensors(root), parse_ros2_control_sensors(root)
        rendered = parse_rendered_sensors(root)
    except SensorDeclarationError as exc:
        raise UrdfError(str(exc), exc.line) from None
    rendered, warnings = _first_of_repeats(rendered)
    return RobotModel(name, links, joints, _parse_ros2_control(root), duplicate_links, duplicate_joints,
                      materials, root.sourceline, duplicate_lines, sensors, control_sensors, rendered, warnings)


def _first_of_repeats(specs: list[RenderedSensorSpec]) -> tuple[list[RenderedSensorSpec], list[str]]:
    """A sensor declared again under the same name on the same link (TALOS's depth camera) is one sensor, as
    in Gazebo: the first declaration is kept and the others are named in a warning. On another link the
    name clash stays an error (the checks)."""
    kept: list[RenderedSensorSpec] = []
    seen: dict[str, str] = {}
    warnings = []
    for spec in specs:
        if seen.get(spec.name) == spec.reference:
            warnings.append(f"{spec.where}: declared again on link '{spec.reference}': the first declaration "
                            "is used")
            continue
        seen.setdefault(spec.name, spec.reference)
        kept.append(spec)
    return kept, warnings
