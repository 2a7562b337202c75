"""Frame links: what ROS tolerates and a physics engine cannot simulate, lumped as Gazebo lumps fixed joints.

A link on a fixed joint without ``<inertial>``, with zero mass or with an inertia that is not positive definite
(a sensor's optical frame, a sole, a tool point) is a *frame*: TF and the sensors need it, the physics does not.
``lump_frames`` merges every frame into its parent body: its shapes (origins composed), its mass (mass, centre
of mass and inertia combined, as a point mass when it has no inertia) and its child joints (re-parented, origins
composed). The result is the URDF text the physics engine loads, and where each merged frame now sits.

A link a joint moves needs a real inertia: without one a physics engine invents it (DART: 1 kg), so that is an
error naming the link, as is a floating root that is left without mass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from lxml import etree

from nodes.urdf.model import RobotModel, UrdfError, parse_urdf
from nodes.urdf.rotation import rpy_matrix
from nodes.urdf.xml_safety import parse_xml

# A fixed base's root: DART's loader and Gazebo weld a link named so to the world.
WORLD_LINK = "world"


def has_inertia(model: RobotModel, link: str) -> bool:
    """A positive mass and a positive definite inertia: what a body a joint moves needs."""
    inertial = model.links[link].inertial
    if inertial is None or not inertial.mass > 0:
        return False
    return float(np.linalg.eigvalsh(inertial.inertia).min()) > 0


def frame_links(model: RobotModel) -> list[str]:
    """Links on fixed joints without a usable inertia, URDF order."""
    fixed_children = {j.child for j in model.joints.values() if j.type == "fixed"}
    return [name for name in model.links if name in fixed_children and not has_inertia(model, name)]


def inertia_errors(model: RobotModel) -> list[str]:
    """Links the physics cannot simulate: moved by a joint (or a floating root) without a real inertia."""
    errors = []
    parent_joint = {j.child: j for j in model.joints.values()}
    for name, link in model.links.items():
        joint = parent_joint.get(name)
        if joint is None or joint.type == "fixed" or has_inertia(model, name):
            continue
        what = "no <inertial>" if link.inertial is None else (
            f"mass {link.inertial.mass:g}" if not link.inertial.mass > 0 else "an inertia that is not positive definite")
        errors.append(f"link '{name}' is moved by {joint.type} joint '{joint.name}' but has {what} "
                      "(a physics engine would invent one: give it an <inertial>)")
    return errors


@dataclass
class Lumped:
    """The URDF the physics loads, and where the frames went."""

    xml: str
    # merged link -> (the body it is part of, the link's pose in that body's frame)
    frames: dict[str, tuple[str, np.ndarray]] = field(default_factory=dict)
    massless_root: str = ""   # the root link when it is left without mass (fine welded to the world only)

    def body_of(self, link: str) -> tuple[str, np.ndarray]:
        """The physics body carrying ``link`` and the link's pose in it (itself and identity if not merged)."""
        return self.frames.get(link, (link, np.eye(4)))


