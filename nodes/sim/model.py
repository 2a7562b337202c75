"""A model in the simulated world (a spawned robot or a world file's model): its skeleton, its pose and
twist in the world, its links by name, moving it, and putting it back where it was spawned.

A model's frame is its root link's frame for a URDF robot and the SDF model frame for a world's model (the
root link's pose in the model is ``root_offset``). A skeleton may hold several trees (an SDF model's links
that no joint connects): moving the model moves every tree as one rigid whole, as Gazebo does.
"""

from __future__ import annotations

import dartpy as dart
import numpy as np

from nodes.sim.pose import Pose


def isometry(matrix: np.ndarray) -> dart.math.Isometry3:
    iso = dart.math.Isometry3()
    iso.set_rotation(matrix[:3, :3])
    iso.set_translation(matrix[:3, 3])
    return iso


class Model:
    """What every entity has, whatever file it came from."""

    name: str
    skeleton: dart.dynamics.Skeleton
    static = False
    root_offset: np.ndarray = np.eye(4)   # the root link's pose in the model frame

    def remember_spawn(self) -> None:
        """The state ``reset`` returns to: joint positions and where each welded tree is fixed."""
        self.spawn_positions = np.array(self.skeleton.getPositions(), dtype=float)
        self.spawn_anchors = [self._root_joint(i).getTransformFromParentBodyNode().matrix().copy()
                              for i in range(self.skeleton.getNumTrees())]

    def reset(self) -> None:
        """Back to the spawn pose and joint positions, at rest."""
        for i, anchor in enumerate(self.spawn_anchors):
            joint = self._root_joint(i)
            if not isinstance(joint, dart.dynamics.FreeJoint):
                joint.setTransformFromParentBodyNode(isometry(anchor))
        self.skeleton.setPositions(self.spawn_positions)
        self.skeleton.resetVelocities()
        self.skeleton.resetAccelerations()
        self.skeleton.resetCommands()
        self.skeleton.clearExternalForces()

    def _root_joint(self, tree: int):
        return self.skeleton.getRootBodyNode(tree).getParentJoint()

    # -- the model as a whole ---------------------------------------------------------------------------
    def world_matrix(self) -> np.ndarray:
        root = self.skeleton.getRootBodyNode().getWorldTransform().matrix()
        offset = self.root_offset
        if offset is not self.__dict__.get("_inverted"):   # root_offset is set once, after construction
            self._inverse = None if np.array_equal(offset, np.eye(4)) else np.linalg.inv(offset)
            self._inverted = offset
        # sim/model_states asks for every model 100 times a simulated second: the inverse once, not per call
        return root if self._inverse is None else root @ self._inverse

    def world_pose(self) -> Pose:
        return Pose.from_matrix(self.world_matrix())

    def world_twist(self) -> tuple[np.ndarray, np.ndarray]:
        """(linear, angular) velocity of the root link in the world frame."""
        body = self.skeleton.getRootBodyNode()
        return np.asarray(body.getLinearVelocity()), np.asarray(body.getAngularVelocity())

    def set_world_pose(self, pose: Pose) -> None:
        """Move the model (every tree of it, rigidly) so that its frame is at ``pose``."""
        delta = pose.to_isometry().matrix() @ np.linalg.inv(self.world_matrix())
        for i in range(self.skeleton.getNumTrees()):
            joint = self._root_joint(i)
            if isinstance(joint, dart.dynamics.FreeJoint):
                current = self.skeleton.getRootBodyNode(i).getWorldTransform().matrix()
                joint.setPositions(dart.dynamics.FreeJoint.convertToPositions(isometry(delta @ current)))
            else:
                anchor = joint.getTransformFromParentBodyNode().matrix()
                joint.setTransformFromParentBodyNode(isometry(delta @ anchor))

    def set_world_twist(self, linear: np.ndarray, angular: np.ndarray) -> None:
        """The model's free trees move with this twist (of the model frame's origin, world coordinates)."""
        origin = self.world_matrix()[:3, 3]
        world = dart.dynamics.Frame.World()
        for i in range(self.skeleton.getNumTrees()):
            joint = self._root_joint(i)
            if isinstance(joint, dart.dynamics.FreeJoint):
                offset = np.asarray(self.skeleton.getRootBodyNode(i).getWorldTransform().translation()) - origin
                velocity = np.concatenate([angular, linear + np.cross(angular, offset)])
                joint.setSpatialVelocity(velocity, world, world)

    # -- links ------------------------------------------------------------------------------------------
    def link_names(self) -> list[str]:
        return [self.skeleton.getBodyNode(i).getName() for i in range(self.skeleton.getNumBodyNodes())]

    def body(self, link: str):
        """The link's body node, or None."""
        return self.skeleton.getBodyNode(link) if link in self.link_names() else None

    def joint(self, name: str):
        """A joint with degrees of freedom, or None."""
        joint = self.skeleton.getJoint(name)
        return joint if joint is not None and joint.getNumDofs() > 0 else None

    @staticmethod
    def set_free_link_state(body, matrix: np.ndarray, linear: np.ndarray, angular: np.ndarray) -> bool:
        """Place a link a free joint holds (world frame); False when a joint holds it to another link."""
        joint = body.getParentJoint()
        if not isinstance(joint, dart.dynamics.FreeJoint):
            return False
        joint.setPositions(dart.dynamics.FreeJoint.convertToPositions(isometry(matrix)))
        world = dart.dynamics.Frame.World()
        joint.setSpatialVelocity(np.concatenate([angular, linear]), world, world)
        return True
