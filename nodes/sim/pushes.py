"""Forces from outside the robot: wrenches on links and efforts on joints for a span of sim time
(gazebo_ros' apply_link_wrench / apply_joint_effort). DART clears external forces and joint forces after
every step, so the active ones are applied again before each step until they expire or are cleared."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass
class LinkWrench:
    model: str
    link: str                  # "model::link"
    body: object               # DART BodyNode
    force: np.ndarray          # world frame
    torque: np.ndarray         # world frame
    offset: np.ndarray         # where the force acts, in the link's frame
    start: float               # sim s
    end: float                 # sim s (inf: until cleared)


@dataclass
class JointEffort:
    model: str
    joint: str                 # "model::joint"
    dart_joint: object
    effort: float
    start: float
    end: float


class Pushes:
    """The wrenches and efforts in effect; ``apply`` is called before each physics step."""

    def __init__(self) -> None:
        self.wrenches: list[LinkWrench] = []
        self.efforts: list[JointEffort] = []

    def __bool__(self) -> bool:
        return bool(self.wrenches or self.efforts)

    @staticmethod
    def span(now: float, start: float, duration: float, dt: float) -> tuple[float, float]:
        """(start, end) in sim time: a start in the past is now; a negative duration lasts until cleared; a
        duration shorter than a step lasts one step."""
        begin = max(now, start)
        end = math.inf if duration < 0 else begin + max(duration, dt * 0.999)
        return begin, end

    def add_wrench(self, wrench: LinkWrench) -> None:
        self.wrenches.append(wrench)

    def add_effort(self, effort: JointEffort) -> None:
        self.efforts.append(effort)

    def clear_link(self, link: str) -> int:
        before = len(self.wrenches)
        self.wrenches = [w for w in self.wrenches if w.link != link]
        return before - len(self.wrenches)

    def clear_joint(self, joint: str) -> int:
        before = len(self.efforts)
        self.efforts = [e for e in self.efforts if e.joint != joint]
        return before - len(self.efforts)

    def drop_model(self, model: str) -> None:
        """A deleted model's bodies and joints are gone: forget what pushed them."""
        self.wrenches = [w for w in self.wrenches if w.model != model]
        self.efforts = [e for e in self.efforts if e.model != model]

    def clear(self) -> None:
        self.wrenches.clear()
        self.efforts.clear()

    def apply(self, now: float, wake: Callable[[str], None] | None = None) -> None:
        """Add the wrenches and efforts active at sim time ``now``; drop the expired ones. ``wake(model)`` is
        called for every model pushed now (a model asleep at rest takes part in the physics again)."""
        if any(w.end <= now for w in self.wrenches):
            self.wrenches = [w for w in self.wrenches if w.end > now]
        if any(e.end <= now for e in self.efforts):
            self.efforts = [e for e in self.efforts if e.end > now]
        for wrench in self.wrenches:
            if wrench.start <= now:
                if wake is not None:
                    wake(wrench.model)
                wrench.body.addExtForce(wrench.force, wrench.offset, False, True)
                wrench.body.addExtTorque(wrench.torque, False)
        for effort in self.efforts:
            if effort.start <= now:
                if wake is not None:
                    wake(effort.model)
                joint = effort.dart_joint
                joint.setForce(0, joint.getForce(0) + effort.effort)
