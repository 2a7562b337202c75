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
        self._key: tuple | None = None                 # the active pushes the sums below are of
        self._summed: tuple[list, list, list] = ([], [], [])

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
        self._key = None

    def add_effort(self, effort: JointEffort, now: float) -> None:
        """Add an effort; raises PushLimitError over a cap (the world unchanged)."""
        self.check_start(now, effort.start)
        self._check_room(self.efforts, effort.joint, now, "efforts", "joint")
        self.efforts.append(effort)
        self._key = None

    def clear_link(self, link: str) -> int:
        self._key = None
        before = len(self.wrenches)
        self.wrenches = [w for w in self.wrenches if w.link != link]
        return before - len(self.wrenches)

    def clear_joint(self, joint: str) -> int:
        self._key = None
        before = len(self.efforts)
        self.efforts = [e for e in self.efforts if e.joint != joint]
        return before - len(self.efforts)

    def drop_model(self, model: str) -> None:
        """A deleted model's bodies and joints are gone: forget what pushed them."""
        self._key = None
        self.wrenches = [w for w in self.wrenches if w.model != model]
        self.efforts = [e for e in self.efforts if e.model != model]

    def clear(self) -> None:
        self._key = None
        self.wrenches.clear()
        self.efforts.clear()

    def apply(self, now: float, wake: Callable[[str], None] | None = None) -> None:
        """Add the wrenches and efforts active at sim time ``now``; drop the expired ones. ``wake(model)`` is
        called for every model pushed now (a model asleep at rest takes part in the physics again).

        Wrenches on one link, and efforts on one joint, go to DART summed: a DART call costs ~10 us on a
        robot's body, and held pushes are applied again every step. The sums are kept while the set of
        active pushes stays the same."""
        if any(w.end <= now for w in self.wrenches):
            self.wrenches = [w for w in self.wrenches if w.end > now]
        if any(e.end <= now for e in self.efforts):
            self.efforts = [e for e in self.efforts if e.end > now]
        wrenches = [w for w in self.wrenches if w.start <= now]
        efforts = [e for e in self.efforts if e.start <= now]
        key = (*map(id, wrenches), None, *map(id, efforts))
        if key != self._key:   # (every change of the lists resets _key: an id is never met again stale)
            self._key = key
            self._summed = _summed(wrenches, efforts)
        models, summed_wrenches, summed_efforts = self._summed
        if wake is not None:
            for model in models:
                wake(model)
        for body, force, offset, torque, spread in summed_wrenches:
            if spread is not None:   # forces at several points of the link: about its origin, in the world
                offsets, forces = spread
                # sum of (R o_i) x F_i: the antisymmetric part of sum F_i (R o_i)^T (np.cross costs 20x more)
                m = forces.T @ (offsets @ body.getWorldTransform().rotation().T)
                torque = torque + np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
            body.addExtForce(force, offset, False, True)
            body.addExtTorque(torque, False)
        for joint, effort in summed_efforts:
            joint.setForce(0, joint.getForce(0) + effort)


def _summed(wrenches: list[LinkWrench], efforts: list[JointEffort]) -> tuple[list, list, list]:
    """(models pushed, [(body, force, offset, torque, spread)] per link, [(joint, effort)] per joint). A link
    pushed at one point gets the sums at that point (spread None); at several, the summed force at its origin,
    the summed torques, and spread = (offsets, forces) for the moments, which turn with the link."""
    models = list(dict.fromkeys([w.model for w in wrenches] + [e.model for e in efforts]))
    by_body: dict[int, list[LinkWrench]] = {}
    for w in wrenches:
        by_body.setdefault(id(w.body), []).append(w)
    summed = []
    for group in by_body.values():
        force = np.sum([w.force for w in group], axis=0)
        torque = np.sum([w.torque for w in group], axis=0)
        offsets = np.array([w.offset for w in group])
        if np.all(offsets == offsets[0]):
            summed.append((group[0].body, force, group[0].offset, torque, None))
        else:
            summed.append((group[0].body, force, np.zeros(3), torque,
                           (offsets, np.array([w.force for w in group]))))
    by_joint: dict[int, list] = {}
    for e in efforts:
        by_joint.setdefault(id(e.dart_joint), [e.dart_joint, 0.0])[1] += e.effort
    return models, summed, [tuple(v) for v in by_joint.values()]
