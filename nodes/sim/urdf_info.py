"""What the simulator needs to know from a URDF before handing it to DART.

DART's loader prints warnings and returns None on bad input; parsing the XML ourselves first lets every
error name the line it comes from, and gives us the joint limits and the ``<ros2_control>`` block, which
DART ignores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from lxml import etree

MOVABLE_TYPES = ("revolute", "continuous", "prismatic")
INTERFACES = ("position", "velocity", "effort")


class UrdfError(ValueError):
    """A URDF that cannot be simulated; the message names the line and the reason."""


@dataclass
class JointInfo:
    """A movable joint with its URDF limits and hardware interfaces (DESIGN §6)."""

    name: str
    type: str
    lower: float = -math.inf
    upper: float = math.inf
    max_velocity: float = math.inf
    max_effort: float = math.inf
    command_interfaces: list[str] = field(default_factory=lambda: ["position"])
    state_interfaces: list[str] = field(default_factory=lambda: list(INTERFACES))
    # <ros2_control> min/max params per command interface, on top of the URDF limits
    command_bounds: dict[str, tuple[float, float]] = field(default_factory=dict)

    def bounds(self, interface: str) -> tuple[float, float]:
        """The admissible range of a command on ``interface`` (URDF limit ∩ ros2_control min/max)."""
        if interface == "position":
            lo, hi = self.lower, self.upper
        elif interface == "velocity":
            lo, hi = -self.max_velocity, self.max_velocity
        else:
            lo, hi = -self.max_effort, self.max_effort
        extra = self.command_bounds.get(interface)
        if extra:
            lo, hi = max(lo, extra[0]), min(hi, extra[1])
        return lo, hi


@dataclass
class RobotInfo:
    name: str
    root_link: str
    links: list[str]
    joints: list[JointInfo]            # movable joints, URDF order
    has_ros2_control: bool = False

    def joint(self, name: str) -> JointInfo:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(name)


def _where(element: etree._Element) -> str:
    return f"line {element.sourceline}"


def _float_attr(element: etree._Element, attr: str, default: float) -> float:
    raw = element.get(attr)
    if raw is None:
        return default
    try:
        value = float(raw)
    except ValueError:
        raise UrdfError(f"{_where(element)}: <{element.tag}> attribute {attr}={raw!r} is not a number") from None
    if math.isnan(value):
        raise UrdfError(f"{_where(element)}: <{element.tag}> attribute {attr} is NaN")
    return value


def _param_value(element: etree._Element) -> float:
    text = (element.text or "").strip()
    try:
        value = float(text)
    except ValueError:
        raise UrdfError(f"{_where(element)}: <param name={element.get('name')!r}> value {text!r} is not a number") from None
    if math.isnan(value):
        raise UrdfError(f"{_where(element)}: <param name={element.get('name')!r}> is NaN")
    return value


# Numeric attributes DART reads: (element, attribute) -> how many numbers. Checked up front because DART
# reports them without a line (or, for NaN geometry, misbehaves later).
NUMERIC_ATTRIBUTES = {
    ("origin", "xyz"): 3, ("origin", "rpy"): 3, ("axis", "xyz"): 3, ("mass", "value"): 1,
    **{("inertia", k): 1 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
    ("box", "size"): 3, ("cylinder", "radius"): 1, ("cylinder", "length"): 1, ("sphere", "radius"): 1,
    ("mesh", "scale"): 3,
}
NON_NEGATIVE = {("mass", "value"), ("box", "size"), ("cylinder", "radius"), ("cylinder", "length"),
                ("sphere", "radius")}


def _check_numbers(root: etree._Element) -> None:
    for element in root.iter():
        if not isinstance(element.tag, str):
            continue
        for attr, raw in element.attrib.items():
            count = NUMERIC_ATTRIBUTES.get((element.tag, attr))
            if count is None:
                continue
            parts = raw.split()
            try:
                values = [float(p) for p in parts]
            except ValueError:
                values = []
            if len(values) != count:
                raise UrdfError(f"{_where(element)}: <{element.tag}> {attr}={raw!r} must be {count} number(s)")
            if not all(math.isfinite(v) for v in values):
                raise UrdfError(f"{_where(element)}: <{element.tag}> {attr}={raw!r} is not finite")
            if (element.tag, attr) in NON_NEGATIVE and any(v < 0 for v in values):
                raise UrdfError(f"{_where(element)}: <{element.tag}> {attr}={raw!r} must not be negative")
        if element.tag == "mesh" and (element.get("filename") or "").startswith("package://"):
            raise UrdfError(f"{_where(element)}: mesh {element.get('filename')!r}: package:// needs ROS; "
                            "use a path relative to the URDF file")


def parse_urdf(xml: str) -> RobotInfo:
    """Parse and check a URDF string; raises ``UrdfError`` naming the offending line."""
    if not isinstance(xml, str) or not xml.strip():
        raise UrdfError("empty robot description")
    try:
        parser = etree.XMLParser(resolve_entities=False, no_network=True, remove_comments=True)
        root = etree.fromstring(xml.encode(), parser)
    except etree.XMLSyntaxError as exc:
        raise UrdfError(f"line {exc.lineno}: XML syntax error: {exc.msg}") from None
    if root.tag != "robot":
        raise UrdfError(f"{_where(root)}: root element is <{root.tag}>, expected <robot>")
    name = root.get("name") or ""
    if not name:
        raise UrdfError(f"{_where(root)}: <robot> has no name")

    _check_numbers(root)
    links: list[str] = []
    for link in root.findall("link"):
        link_name = link.get("name")
        if not link_name:
            raise UrdfError(f"{_where(link)}: <link> has no name")
        if link_name in links:
            raise UrdfError(f"{_where(link)}: duplicate link {link_name!r}")
        links.append(link_name)
    if not links:
        raise UrdfError(f"{_where(root)}: robot {name!r} has no links")

    children: set[str] = set()
    joints: list[JointInfo] = []
    seen_joints: set[str] = set()
    for joint in root.findall("joint"):
        joint_name = joint.get("name")
        joint_type = joint.get("type")
        if not joint_name:
            raise UrdfError(f"{_where(joint)}: <joint> has no name")
        if joint_name in seen_joints:
            raise UrdfError(f"{_where(joint)}: duplicate joint {joint_name!r}")
        seen_joints.add(joint_name)
        if joint_type not in (*MOVABLE_TYPES, "fixed", "floating", "planar"):
            raise UrdfError(f"{_where(joint)}: joint {joint_name!r} has unknown type {joint_type!r}")
        parent, child = joint.find("parent"), joint.find("child")
        for tag, element in (("parent", parent), ("child", child)):
            if element is None or element.get("link") not in links:
                link = None if element is None else element.get("link")
                raise UrdfError(f"{_where(joint)}: joint {joint_name!r} <{tag}> link {link!r} is not a link of the robot")
        children.add(child.get("link"))
        if joint_type not in MOVABLE_TYPES:
            continue
        info = JointInfo(name=joint_name, type=joint_type)
        limit = joint.find("limit")
        if limit is None and joint_type != "continuous":
            raise UrdfError(f"{_where(joint)}: {joint_type} joint {joint_name!r} has no <limit>")
        if limit is not None:
            if joint_type != "continuous":
                info.lower = _float_attr(limit, "lower", 0.0)
                info.upper = _float_attr(limit, "upper", 0.0)
                if info.lower > info.upper:
                    raise UrdfError(f"{_where(limit)}: joint {joint_name!r} lower limit {info.lower} > upper {info.upper}")
            # URDF: velocity/effort <= 0 or absent means "no limit" in practice
            velocity = _float_attr(limit, "velocity", math.inf)
            effort = _float_attr(limit, "effort", math.inf)
            info.max_velocity = velocity if velocity > 0 else math.inf
            info.max_effort = effort if effort > 0 else math.inf
        joints.append(info)

    roots = [link for link in links if link not in children]
    if len(roots) != 1:
        raise UrdfError(f"{_where(root)}: robot {name!r} must have exactly one root link, found {roots}")

    has_block = _apply_ros2_control(root, joints)
    return RobotInfo(name=name, root_link=roots[0], links=links, joints=joints, has_ros2_control=has_block)


def _apply_ros2_control(root: etree._Element, joints: list[JointInfo]) -> bool:
    """Interfaces from ``<ros2_control>``: joints it does not list become passive (no command interface)."""
    blocks = root.findall("ros2_control")
    if not blocks:
        return False
    by_name = {joint.name: joint for joint in joints}
    for joint in joints:
        joint.command_interfaces = []
    for block in blocks:
        for element in block.findall("joint"):
            joint_name = element.get("name")
            joint = by_name.get(joint_name or "")
            if joint is None:
                raise UrdfError(f"{_where(element)}: <ros2_control> joint {joint_name!r} is not a movable joint of the robot")
            commands: list[str] = []
            for command in element.findall("command_interface"):
                interface = command.get("name")
                if interface not in INTERFACES:
                    raise UrdfError(f"{_where(command)}: joint {joint_name!r} command_interface {interface!r} "
                                    f"is not one of {', '.join(INTERFACES)}")
                commands.append(interface)
                params = {p.get("name"): _param_value(p) for p in command.findall("param")}
                if "min" in params or "max" in params:
                    joint.command_bounds[interface] = (params.get("min", -math.inf), params.get("max", math.inf))
            states = [s.get("name") for s in element.findall("state_interface")]
            for state, element_state in zip(states, element.findall("state_interface"), strict=True):
                if state not in INTERFACES:
                    raise UrdfError(f"{_where(element_state)}: joint {joint_name!r} state_interface {state!r} "
                                    f"is not one of {', '.join(INTERFACES)}")
            joint.command_interfaces = commands
            joint.state_interfaces = states or list(INTERFACES)
    return True
