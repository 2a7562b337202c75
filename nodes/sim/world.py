"""The DART world: time step, gravity, collision detector and the optional ground plane."""

from __future__ import annotations

import math

import dartpy as dart
import numpy as np

GROUND_NAME = "ground_plane"
GROUND_THICKNESS = 0.1
COLLISION_DETECTORS = ("fcl", "dart", "bullet", "ode")


def _make_detector(kind: str):
    factories = {
        "fcl": dart.collision.FCLCollisionDetector,
        "dart": dart.collision.DARTCollisionDetector,
        "bullet": getattr(dart.collision, "BulletCollisionDetector", None),
        "ode": getattr(dart.collision, "OdeCollisionDetector", None),
    }
    factory = factories.get(kind)
    if factory is None:
        raise ValueError(f"collision_detector {kind!r} is not available (choose from {', '.join(COLLISION_DETECTORS)})")
    return factory()


class PhysicsWorld:
    """One DART world plus the settings Gazebo exposes as physics properties."""

    def __init__(self, physics_rate: float = 1000.0, gravity: tuple[float, float, float] = (0.0, 0.0, -9.81),
                 collision_detector: str = "fcl") -> None:
        if not (math.isfinite(physics_rate) and physics_rate > 0):
            raise ValueError(f"physics_rate must be a positive number, got {physics_rate}")
        self.world = dart.simulation.World()
        self.set_time_step(1.0 / physics_rate)
        self.collision_detector = collision_detector
        self.world.getConstraintSolver().setCollisionDetector(_make_detector(collision_detector))
        self.set_gravity(gravity)
        self.ground: dart.dynamics.Skeleton | None = None
        self._static_bodies: list = []   # bodies of static models and the ground (never collide with each other)
        self._static_names: set[str] = set()
        self.ground_size = 0.0
        self.ground_friction = 1.0

    # -- time -------------------------------------------------------------------------------------------
    @property
    def time_step(self) -> float:
        return self._time_step   # kept here: read every control period, and only set_time_step changes it

    def set_time_step(self, time_step: float) -> None:
        self.world.setTimeStep(time_step)
        self._time_step = self.world.getTimeStep()

    @property
    def physics_rate(self) -> float:
        return 1.0 / self.world.getTimeStep()

    @property
    def time(self) -> float:
        return self.world.getTime()

    def step(self) -> None:
        self.world.step()

    def reset_collision(self) -> None:
        """A fresh collision detector: its broad-phase tree orders contacts, so a reset that keeps the old
        one is not bit-identical to a fresh start (measured: 1e-13 rad apart after 200 steps)."""
        solver = self.world.getConstraintSolver()
        solver.setCollisionDetector(_make_detector(self.collision_detector))
        solver.clearLastCollisionResult()   # its contacts point into the old detector's objects

    # -- gravity ----------------------------------------------------------------------------------------
    def set_gravity(self, gravity) -> None:
        vector = np.asarray(gravity, dtype=float).reshape(-1)
        if vector.shape != (3,) or not np.all(np.isfinite(vector)):
            raise ValueError(f"gravity must be three finite numbers, got {list(np.ravel(gravity))}")
        self.world.setGravity(vector)
        g = self.world.getGravity()
        self._gravity = (float(g[0]), float(g[1]), float(g[2]))

    @property
    def gravity(self) -> tuple[float, float, float]:
        return self._gravity   # kept here: the sensors read it every control period, only set_gravity changes it

    # -- ground -----------------------------------------------------------------------------------------
    def add_ground(self, size: float = 50.0, friction: float = 1.0, pose: np.ndarray | None = None) -> None:
        """A static box whose top face is z = 0 (Gazebo's ``ground_plane`` model), or the x-y plane of
        ``pose`` (4x4, a world file's ``<include>`` of it)."""
        if not (math.isfinite(size) and size > 0):
            raise ValueError(f"ground size must be positive, got {size}")
        if not (math.isfinite(friction) and friction >= 0):
            raise ValueError(f"ground friction must be >= 0, got {friction}")
        self.remove_ground()
        ground = dart.dynamics.Skeleton(GROUND_NAME)
        _, body = ground.createWeldJointAndBodyNodePair()
        body.setName("link")
        shape = dart.dynamics.BoxShape([size, size, GROUND_THICKNESS])
        node = body.createShapeNode(shape)
        node.createVisualAspect()
        node.createCollisionAspect()
        node.createDynamicsAspect().setFrictionCoeff(friction)
        below = np.eye(4)
        below[2, 3] = -GROUND_THICKNESS / 2
        placed = (np.eye(4) if pose is None else pose) @ below
        offset = dart.math.Isometry3()
        offset.set_rotation(placed[:3, :3])
        offset.set_translation(placed[:3, 3])
        body.getParentJoint().setTransformFromParentBodyNode(offset)
        self.world.addSkeleton(ground)
        self.mark_static(ground)
        self.ground, self.ground_size, self.ground_friction = ground, size, friction

    def remove_ground(self) -> bool:
        if self.ground is None:
            return False
        self.remove_skeleton(self.ground)
        self.ground = None
        return True

    def mark_static(self, skeleton) -> None:
        """A skeleton that never moves: its bodies and those of the other static ones are not checked for
        collisions (a table standing on the ground made four contacts a step for nothing: measured 39 against
        16 us a step for simple_lab.world's static models)."""
        collision_filter = self.world.getConstraintSolver().getCollisionOption().collisionFilter
        bodies = [skeleton.getBodyNode(i) for i in range(skeleton.getNumBodyNodes())]
        for body in bodies:
            for other in self._static_bodies:
                collision_filter.addBodyNodePairToBlackList(body, other)
        self._static_bodies.extend(bodies)
        self._static_names.add(skeleton.getName())

    def is_static(self, name: str) -> bool:
        """The skeleton of this name never moves now (a static model, the ground, a model asleep)."""
        return name in self._static_names

    def unmark_static(self, skeleton) -> None:
        """The skeleton moves again: its contacts with the static ones are checked again."""
        name = skeleton.getName()
        self._static_names.discard(name)
        gone = [b for b in self._static_bodies if b.getSkeleton().getName() == name]
        if not gone:
            return
        self._static_bodies = [b for b in self._static_bodies if b.getSkeleton().getName() != name]
        collision_filter = self.world.getConstraintSolver().getCollisionOption().collisionFilter
        for body in gone:
            for other in self._static_bodies:
                collision_filter.removeBodyNodePairFromBlackList(body, other)

    def remove_skeleton(self, skeleton) -> None:
        """Remove a skeleton and forget the last step's contacts, which point into its collision objects
        (reading them after the removal is a use-after-free: measured as a crash)."""
        self.unmark_static(skeleton)
        self.world.removeSkeleton(skeleton)
        self.world.getConstraintSolver().clearLastCollisionResult()

    @property
    def has_ground(self) -> bool:
        return self.ground is not None

    # -- contacts ---------------------------------------------------------------------------------------
    def contacts(self):
        """Contacts found by the last step's collision detection."""
        return self.world.getLastCollisionResult().getContacts()
