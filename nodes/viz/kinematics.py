"""Rigid-transform maths and URDF forward kinematics (numpy, 4x4 homogeneous matrices).

Used for the markers (end-effector paths, the target pose of a trajectory) and as a fallback for link
frames when no ``tf`` arrives. Quaternions are ``(x, y, z, w)`` like geometry_msgs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from .urdf_model import Joint, Origin, RobotModel


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF convention: fixed-axis X (roll), then Y (pitch), then Z (yaw): R = Rz Ry Rx."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def axis_angle_to_matrix(axis: tuple[float, float, float] | np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array([
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ])


def quat_to_matrix(q: tuple[float, float, float, float] | np.ndarray) -> np.ndarray:
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n < 1e-12:
        return np.eye(3)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Rotation matrix -> unit quaternion (x, y, z, w), numerically stable branch choice."""
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = math.sqrt(trace + 1.0) * 2
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, 0.25 * s]
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2]) * 2
        q = [0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s, (r[2, 1] - r[1, 2]) / s]
    elif r[1, 1] > r[2, 2]:
        s = math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2]) * 2
        q = [(r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s, (r[0, 2] - r[2, 0]) / s]
    else:
        s = math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1]) * 2
        q = [(r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s, (r[1, 0] - r[0, 1]) / s]
    quat = np.array(q)
    return quat / np.linalg.norm(quat)


def make_transform(rotation: np.ndarray, translation) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


def origin_transform(origin: Origin) -> np.ndarray:
    return make_transform(rpy_to_matrix(*origin.rpy), origin.xyz)


def pose_transform(position, orientation_xyzw) -> np.ndarray:
    return make_transform(quat_to_matrix(orientation_xyzw), position)


def joint_transform(joint: Joint, value: float) -> np.ndarray:
    """Parent-link -> child-link transform of ``joint`` at ``value`` (rad or m)."""
    base = origin_transform(joint.origin)
    if joint.type in ("revolute", "continuous"):
        return base @ make_transform(axis_angle_to_matrix(joint.axis, value), (0.0, 0.0, 0.0))
    if joint.type == "prismatic":
        return base @ make_transform(np.eye(3), np.asarray(joint.axis) * value)
    return base


class ForwardKinematics:
    """Link poses in the root-link frame for a map of joint positions (missing joints at 0)."""

    def __init__(self, model: RobotModel) -> None:
        self.model = model
        self.root = model.root_link
        # Joints ordered parent-before-child so one pass composes every chain.
        self.ordered: list[Joint] = []
        frontier = [self.root]
        by_parent: dict[str, list[Joint]] = {}
        for joint in model.joints.values():
            by_parent.setdefault(joint.parent, []).append(joint)
        while frontier:
            link = frontier.pop()
            for joint in by_parent.get(link, []):
                self.ordered.append(joint)
                frontier.append(joint.child)

    def joint_transforms(self, positions: Mapping[str, float]) -> dict[str, tuple[str, np.ndarray]]:
        """child link -> (parent link, parent->child transform): what a state publisher puts on tf."""
        return {j.child: (j.parent, joint_transform(j, positions.get(j.name, 0.0))) for j in self.ordered}

    def link_poses(self, positions: Mapping[str, float], base: np.ndarray | None = None) -> dict[str, np.ndarray]:
        poses = {self.root: np.eye(4) if base is None else base}
        for joint in self.ordered:
            poses[joint.child] = poses[joint.parent] @ joint_transform(joint, positions.get(joint.name, 0.0))
        return poses
