"""World models at rest leave the physics until something touches them.

A world file's free boxes, books and balls lie still most of the time, yet DART detects and solves their
contacts with the floor every step while anything else in the world moves (the humanoid always does): in
simple_lab.world that was +41 % of the physics step's instructions. DART's own deactivation puts the whole
world to sleep only when everything is still, so this does it model by model, as Gazebo's and Bullet's
islands do:

- a dynamic world model (never a robot) whose every degree of freedom has moved slower than the thresholds
  for ``SLEEP_AFTER_S`` is made immobile (DART then leaves it out of the dynamics) and its bodies join the
  static ones, whose contacts with each other and with the ground are never checked;
- it wakes (mobile again, its contacts checked) when a moving body touches it, when a request moves it or
  pushes it (``wake``), and on a reset.

Checked every ``CHECK_EVERY`` steps (10 ms at 1 kHz), with one native collision check of the sleepers against
the moving skeletons: the cost of looking must stay below what sleeping saves. So a body that touches a
sleeper meets an immovable one for up to that long before it wakes. Deterministic: the same states
make the same decisions, so lockstep runs stay bit-identical.
"""

from __future__ import annotations

from dataclasses import dataclass

import dartpy as dart
import numpy as np

from nodes.sim.world import PhysicsWorld

SLEEP_AFTER_S = 0.5        # still for this long (sim time): asleep
LINEAR_SPEED = 0.01        # m/s (and rad/s for rotations): slower than this is still
CHECK_EVERY = 10           # steps between looks at the speeds


@dataclass
class _Sleeper:
    skeleton: object
    still_steps: int = 0
    asleep: bool = False


class RestKeeper:
    def __init__(self, world: PhysicsWorld) -> None:
        self.world = world
        self.models: dict[str, _Sleeper] = {}        # by skeleton name
        self._since_check = 0
        self._sleeping = 0            # models asleep now
        self._cached = None           # (collision detector, sleepers' group, movers' group)
        self._dirty = True
        self._option = dart.collision.CollisionOption()
        self._option.maxNumContacts = 64

    # -- which models -------------------------------------------------------------------------------------
    def track(self, name: str, skeleton) -> None:
        """A dynamic world model that may sleep."""
        self.models[name] = _Sleeper(skeleton)

    def forget(self, name: str) -> None:
        sleeper = self.models.pop(name, None)
        if sleeper is not None and sleeper.asleep:
            self._wake(sleeper)

    @property
    def asleep(self) -> list[str]:
        return [name for name, sleeper in self.models.items() if sleeper.asleep]

    # -- every step ---------------------------------------------------------------------------------------
    def after_step(self) -> None:
        if not self.models:
            return
        self._since_check += 1
        checking = self._since_check >= CHECK_EVERY
        if checking and self._sleeping:
            self._wake_touched()
        if checking:
            steps, self._since_check = self._since_check, 0
            self._look(steps)

    def _look(self, steps: int) -> None:
        still_for = max(1, round(SLEEP_AFTER_S / self.world.time_step))
        for sleeper in self.models.values():
            if sleeper.asleep:
                continue
            speeds = np.asarray(sleeper.skeleton.getVelocities())
            if speeds.size and float(np.abs(speeds).max()) < LINEAR_SPEED:
                sleeper.still_steps += steps
                if sleeper.still_steps >= still_for:
                    self._sleep(sleeper)
            else:
                sleeper.still_steps = 0

    def _wake_touched(self) -> None:
        """Wake every sleeper a moving body touches: one native collision check of the sleepers against the
        moving skeletons (walking the world's contacts in Python cost more than sleeping saved)."""
        sleepers, movers = self._groups()
        result = dart.collision.CollisionResult()
        if not sleepers.collide(movers, self._option, result):
            return
        touched = set()
        for contact in result.getContacts():
            for obj in (contact.collisionObject1, contact.collisionObject2):
                name = obj.getShapeFrame().getSkeleton().getName()
                if name in self.models and self.models[name].asleep:
                    touched.add(name)
        for name in sorted(touched):   # sorted: the same order every run
            self._wake(self.models[name])

    def _groups(self):
        """Collision groups of the sleeping skeletons and of the moving ones (rebuilt when either changes,
        or when the world's collision detector was replaced by a reset)."""
        detector = self.world.world.getConstraintSolver().getCollisionDetector()
        if self._cached is None or self._cached[0] is not detector or self._dirty:
            sleepers, movers = detector.createCollisionGroup(), detector.createCollisionGroup()
            for i in range(self.world.world.getNumSkeletons()):
                skeleton = self.world.world.getSkeleton(i)
                name = skeleton.getName()
                if name in self.models and self.models[name].asleep:
                    sleepers.addShapeFramesOf(skeleton)
                elif not self.world.is_static(name):
                    movers.addShapeFramesOf(skeleton)
            self._cached, self._dirty = (detector, sleepers, movers), False
        return self._cached[1], self._cached[2]

    def changed(self) -> None:
        """A skeleton came or went: the collision groups are built again at the next check."""
        self._dirty = True

    # -- sleeping and waking ------------------------------------------------------------------------------
    def _sleep(self, sleeper: _Sleeper) -> None:
        sleeper.skeleton.resetVelocities()
        sleeper.skeleton.setMobile(False)
        self.world.mark_static(sleeper.skeleton)
        sleeper.asleep = True
        self._sleeping += 1
        self._dirty = True

    def _wake(self, sleeper: _Sleeper) -> None:
        self.world.unmark_static(sleeper.skeleton)
        sleeper.skeleton.setMobile(True)
        sleeper.asleep, sleeper.still_steps = False, 0
        self._sleeping -= 1
        self._dirty = True

    def wake(self, name: str) -> None:
        """A request moves or pushes this model: it takes part in the physics again."""
        sleeper = self.models.get(name)
        if sleeper is not None:
            sleeper.still_steps = 0
            if sleeper.asleep:
                self._wake(sleeper)

    def wake_all(self) -> None:
        for name in list(self.models):
            self.wake(name)
