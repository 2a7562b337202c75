"""Pushes summed per link and joint before they reach DART: the same motion as each applied on its own, and
the caps on what may be pending."""

from __future__ import annotations

import math

import dartpy as dart
import numpy as np
import pytest

from nodes.sim.pushes import MAX_PENDING, MAX_PER_TARGET, LinkWrench, Pushes, PushLimitError


def _body() -> tuple[dart.simulation.World, dart.dynamics.BodyNode]:
    world = dart.simulation.World()
    world.setGravity([0.0, 0.0, 0.0])
    world.setTimeStep(0.001)
    skeleton = dart.dynamics.Skeleton("s")
    joint, body = skeleton.createFreeJointAndBodyNodePair(None)
    body.setInertia(dart.dynamics.Inertia(2.0, np.zeros(3), np.diag([0.1, 0.2, 0.3])))
    pose = np.eye(4)
    pose[:3, :3] = dart.math.eulerXYZToMatrix([0.3, -0.2, 0.5])
    iso = dart.math.Isometry3()
    iso.set_matrix(pose)
    joint.setPositions(dart.dynamics.FreeJoint.convertToPositions(iso))
    world.addSkeleton(skeleton)
    return world, body


@pytest.mark.parametrize("offsets", [[(0, 0.1, 0)] * 3, [(0, 0.1, 0), (0.2, 0, 0.1), (0, 0, 0)]])
def test_summed_wrenches_move_a_link_as_each_one_applied_alone(offsets):
    forces = [(1.0, 0.0, 0.0), (0.0, 2.0, 0.0), (0.0, 0.0, -1.0)]
    finals = []
    for summed in (False, True):
        world, body = _body()
        pushes = Pushes()
        for force, offset in zip(forces, offsets, strict=True):
            pushes.wrenches.append(LinkWrench("s", "s::l", body, np.array(force), np.array([0.0, 0.0, 0.1]),
                                              np.array(offset, dtype=float), 0.0, math.inf))
        for _ in range(300):
            if summed:
                pushes.apply(world.getTime())
            else:
                for w in pushes.wrenches:
                    body.addExtForce(w.force, w.offset, False, True)
                    body.addExtTorque(w.torque, False)
            world.step()
        finals.append(np.asarray(body.getWorldTransform().matrix()))
    assert np.abs(finals[0] - np.eye(4)).max() > 0.01          # it moved
    assert finals[1] == pytest.approx(finals[0], abs=1e-12)


def test_caps_per_link_in_total_and_the_start_horizon():
    _, body = _body()
    pushes = Pushes()

    def wrench(link: str, start: float = 0.0) -> LinkWrench:
        return LinkWrench("s", link, body, np.zeros(3), np.zeros(3), np.zeros(3), start, math.inf)

    for _ in range(MAX_PER_TARGET):
        pushes.add_wrench(wrench("s::a"), 0.0)
    with pytest.raises(PushLimitError, match=f"the limit per link is {MAX_PER_TARGET}"):
        pushes.add_wrench(wrench("s::a"), 0.0)
    links = iter(range(1000))
    with pytest.raises(PushLimitError, match=f"the limit in total is {MAX_PENDING}"):
        while True:
            pushes.add_wrench(wrench(f"s::{next(links)}"), 0.0)
    assert len(pushes.wrenches) == MAX_PENDING
    pushes.clear()
    with pytest.raises(PushLimitError, match="beyond the 3600 s horizon"):
        pushes.add_wrench(wrench("s::a", start=2.0**31), 0.0)
