"""Structural and physical checks of a parsed URDF (what ``check_urdf`` reports).

Errors make a model unusable (the tree is not a tree, limits or inertias are impossible); warnings are
things a simulator needs but a viewer does not (links without inertia or collision).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodes.urdf.frames import frame_links
from nodes.urdf.model import RobotModel
from nodes.urdf.rendered_sensors import rendered_sensor_problems
from nodes.urdf.sensors import sensor_problems


@dataclass(frozen=True)
class Issue:
    severity: str  # "error" | "warning"
    message: str

    def __str__(self) -> str:
        return f"{self.severity}: {self.message}"


def _reaches(model: RobotModel, start: str, target: str) -> bool:
    """True when ``target`` is an ancestor of (or is) ``start`` through any parent joint."""
    parents: dict[str, list[str]] = {}
    for joint in model.joints.values():
        parents.setdefault(joint.child, []).append(joint.parent)
    stack, seen = [start], set()
    while stack:
        link = stack.pop()
        if link == target:
            return True
        if link not in seen:
            seen.add(link)
            stack.extend(parents.get(link, []))
    return False


def _tree_errors(model: RobotModel) -> list[str]:
    errors: list[str] = []
    for name in model.duplicate_links:
        errors.append(f"duplicate link name '{name}'")
    for name in model.duplicate_joints:
        errors.append(f"duplicate joint name '{name}'")
    parent_of: dict[str, str] = {}
    for joint in model.joints.values():
        for end, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in model.links:
                errors.append(f"joint '{joint.name}': {end} link '{link}' does not exist")
        if joint.parent == joint.child:
            errors.append(f"joint '{joint.name}': link '{joint.child}' is its own parent (cycle)")
        if joint.child in parent_of:
            loop = " and closes a loop (cycle)" if _reaches(model, joint.parent, joint.child) else ""
            errors.append(
                f"link '{joint.child}' has two parent joints ('{parent_of[joint.child]}' and '{joint.name}'){loop}"
            )
        else:
            parent_of[joint.child] = joint.name
        if joint.mimic and joint.mimic.joint not in model.joints:
            errors.append(f"joint '{joint.name}': mimics unknown joint '{joint.mimic.joint}'")
        elif joint.mimic and joint.mimic.joint == joint.name:
            errors.append(f"joint '{joint.name}': mimics itself")
    if errors:
        return errors
    # Cycle detection: from each link walk up through parents; a walk longer than the link count loops.
    parent_link = {j.child: j.parent for j in model.joints.values()}
    for start in model.links:
        seen = {start}
        link = start
        while link in parent_link:
            link = parent_link[link]
            if link in seen:
                return [f"kinematic loop through link '{link}' (cycle)"]
            seen.add(link)
    roots = model.roots()
    if len(roots) > 1:
        errors.append(f"several root links: {', '.join(roots)} (a URDF must be one tree)")
    elif not roots:
        errors.append("no root link (every link has a parent: cycle)")
    return errors


def _joint_errors(model: RobotModel) -> list[str]:
    errors: list[str] = []
    for joint in model.joints.values():
        if joint.lower is not None and joint.upper is not None and joint.lower > joint.upper:
            errors.append(f"joint '{joint.name}': lower limit {joint.lower:g} > upper limit {joint.upper:g}")
        if joint.effort is not None and joint.effort < 0:
            errors.append(f"joint '{joint.name}': negative effort limit {joint.effort:g}")
        if joint.velocity is not None and joint.velocity < 0:
            errors.append(f"joint '{joint.name}': negative velocity limit {joint.velocity:g}")
    return errors


def _inertia_errors(model: RobotModel) -> list[str]:
    errors: list[str] = []
    frames = set(frame_links(model))   # ROS tolerates these: the simulator merges them into their parent
    roots = model.roots()
    if len(roots) == 1 and any(j.parent == roots[0] and j.type == "fixed" for j in model.joints.values()):
        frames.add(roots[0])   # a massless root takes its fixed children's mass in the simulator (Gazebo's way)
    for link in model.links.values():
        if link.inertial is None or link.name in frames:
            continue
        if link.inertial.mass <= 0:
            errors.append(f"link '{link.name}': mass {link.inertial.mass:g} is not positive")
        eigenvalues = np.linalg.eigvalsh(link.inertial.inertia)
        if eigenvalues.min() <= 0:
            errors.append(
                f"link '{link.name}': inertia is not positive definite (eigenvalues "
                f"{', '.join(f'{e:.3g}' for e in eigenvalues)})"
            )
        else:
            # Principal moments of a real body satisfy the triangle inequality.
            a, b, c = sorted(eigenvalues)
            if a + b < c * (1 - 1e-9):
                errors.append(
                    f"link '{link.name}': principal moments {a:.3g}, {b:.3g}, {c:.3g} violate the triangle "
                    "inequality (no real body has this inertia)"
                )
    return errors


# A link this light without shapes is a frame (a sensor's, say) carrying a token mass: physics engines give
# a link without <inertial> a whole kilogram (DART does).
FRAME_MASS = 0.05


def _warnings(model: RobotModel) -> list[str]:
    warnings: list[str] = list(model.warnings)
    frames = frame_links(model)
    if frames:
        warnings.append(f"{len(frames)} link(s) on fixed joints without a usable inertia are frames (the simulator "
                        f"merges them into their parent body): {', '.join(frames)}")
    for link in model.links.values():
        if link.name in frames:
            continue
        if link.inertial is None:
            warnings.append(f"link '{link.name}' has no <inertial> (simulation needs mass and inertia)")
        elif not link.has_collision and link.inertial.mass > FRAME_MASS:
            warnings.append(f"link '{link.name}' has mass but no <collision> shape")
    for joint in model.joints.values():
        if joint.movable and joint.effort is None and joint.type != "continuous":
            warnings.append(f"joint '{joint.name}' has no effort limit")
    control_names = {c.name for c in model.ros2_control}
    for name in control_names - set(model.joints):
        warnings.append(f"<ros2_control> lists joint '{name}' which is not in the URDF")
    return warnings


def validate(model: RobotModel) -> list[Issue]:
    """All problems found, errors first."""
    errors = _tree_errors(model) + _joint_errors(model) + _inertia_errors(model)
    errors += sensor_problems(model.sensors, model.ros2_control_sensors, model.links, model.joints)
    errors += rendered_sensor_problems(model.rendered_sensors, model.links, taken={s.name for s in model.sensors})
    return [Issue("error", m) for m in errors] + [Issue("warning", m) for m in _warnings(model)]
