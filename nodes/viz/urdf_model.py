"""The parts of a URDF the visualiser needs: visual geometry with colours, and the joint tree.

Parsed from the XML text received on ``<ns>/robot_description`` (no file, no ROS package paths), with
errors that name the element and the reason so a bad description is logged and skipped.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

DEFAULT_RGBA = (0.7, 0.7, 0.7, 1.0)
MOVING_JOINT_TYPES = ("revolute", "continuous", "prismatic")
JOINT_TYPES = (*MOVING_JOINT_TYPES, "fixed", "floating", "planar")


class UrdfError(ValueError):
    """The robot description cannot be used; the message names the element and the reason."""


@dataclass(frozen=True)
class Origin:
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Visual:
    """One ``<visual>``: ``kind`` is box / cylinder / sphere / mesh; sizes in metres."""

    kind: str
    origin: Origin
    rgba: tuple[float, float, float, float]
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)  # box
    radius: float = 0.0  # cylinder, sphere
    length: float = 0.0  # cylinder
    filename: str = ""  # mesh
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  # mesh


@dataclass(frozen=True)
class Joint:
    name: str
    type: str
    parent: str
    child: str
    origin: Origin
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    lower: float = -math.inf
    upper: float = math.inf


@dataclass
class RobotModel:
    name: str
    links: dict[str, list[Visual]] = field(default_factory=dict)  # link -> its visuals (may be empty)
    joints: dict[str, Joint] = field(default_factory=dict)

    @property
    def root_link(self) -> str:
        children = {j.child for j in self.joints.values()}
        roots = [link for link in self.links if link not in children]
        return roots[0]

    @property
    def moving_joints(self) -> list[Joint]:
        return [j for j in self.joints.values() if j.type in MOVING_JOINT_TYPES]

    def leaf_links(self) -> list[str]:
        """Links that are no joint's parent: hands, feet, head (default end-effectors)."""
        parents = {j.parent for j in self.joints.values()}
        return [link for link in self.links if link not in parents]

    def joint_to_child(self, link: str) -> Joint | None:
        for joint in self.joints.values():
            if joint.child == link:
                return joint
        return None

    def visual_links(self) -> list[str]:
        return [link for link, visuals in self.links.items() if visuals]