def _matrix(element: etree._Element | None) -> np.ndarray:
    transform = np.eye(4)
    origin = None if element is None else element.find("origin")
    if origin is not None:
        transform[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
        transform[:3, :3] = rpy_matrix(*(float(v) for v in origin.get("rpy", "0 0 0").split()))
    return transform


def _rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """Inverse of ``rpy_matrix`` (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    pitch = math.asin(max(-1.0, min(1.0, -rotation[2, 0])))
    if abs(rotation[2, 0]) < 1 - 1e-9:
        roll = math.atan2(rotation[2, 1], rotation[2, 2])
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
    else:   # gimbal lock: roll folded into yaw
        roll = 0.0
        yaw = math.atan2(-rotation[0, 1], rotation[1, 1])
    return roll, pitch, yaw


def _set_origin(element: etree._Element, transform: np.ndarray) -> None:
    origin = element.find("origin")
    if origin is None:
        origin = etree.Element("origin")
        element.insert(0, origin)
    origin.set("xyz", " ".join(f"{v:.17g}" for v in transform[:3, 3]))
    origin.set("rpy", " ".join(f"{v:.17g}" for v in _rpy(transform[:3, :3])))


def _mass_properties(link: etree._Element) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about it) in the link frame; zero for a link without <inertial>."""
    inertial = link.find("inertial")
    if inertial is None:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    mass_el = inertial.find("mass")
    mass = float(mass_el.get("value", "0")) if mass_el is not None else 0.0
    values = {k: 0.0 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    inertia_el = inertial.find("inertia")
    if inertia_el is not None:
        values.update({k: float(inertia_el.get(k, "0")) for k in values})
    inertia = np.array([[values["ixx"], values["ixy"], values["ixz"]],
                        [values["ixy"], values["iyy"], values["iyz"]],
                        [values["ixz"], values["iyz"], values["izz"]]])
    frame = _matrix(inertial)
    rotation = frame[:3, :3]
    if np.linalg.eigvalsh(inertia).min() < 0:
        inertia = np.zeros((3, 3))   # an impossible inertia: the mass counts, as a point
    return max(mass, 0.0), frame[:3, 3], rotation @ inertia @ rotation.T


def _combine(parts: list[tuple[float, np.ndarray, np.ndarray]]) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, centre of mass and inertia (about it) of rigidly joined parts, all in one frame."""
    mass = sum(m for m, _, _ in parts)
    if mass <= 0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    com = sum(m * c for m, c, _ in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, i in parts:
        d = c - com
        inertia += i + m * (float(d @ d) * np.eye(3) - np.outer(d, d))   # parallel axes
    return mass, com, inertia


def _write_inertial(link: etree._Element, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
    old = link.find("inertial")
    if old is not None:
        link.remove(old)
    if mass <= 0:
        return
    inertial = etree.SubElement(link, "inertial")
    _set_origin(inertial, np.block([[np.eye(3), com[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]]))
    etree.SubElement(inertial, "mass", value=f"{mass:.17g}")
    etree.SubElement(inertial, "inertia", **{
        key: f"{inertia[a, b]:.17g}" for key, (a, b) in
        {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}.items()})


def _merge(root: etree._Element, links: dict, joint: etree._Element, parent: str, child: str) -> np.ndarray:
    """Merge link ``child`` into ``parent`` across fixed ``joint``; returns the child's pose in the parent."""
    offset = _matrix(joint)
    parent_el, child_el = links[parent], links[child]
    m1, c1, i1 = _mass_properties(parent_el)
    m2, c2, i2 = _mass_properties(child_el)
    if m2 > 0:
        rotation = offset[:3, :3]
        _write_inertial(parent_el, *_combine([(m1, c1, i1), (m2, offset[:3, :3] @ c2 + offset[:3, 3],
                                                             rotation @ i2 @ rotation.T)]))
    for shape in child_el.findall("visual") + child_el.findall("collision"):
        _set_origin(shape, offset @ _matrix(shape))
        parent_el.append(shape)
    for other in root.findall("joint"):
        other_parent = other.find("parent")
        if other_parent is not None and other_parent.get("link") == child:
            other_parent.set("link", parent)
            _set_origin(other, offset @ _matrix(other))
    root.remove(joint)
    root.remove(child_el)
    del links[child]
    return offset


def lump_frames(xml: str, model: RobotModel | None = None) -> Lumped:
    """The URDF with every frame link merged into its parent (``model``: the same text already parsed)."""
    model = model if model is not None else parse_urdf(xml)
    frames = frame_links(model)
    root_name = model.root
    if root_name != WORLD_LINK and not has_inertia(model, root_name):
        # a root without mass (``base_link`` over the pelvis): its fixed children lump into it, as in Gazebo
        frames += [j.child for j in model.joints.values()
                   if j.parent == root_name and j.type == "fixed" and j.child not in frames]
    if not frames:
        return Lumped(xml, massless_root=root_name if root_name != WORLD_LINK and not has_inertia(model, root_name)
                      else "")
    root = parse_xml(xml)
    links = {el.get("name"): el for el in root.findall("link")}
    joint_of = {el.find("child").get("link"): el for el in root.findall("joint") if el.find("child") is not None}
    parent_of = {j.child: j.parent for j in model.joints.values()}
    # parents first, so a frame below a frame lands on the first real body directly
    depth = {}
    for name in model.links:
        d, link = 0, name
        while link in parent_of and d <= len(model.links):
            link, d = parent_of[link], d + 1
        depth[name] = d
    placed: dict[str, tuple[str, np.ndarray]] = {}
    for child in sorted(frames, key=depth.__getitem__):
        joint = joint_of[child]
        parent = joint.find("parent").get("link")
        placed[child] = (parent, _merge(root, links, joint, parent, child))
    # a frame merged into a frame that merged later: follow to the body
    for name, (body, pose) in list(placed.items()):
        while body in placed:
            above, offset = placed[body]
            body, pose = above, offset @ pose
        placed[name] = (body, pose)
    mass, _, inertia = _mass_properties(links[root_name])
    massless = root_name != WORLD_LINK and not (mass > 0 and np.linalg.eigvalsh(inertia).min() > 0)
    return Lumped(etree.tostring(root, encoding="unicode"), placed, root_name if massless else "")


def check_inertias(model: RobotModel) -> None:
    """Raise UrdfError naming every moving link without a real inertia (``inertia_errors``)."""
    errors = inertia_errors(model)
    if errors:
        shown = errors[:5] + ([f"... and {len(errors) - 5} more"] if len(errors) > 5 else [])
        raise UrdfError("; ".join(shown))


__all__ = ["WORLD_LINK", "Lumped", "check_inertias", "frame_links", "has_inertia", "inertia_errors",
           "lump_frames"]
