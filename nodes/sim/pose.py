"""A pose in the world (the geometry_msgs/Pose layout) and the error a spawn or move with a bad one raises."""

from __future__ import annotations

import math
from dataclasses import dataclass

import dartpy as dart
import numpy as np

from nodes.sim.geometry import pose_from_xyz_rpy, quaternion_from_rotation


class SpawnError(ValueError):
    """A spawn request that cannot be honoured (the message says which field and why)."""


@dataclass
class Pose:
    """Position + unit quaternion (x, y, z, w), the geometry_msgs/Pose layout."""

    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)

    @classmethod
    def from_xyz_rpy(cls, x: float, y: float, z: float, roll: float = 0.0, pitch: float = 0.0,
                     yaw: float = 0.0) -> Pose:
        position, orientation = pose_from_xyz_rpy(x, y, z, roll, pitch, yaw)
        return cls(position, orientation)

    def validated(self) -> Pose:
        """The same pose with a normalised quaternion; raises SpawnError on NaN/inf or a zero quaternion."""
        values = [*self.position, *self.orientation]
        if len(self.position) != 3 or len(self.orientation) != 4:
            raise SpawnError("initial_pose must have a 3-D position and a 4-D orientation")
        if not all(math.isfinite(v) for v in values):
            raise SpawnError(f"initial_pose contains NaN or infinity: {values}")
        norm = math.sqrt(sum(q * q for q in self.orientation))
        if norm < 1e-9:
            # ROS messages default to an all-zero quaternion: read it as "no rotation"
            return Pose(tuple(self.position), (0.0, 0.0, 0.0, 1.0))
        return Pose(tuple(self.position), tuple(q / norm for q in self.orientation))

    def to_isometry(self) -> dart.math.Isometry3:
        x, y, z, w = self.orientation
        rotation = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ])
        iso = dart.math.Isometry3()
        iso.set_rotation(rotation)
        iso.set_translation(np.asarray(self.position, dtype=float))
        return iso

    @classmethod
    def from_matrix(cls, matrix: np.ndarray) -> Pose:
        return cls(tuple(float(v) for v in matrix[:3, 3]), quaternion_from_rotation(matrix[:3, :3]))

    def compose(self, child: Pose) -> Pose:
        return Pose.from_matrix(self.to_isometry().matrix() @ child.to_isometry().matrix())