def _floats(text: str | None, count: int, where: str, default: tuple[float, ...] | None = None) -> tuple[float, ...]:
    if text is None:
        if default is None:
            raise UrdfError(f"{where}: missing value")
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise UrdfError(f"{where}: '{text}' is not a list of numbers") from None
    if len(values) != count:
        raise UrdfError(f"{where}: expected {count} numbers, got {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise UrdfError(f"{where}: '{text}' is not finite")
    return values


def _origin(element: ET.Element | None, where: str) -> Origin:
    if element is None:
        return Origin()
    xyz = _floats(element.get("xyz"), 3, f"{where}/origin@xyz", (0.0, 0.0, 0.0))
    rpy = _floats(element.get("rpy"), 3, f"{where}/origin@rpy", (0.0, 0.0, 0.0))
    return Origin(xyz, rpy)  # type: ignore[arg-type]


def _material_rgba(material: ET.Element | None, named: dict[str, tuple[float, ...]], where: str) -> tuple:
    if material is None:
        return DEFAULT_RGBA
    color = material.find("color")
    if color is not None:
        return _floats(color.get("rgba"), 4, f"{where}/material/color@rgba")
    # A reference to a top-level <material name=...>; unknown names fall back to grey, like RViz.
    return named.get(material.get("name", ""), DEFAULT_RGBA)


def _visual(element: ET.Element, named: dict, where: str) -> Visual:
    origin = _origin(element.find("origin"), where)
    rgba = _material_rgba(element.find("material"), named, where)
    geometry = element.find("geometry")
    if geometry is None or len(geometry) == 0:
        raise UrdfError(f"{where}: <visual> has no <geometry>")
    shape = geometry[0]
    gwhere = f"{where}/geometry/{shape.tag}"
    if shape.tag == "box":
        size = _floats(shape.get("size"), 3, f"{gwhere}@size")
        return Visual("box", origin, rgba, size=size)  # type: ignore[arg-type]
    if shape.tag == "cylinder":
        (radius,) = _floats(shape.get("radius"), 1, f"{gwhere}@radius")
        (length,) = _floats(shape.get("length"), 1, f"{gwhere}@length")
        return Visual("cylinder", origin, rgba, radius=radius, length=length)  # type: ignore[arg-type]
    if shape.tag == "sphere":
        (radius,) = _floats(shape.get("radius"), 1, f"{gwhere}@radius")
        return Visual("sphere", origin, rgba, radius=radius)  # type: ignore[arg-type]
    if shape.tag == "mesh":
        filename = shape.get("filename", "")
        if not filename:
            raise UrdfError(f"{gwhere}: missing filename")
        scale = _floats(shape.get("scale"), 3, f"{gwhere}@scale", (1.0, 1.0, 1.0))
        return Visual("mesh", origin, rgba, filename=filename, scale=scale)  # type: ignore[arg-type]
    raise UrdfError(f"{gwhere}: unknown geometry '{shape.tag}'")


def parse_urdf(xml_text: str) -> RobotModel:
    """Parse URDF XML text; raises ``UrdfError`` naming the element and the reason."""
    if not xml_text or not xml_text.strip():
        raise UrdfError("robot_description: empty")
    if "<!DOCTYPE" in xml_text or "<!ENTITY" in xml_text:
        # Entity expansion is the classic XML bomb; a URDF never needs a DTD.
        raise UrdfError("robot_description: DTD/entity declarations are not allowed")
    try:
        root = ET.fromstring(xml_text)
    except ET.ParseError as exc:
        raise UrdfError(f"robot_description: not XML ({exc})") from None
    if root.tag != "robot":
        raise UrdfError(f"robot_description: root element is <{root.tag}>, expected <robot>")
    model = RobotModel(name=root.get("name", ""))
    named: dict[str, tuple[float, ...]] = {}
    for material in root.findall("material"):
        color = material.find("color")
        if color is not None:
            named[material.get("name", "")] = _floats(
                color.get("rgba"), 4, f"material[{material.get('name')}]/color@rgba")
    for link in root.findall("link"):
        name = link.get("name")
        if not name:
            raise UrdfError("link: missing name")
        if name in model.links:
            raise UrdfError(f"link[{name}]: defined twice")
        model.links[name] = [
            _visual(v, named, f"link[{name}]/visual[{i}]") for i, v in enumerate(link.findall("visual"))
        ]
    if not model.links:
        raise UrdfError("robot_description: no <link>")
    for joint in root.findall("joint"):
        model.joints[joint.get("name", "")] = _joint(joint, model)
    roots = [link for link in model.links if link not in {j.child for j in model.joints.values()}]
    if len(roots) != 1:
        raise UrdfError(f"robot_description: expected one root link, found {len(roots)}: {roots[:5]}")
    return model


def _joint(element: ET.Element, model: RobotModel) -> Joint:
    name = element.get("name")
    if not name:
        raise UrdfError("joint: missing name")
    where = f"joint[{name}]"
    joint_type = element.get("type", "")
    if joint_type not in JOINT_TYPES:
        raise UrdfError(f"{where}@type: unknown type '{joint_type}'")
    if name in model.joints:
        raise UrdfError(f"{where}: defined twice")
    parent_el, child_el = element.find("parent"), element.find("child")
    if parent_el is None or child_el is None:
        raise UrdfError(f"{where}: needs <parent> and <child>")
    parent, child = parent_el.get("link", ""), child_el.get("link", "")
    for role, link in (("parent", parent), ("child", child)):
        if link not in model.links:
            raise UrdfError(f"{where}/{role}: unknown link '{link}'")
    axis_el = element.find("axis")
    axis = _floats(axis_el.get("xyz") if axis_el is not None else None, 3, f"{where}/axis@xyz", (1.0, 0.0, 0.0))
    norm = math.sqrt(sum(a * a for a in axis))
    if joint_type in MOVING_JOINT_TYPES and norm < 1e-9:
        raise UrdfError(f"{where}/axis@xyz: zero axis")
    axis = tuple(a / norm for a in axis) if norm > 1e-9 else axis
    lower, upper = -math.inf, math.inf
    limit = element.find("limit")
    if limit is not None and joint_type in ("revolute", "prismatic"):
        (lower,) = _floats(limit.get("lower", "0"), 1, f"{where}/limit@lower")
        (upper,) = _floats(limit.get("upper", "0"), 1, f"{where}/limit@upper")
    return Joint(name, joint_type, parent, child, _origin(element.find("origin"), where), axis,  # type: ignore[arg-type]
                 lower, upper)
