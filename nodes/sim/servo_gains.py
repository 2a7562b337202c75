"""Joint servo gains from the physics: each joint's stiffness and damping scale with what it moves and carries.

A position servo of stiffness ``kp`` holding a load torque ``tau`` sits ``tau / kp`` off its target, and moves
an inertia ``I`` with a natural frequency ``sqrt(kp / I)``. So for each joint, in the spawn pose:

- the *carried* side: the links beyond the joint, or, for a floating-base robot, the rest of the robot when the
  links beyond it hold it up (a leg: its foot is among the lowest collision geometry), shared among the limbs
  that hold it up;
- its load: that mass times g times its centre of mass's distance from the joint (what it is from the axis
  in the worst pose of the joints around it; for a prismatic joint: the mass times g);
- its inertia about the axis (the mass, for a prismatic joint);
- ``kp = max(load / STATIC_ERROR, inertia * BANDWIDTH**2)``, at most what the links beyond it alone can follow
  at the physics' rate (``inertia_beyond * MAX_FREQUENCY**2``), ``kd = 2 * ratio * sqrt(kp * inertia)``, where the
  damping ratio is light for a floating-base robot and near critical for a fixed-base one.

One rule for a 1 kg cart, a 57 kg humanoid and a 35 kg G1; ``gains:`` in config/sim.yaml overrides it per
joint pattern.
"""

from __future__ import annotations

import math

import dartpy as dart
import numpy as np

from nodes.sim.config import Gains

GRAVITY = 9.81
STATIC_ERROR = 0.015         # rad (m for a prismatic joint) off target under the full static load
BANDWIDTH = 2 * math.pi * 4  # rad/s: the servo's natural frequency on the inertia it moves, at least
# Of the inertia's critical damping (DART's implicit spring adds its own). A standing robot needs light damping:
# near-critical damping on every joint tips a humanoid over. Nothing tips a fixed-base robot (an arm, a cart
# on its rail) over, and lightly damped it rings for seconds after each move, outside a trajectory goal's
# stopped-velocity tolerance.
FLOATING_DAMPING_RATIO = 0.05
FIXED_BASE_DAMPING_RATIO = 0.7
# rad/s: the fastest a servo may make the links beyond it move. Stiffer, a light foot on point contacts
# rings at the physics' step (1 kHz by default) and the robot chatters off its feet.
MAX_FREQUENCY = 1000.0
SUPPORT_BAND = 0.03          # m above the lowest collision geometry: the links that stand on the ground
MIN_GAINS = Gains(kp=1.0, kd=0.01)


def _subtree(body) -> list:
    out, stack = [], [body]
    while stack:
        node = stack.pop()
        out.append(node)
        stack.extend(node.getChildBodyNode(i) for i in range(node.getNumChildBodyNodes()))
    return out


def lowest_points(skeleton) -> dict[str, float]:
    """The lowest world z of each body's collision shapes (bounding boxes), for the bodies that have any."""
    out: dict[str, float] = {}
    for i in range(skeleton.getNumBodyNodes()):
        body = skeleton.getBodyNode(i)
        for j in range(body.getNumShapeNodes()):
            node = body.getShapeNode(j)
            if node.getCollisionAspect() is None:
                continue
            box = node.getShape().getBoundingBox()
            low, high = np.asarray(box.getMin()), np.asarray(box.getMax())
            corners = np.array([[x, y, z, 1.0] for x in (low[0], high[0]) for y in (low[1], high[1])
                                for z in (low[2], high[2])])
            z = float((node.getWorldTransform().matrix() @ corners.T)[2].min())
            name = body.getName()
            out[name] = min(out.get(name, math.inf), z)
    return out


def _axis_inertia(bodies: list, point: np.ndarray, axis: np.ndarray) -> float:
    total = 0.0
    for body in bodies:
        mass = body.getMass()
        rotation = body.getWorldTransform().rotation()
        moment = rotation @ np.asarray(body.getInertia().getMoment()) @ rotation.T
        offset = np.asarray(body.getCOM()) - point
        perpendicular = offset - axis * float(offset @ axis)
        total += float(axis @ moment @ axis) + mass * float(perpendicular @ perpendicular)
    return total


def physics_gains(skeleton, joint_names: list[str], floating: bool) -> dict[str, Gains]:
    """Gains of each named 1-DOF joint of ``skeleton`` in its current pose."""
    bodies = [skeleton.getBodyNode(i) for i in range(skeleton.getNumBodyNodes())]
    supports: set[str] = set()
    if floating:
        lows = lowest_points(skeleton)
        if lows:
            ground = min(lows.values())
            supports = {name for name, z in lows.items() if z <= ground + SUPPORT_BAND}
    damping_ratio = FLOATING_DAMPING_RATIO if floating else FIXED_BASE_DAMPING_RATIO
    out: dict[str, Gains] = {}
    for name in joint_names:
        joint = skeleton.getJoint(name)
        child = joint.getChildBodyNode()
        frame = child.getWorldTransform().matrix() @ joint.getTransformFromChildBodyNode().matrix()
        prismatic = isinstance(joint, dart.dynamics.PrismaticJoint)
        axis = frame[:3, :3] @ np.asarray(joint.getAxis())
        point = frame[:3, 3]
        beyond = _subtree(child)
        beyond_names = {b.getName() for b in beyond}
        held = len(supports & beyond_names)
        if held:   # it holds the rest of the robot up, with the other supports
            rest = [b for b in bodies if b.getName() not in beyond_names]
            carried, share = rest, held / len(supports)
        else:
            carried, share = beyond, 1.0
        mass = sum(b.getMass() for b in carried) * share
        if mass <= 0:
            out[name] = MIN_GAINS
            continue
        com = sum(b.getMass() * np.asarray(b.getCOM()) for b in carried) / sum(b.getMass() for b in carried)
        if prismatic:
            load = mass * GRAVITY
            inertia = mass
            inertia_beyond = sum(b.getMass() for b in beyond)
        else:
            # the distance from the joint, not from the axis in this pose: another pose of the joints around
            # it (an elbow bent under a shoulder's yaw) turns all of it into a lever
            lever = float(np.linalg.norm(com - point))
            load = mass * GRAVITY * lever
            inertia = _axis_inertia(carried, point, axis) * share
            inertia_beyond = _axis_inertia(beyond, point, axis)
        own = inertia_beyond if held else inertia   # what the servo alone swings (a foot, not the body)
        kp = max(min(max(load / STATIC_ERROR, inertia * BANDWIDTH ** 2), own * MAX_FREQUENCY ** 2), MIN_GAINS.kp)
        kd = max(2 * damping_ratio * math.sqrt(kp * inertia), MIN_GAINS.kd)
        out[name] = Gains(kp=kp, kd=kd)
    return out
