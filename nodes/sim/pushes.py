"""Forces from outside the robot: wrenches on links and efforts on joints for a span of sim time
(gazebo_ros' apply_link_wrench / apply_joint_effort). DART clears external forces and joint forces after
every step, so the active ones are applied again before each step until they expire or are cleared."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

# Each pending push is applied again before every physics step (two DART calls, ~5 us, a push), so their
# number is the physics loop's cost: capped per link or joint and in total (wrenches and efforts together),
# pending ones counted (active or still to start). A start further ahead than the horizon is refused: it would
# only be held, unseen, until then.
MAX_PER_TARGET = 8
MAX_PENDING = 32
START_HORIZON_S = 3600.0


class PushLimitError(ValueError):
    """A push over one of the caps (the message names the cap and its value)."""


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

    @staticmethod
    def check_start(now: float, start: float, field: str = "start_time") -> None:
        """Refuse a start beyond ``START_HORIZON_S`` of sim time from now."""
        if start - now > START_HORIZON_S:
            raise PushLimitError(f"{field}: {start:.6g} s is {start - now:.6g} s ahead of the sim time "
                                 f"{now:.3f} s, beyond the {START_HORIZON_S:g} s horizon")

    def _check_room(self, pending: list, target: str, now: float, what: str, per: str) -> None:
        on_target = sum(1 for p in pending if p.end > now and getattr(p, per) == target)
        if on_target >= MAX_PER_TARGET:
            raise PushLimitError(f"{target!r} already has {on_target} pending {what}, the limit per {per} is "
                                 f"{MAX_PER_TARGET} (clear them first)")
        live = sum(1 for p in (*self.wrenches, *self.efforts) if p.end > now)
        if live >= MAX_PENDING:
            raise PushLimitError(f"{live} wrenches and efforts are pending, the limit in total is {MAX_PENDING} "
                                 "(clear some first)")

    def add_wrench(self, wrench: LinkWrench, now: float) -> None:
        """Add a wrench; raises PushLimitError over a cap (the world unchanged)."""
        self.check_start(now, wrench.start)
        self._check_room(self.wrenches, wrench.link, now, "wrenches", "link")
        self.wrenches.append(wrench)

    def add_effort(self, effort: JointEffort, now: float) -> None:
        """Add an effort; raises PushLimitError over a cap (the world unchanged)."""
        self.check_start(now, effort.start)
        self._check_room(self.efforts, effort.joint, now, "efforts", "joint")
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
