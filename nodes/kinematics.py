"""Vectorised forward kinematics of a URDF tree (numpy).

Everything that does not depend on the joint values is precomputed once: joint origins, the skew matrix K
of each axis and K @ K (Rodrigues: R = I + sin(q) K + (1 - cos(q)) K^2), the mimic map, and the tree cut
into depth levels. One update is then a fixed, small number of numpy calls, whatever the number of joints:
all local joint transforms in one batch, then one batched matmul per tree level (not per link).
Every function also accepts a batch of configurations (``q`` of shape ``(..., n_dof)``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from nodes.urdf.model import Joint, RobotModel, UrdfError


def _skew(v: np.ndarray) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


class KinematicTree:
    """Forward kinematics for one URDF model.

    - ``dof_names``: the independent joint variables (movable, not mimic), the order of ``q``.
    - ``joints``: every joint (fixed ones included) in parent-before-child order; ``local_transforms``
      returns one parent-link -> child-link transform per entry (what ``tf`` publishes).
    - ``link_names``: the root first, then each joint's child; ``link_transforms`` are root -> link.
    """

    def __init__(self, model: RobotModel) -> None:
        self.model = model
        self.root = model.root
        ordered: list[Joint] = []
        frontier = [self.root]
        depth_of_link = {self.root: 0}
        while frontier:  # breadth first: parents always before children
            link = frontier.pop(0)
            for joint in model.children_of(link):
                ordered.append(joint)
                depth_of_link[joint.child] = depth_of_link[link] + 1
                frontier.append(joint.child)
        if len(ordered) != len(model.joints):
            unreachable = sorted(set(model.joints) - {j.name for j in ordered})
            raise UrdfError(f"joints not reachable from root '{self.root}': {', '.join(unreachable)}")
        self.joints = ordered
        self.joint_names = [j.name for j in ordered]
        self.link_names = [self.root] + [j.child for j in ordered]
        self.link_index = {name: i for i, name in enumerate(self.link_names)}
        self.parent_names = [j.parent for j in ordered]
        self.child_names = [j.child for j in ordered]

        movable = [j for j in ordered if j.movable]
        self.dof_names = [j.name for j in movable if j.mimic is None]
        self.dof_index = {name: i for i, name in enumerate(self.dof_names)}
        n = len(ordered)
        self.fixed_mask = np.array([not j.movable for j in ordered], dtype=bool)
        self.movable_indices = np.flatnonzero(~self.fixed_mask)

        # Joint value of joint i = source[i] * multiplier[i] + offset[i]; source indexes q (or 0 for fixed).
        q_source = np.zeros(n, dtype=np.intp)
        multiplier = np.zeros(n)
        offset = np.zeros(n)
        for i, joint in enumerate(ordered):
            if not joint.movable:
                continue
            if joint.mimic is None:
                q_source[i], multiplier[i] = self.dof_index[joint.name], 1.0
                continue
            # Follow mimic chains (a mimics b mimics c) down to an independent joint.
            mult, off, target = 1.0, 0.0, joint
            seen = {joint.name}
            while target.mimic is not None:
                source = model.joints.get(target.mimic.joint)
                if source is None or not source.movable:
                    raise UrdfError(f"joint '{joint.name}': mimicked joint '{target.mimic.joint}' is not movable")
                if source.name in seen:
                    raise UrdfError(f"joint '{joint.name}': mimic loop through '{source.name}'")
                seen.add(source.name)
                # value(joint) = mult * value(target) + off and value(target) = m * value(source) + o.
                mult, off = mult * target.mimic.multiplier, off + mult * target.mimic.offset
                target = source
            q_source[i], multiplier[i], offset[i] = self.dof_index[target.name], mult, off
        self._q_source, self._multiplier, self._offset = q_source, multiplier, offset

        self._origin_rot = np.array([j.origin[:3, :3] for j in ordered]).reshape(n, 3, 3)
        self._origin_pos = np.array([j.origin[:3, 3] for j in ordered]).reshape(n, 3)
        axes = np.array([j.axis for j in ordered]).reshape(n, 3)
        self._revolute = np.array([j.type in ("revolute", "continuous") for j in ordered], dtype=float)
        self._prismatic = np.array([j.type == "prismatic" for j in ordered], dtype=float)
        self._axes = axes
        k = np.array([_skew(a) for a in axes]).reshape(n, 3, 3)
        self._k = k
        self._k2 = k @ k
        # Prismatic: translation in the parent frame per unit of q = origin_rot @ axis.
        self._slide = np.einsum("nij,nj->ni", self._origin_rot, axes) * self._prismatic[:, None]

        # Joint origins as quaternions, for the matrix-free tf path (``local_poses``).
        self._origin_quat = matrix_to_quaternion(self._origin_rot) if n else np.zeros((0, 4))

        # Tree levels: joints whose parent link is at depth d, with the link indices to gather/scatter.
        self._levels: list[tuple[np.ndarray, np.ndarray]] = []
        joint_depth = np.array([depth_of_link[j.parent] for j in ordered], dtype=int)
        for depth in range(int(joint_depth.max()) + 1 if n else 0):
            members = np.flatnonzero(joint_depth == depth)
            parents = np.array([self.link_index[ordered[i].parent] for i in members], dtype=np.intp)
            self._levels.append((members, parents))

    # ------------------------------------------------------------------------------------------ inputs
    @property
    def num_dofs(self) -> int:
        return len(self.dof_names)

    def zero_configuration(self) -> np.ndarray:
        return np.zeros(self.num_dofs)

    def configuration(self, values: Mapping[str, float], base: np.ndarray | None = None) -> np.ndarray:
        """q from a name -> value mapping; joints not named keep ``base`` (default zeros)."""
        q = self.zero_configuration() if base is None else np.array(base, dtype=float)
        for name, value in values.items():
            index = self.dof_index.get(name)
            if index is not None:
                q[index] = value
        return q

    def joint_values(self, q: np.ndarray) -> np.ndarray:
        """Value of every joint in ``joints`` order (mimic applied, 0 for fixed joints)."""
        q = np.asarray(q, dtype=float)
        if q.shape[-1] != self.num_dofs:
            raise ValueError(f"q has {q.shape[-1]} values, the robot has {self.num_dofs} degrees of freedom")
        if self.num_dofs == 0:
            return np.zeros(q.shape[:-1] + (len(self.joints),))
        return q[..., self._q_source] * self._multiplier + self._offset

    # ---------------------------------------------------------------------------------------- outputs
    def local_transforms(self, q: np.ndarray) -> np.ndarray:
        """Parent-link -> child-link transform of every joint: shape ``(..., n_joints, 4, 4)``."""
        values = self.joint_values(q)
        angle = values * self._revolute
        s = np.sin(angle)[..., None, None]
        c = np.cos(angle)[..., None, None]
        rotation = np.eye(3) + s * self._k + (1.0 - c) * self._k2
        out = np.zeros(values.shape + (4, 4))
        out[..., :3, :3] = self._origin_rot @ rotation
        out[..., :3, 3] = self._origin_pos + values[..., None] * self._slide
        out[..., 3, 3] = 1.0
        return out

    def local_poses(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Parent -> child pose of every joint as (translation ``(..., n, 3)``, quaternion xyzw ``(..., n, 4)``).

        What ``tf`` needs, without building matrices: the joint's rotation is the origin quaternion times the
        axis-angle quaternion (axis * sin(q/2), cos(q/2)); about 3x cheaper than matrices + conversion.
        """
        values = self.joint_values(q)
        half = 0.5 * values * self._revolute
        s, c = np.sin(half), np.cos(half)
        bx, by, bz = (self._axes[:, 0] * s, self._axes[:, 1] * s, self._axes[:, 2] * s)
        ax, ay, az, aw = self._origin_quat.T
        quat = np.stack([
            aw * bx + c * ax + ay * bz - az * by,
            aw * by + c * ay + az * bx - ax * bz,
            aw * bz + c * az + ax * by - ay * bx,
            aw * c - ax * bx - ay * by - az * bz,
        ], axis=-1)
        translation = self._origin_pos + values[..., None] * self._slide
        return translation, quat

    def link_transforms(self, q: np.ndarray, local: np.ndarray | None = None) -> np.ndarray:
        """Root -> link transform of every link (``link_names`` order): shape ``(..., n_links, 4, 4)``."""
        if local is None:
            local = self.local_transforms(q)
        batch = local.shape[:-3]
        world = np.empty(batch + (len(self.link_names), 4, 4))
        world[..., 0, :, :] = np.eye(4)
        for members, parents in self._levels:
            # Joint i's child is link i + 1 (link_names = [root] + children in joint order).
            world[..., members + 1, :, :] = world[..., parents, :, :] @ local[..., members, :, :]
        return world

    def link_transform(self, q: np.ndarray, link: str) -> np.ndarray:
        if link not in self.link_index:
            raise KeyError(f"unknown link '{link}'")
        return self.link_transforms(q)[..., self.link_index[link], :, :]


