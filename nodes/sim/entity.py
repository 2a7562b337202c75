"""Entities: a URDF turned into a DART skeleton, placed at its spawn pose, and put back there on reset."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import dartpy as dart
import numpy as np

from nodes.sim.geometry import pose_from_xyz_rpy, quaternion_from_rotation
from nodes.sim.urdf_info import RobotInfo, parse_urdf

_NAME = re.compile(r"^[A-Za-z0-9_.\-]+$")   # entity names and namespace parts: safe in key expressions


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


@dataclass
class EntitySpec:
    """Everything a spawn needs (the SpawnEntity request plus our fixed-base / initial-joint options)."""

    name: str
    xml: str
    namespace: str = ""
    pose: Pose = field(default_factory=Pose)
    fixed: bool = False
    initial_positions: dict[str, float] = field(default_factory=dict)
    base_uri: str = ""            # where relative mesh paths resolve (the URDF file's path)


class Entity:
    """A spawned model: its skeleton, URDF info and spawn state (for reset_world)."""

    def __init__(self, spec: EntitySpec) -> None:
        if not _NAME.match(spec.name or ""):
            raise SpawnError(f"name {spec.name!r} must be letters, digits, '_', '-' or '.'")
        self.spec = spec
        self.name = spec.name
        self.namespace = (spec.namespace or spec.name).strip("/")
        if not all(_NAME.match(part) for part in self.namespace.split("/")):
            raise SpawnError(f"robot_namespace {spec.namespace!r} must be '/'-separated names of letters, digits, "
                             "'_', '-' or '.'")
        self.info: RobotInfo = parse_urdf(spec.xml)
        self.pose = spec.pose.validated()
        self.skeleton = self._load_skeleton(spec)
        self.skeleton.setName(spec.name)
        self.floating = not spec.fixed and isinstance(self.skeleton.getRootJoint(), dart.dynamics.FreeJoint)
        # DART's DOF order differs from the URDF: map every movable joint by name once.
        self.dof_index: dict[str, int] = {}
        for joint in self.info.joints:
            dart_joint = self.skeleton.getJoint(joint.name)
            if dart_joint is None or dart_joint.getNumDofs() != 1:
                raise SpawnError(f"joint {joint.name!r} was not loaded by DART as a 1-DOF joint")
            dart_joint.setLimitEnforcement(joint.type != "continuous")
            self.dof_index[joint.name] = int(dart_joint.getIndexInSkeleton(0))
        self._place(self.pose)
        self._apply_initial_positions(spec.initial_positions)
        self.spawn_positions = np.array(self.skeleton.getPositions(), dtype=float)

    @staticmethod
    def _load_skeleton(spec: EntitySpec) -> dart.dynamics.Skeleton:
        loader = dart.utils.DartLoader()
        flags = dart.utils.DartLoaderFlags.FIXED_BASE_LINK if spec.fixed else dart.utils.DartLoaderFlags.NONE
        uri = dart.common.Uri(spec.base_uri or "file:///")
        skeleton = loader.parseSkeletonString(spec.xml, uri, dart.common.LocalResourceRetriever(), flags)
        if skeleton is None:
            raise SpawnError(f"DART could not load the URDF of {spec.name!r} (a mesh file that cannot be read? "
                             "see the simulator log)")
        return skeleton

    def _place(self, pose: Pose) -> None:
        root = self.skeleton.getRootJoint()
        iso = pose.to_isometry()
        if isinstance(root, dart.dynamics.FreeJoint):
            root.setPositions(dart.dynamics.FreeJoint.convertToPositions(iso))
        else:
            # fixed base: the weld joint's offset from the world is the spawn pose
            root.setTransformFromParentBodyNode(iso)

    def _apply_initial_positions(self, positions: dict[str, float]) -> None:
        for joint_name, value in positions.items():
            if joint_name not in self.dof_index:
                raise SpawnError(f"initial joint position for unknown joint {joint_name!r}")
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise SpawnError(f"initial position of joint {joint_name!r} is not a finite number: {value!r}")
            joint = self.info.joint(joint_name)
            if not joint.min_position <= value <= joint.max_position:
                raise SpawnError(f"initial position {value} of joint {joint_name!r} is outside "
                                 f"[{joint.min_position}, {joint.max_position}]")
            self.skeleton.setPosition(self.dof_index[joint_name], float(value))

    def reset(self) -> None:
        """Back to the spawn pose and joint positions, at rest."""
        self.skeleton.setPositions(self.spawn_positions)
        self.skeleton.resetVelocities()
        self.skeleton.resetAccelerations()
        self.skeleton.resetCommands()
        self.skeleton.clearExternalForces()

    # -- model_states -----------------------------------------------------------------------------------
    def world_pose(self) -> Pose:
        return Pose.from_matrix(self.skeleton.getRootBodyNode().getWorldTransform().matrix())

    def world_twist(self) -> tuple[np.ndarray, np.ndarray]:
        """(linear, angular) velocity of the root link in the world frame."""
        body = self.skeleton.getRootBodyNode()
        return np.asarray(body.getLinearVelocity()), np.asarray(body.getAngularVelocity())