def matrix_to_quaternion(rotation: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` -> unit quaternions ``(..., 4)`` as (x, y, z, w), w >= 0.

    Shepperd's method, vectorised: compute the four candidate forms and keep, per matrix, the one with the
    largest divisor (numerically stable near 180 degrees).
    """
    m = np.asarray(rotation, dtype=float)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    trace = m00 + m11 + m22
    candidates = np.stack([
        np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1],
                  1.0 + trace], axis=-1),
        np.stack([1.0 + m00 - m11 - m22, m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0],
                  m[..., 2, 1] - m[..., 1, 2]], axis=-1),
        np.stack([m[..., 0, 1] + m[..., 1, 0], 1.0 - m00 + m11 - m22, m[..., 1, 2] + m[..., 2, 1],
                  m[..., 0, 2] - m[..., 2, 0]], axis=-1),
        np.stack([m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1], 1.0 - m00 - m11 + m22,
                  m[..., 1, 0] - m[..., 0, 1]], axis=-1),
    ], axis=-2)
    diag = np.stack([trace, m00, m11, m22], axis=-1)
    best = np.argmax(diag, axis=-1)
    quat = np.take_along_axis(candidates, best[..., None, None], axis=-2)[..., 0, :]
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    return np.where(quat[..., 3:4] < 0, -quat, quat)


def quaternion_to_matrix(quat: Sequence[float] | np.ndarray) -> np.ndarray:
    """(x, y, z, w) -> 3x3 rotation (batched); the quaternion is normalised first."""
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def pose_matrix(position: Sequence[float], quaternion_xyzw: Sequence[float]) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = quaternion_to_matrix(quaternion_xyzw)
    out[:3, 3] = position
    return out
