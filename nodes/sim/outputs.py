"""What the simulator publishes besides the hardware frames: ``sim/clock``, ``sim/model_states`` and
``sim/link_states`` (with each robot's ``humanoid_state``) on a sim-time schedule, and ``sim/diagnostics``
once a wall second.

Every stream drops rather than blocks on a stalled subscriber: the physics loop must never wait for one."""

from __future__ import annotations

import json
import math
import time
from collections import deque
from collections.abc import Mapping

import msgs
from nodes.core import Node
from nodes.sim.interfaces import Clock, LinkStates, ModelStates, String
from nodes.sim.robot_link import RobotLink
from nodes.sim.simulation import Simulation

_pack_clock = msgs.packer("rosgraph_msgs/msg/Clock")
_pack_model_states = msgs.packer("gazebo_msgs/msg/ModelStates")
_pack_link_states = msgs.packer("gazebo_msgs/msg/LinkStates")
_pose = msgs.builder("geometry_msgs/msg/Pose")
_point = msgs.builder("geometry_msgs/msg/Point")
_quaternion = msgs.builder("geometry_msgs/msg/Quaternion")
_twist = msgs.builder("geometry_msgs/msg/Twist")
_vector3 = msgs.builder("geometry_msgs/msg/Vector3")


class SimOutputs:
    def __init__(self, node: Node, sim: Simulation, robots: Mapping[str, RobotLink], *, clock_rate: float,
                 state_rate: float) -> None:
        """``clock_rate`` and ``state_rate``: messages per simulated second; ``robots`` is the simulator's
        live map of spawned robots (namespace -> link)."""
        self.sim = sim
        self.robots = robots
        self.clock_period = 1.0 / clock_rate
        self.state_period = 1.0 / state_rate
        self.clock_pub = node.create_publisher(Clock, "/sim/clock", express=True, reliable=False)
        self.model_states_pub = node.create_publisher(ModelStates, "/sim/model_states", reliable=False)
        self.link_states_pub = node.create_publisher(LinkStates, "/sim/link_states", reliable=False)
        self.diagnostics_pub = node.create_publisher(String, "/sim/diagnostics")
        self._next_clock = 0.0
        self._next_state = 0.0
        self.lateness: deque[float] = deque(maxlen=5000)   # s behind the wall clock, per paced period
        self._diag_wall = time.monotonic()
        self._diag_sim = 0.0
        self._diag_steps = 0

    def publish(self, force: bool = False) -> None:
        """The clock and the states that are due at the current sim time (all of them when ``force``)."""
        t = self.sim.world.time
        eps = 1e-9
        if force or t + eps >= self._next_clock:
            self.clock_pub.publish_raw(_pack_clock(clock=msgs.time_map(t)))
            self._next_clock = next_due(self._next_clock, t, self.clock_period)
        if force or t + eps >= self._next_state:
            self._publish_states(self.sim.model_states(), self.model_states_pub, _pack_model_states)
            if self.link_states_pub.has_subscribers:   # every link of every model: only when read
                self._publish_states(self.sim.link_states(), self.link_states_pub, _pack_link_states)
            for link in self.robots.values():
                if link.humanoid_pub.has_subscribers:   # CoM, contacts and ZMP cost ~0.15 ms: only when read
                    link.publish_humanoid_state(t)
            self._next_state = next_due(self._next_state, t, self.state_period)

    def restart_schedule(self) -> None:
        """After a reset: the next clock and states are due at the current sim time."""
        self._next_clock = self._next_state = self.sim.world.time

    @staticmethod
    def _publish_states(rows, publisher, pack) -> None:
        """ModelStates / LinkStates (the same layout) of (name, pose, linear, angular) rows."""
        names, poses, twists = [], [], []
        for name, pose, linear, angular in rows:
            names.append(name)
            px, py, pz = pose.position
            qx, qy, qz, qw = pose.orientation
            poses.append(_pose(position=_point(x=px, y=py, z=pz), orientation=_quaternion(x=qx, y=qy, z=qz, w=qw)))
            lx, ly, lz = linear.tolist()
            ax, ay, az = angular.tolist()
            twists.append(_twist(linear=_vector3(x=lx, y=ly, z=lz), angular=_vector3(x=ax, y=ay, z=az)))
        publisher.publish_raw(pack(name=names, pose=poses, twist=twists))

    def publish_diagnostics(self, paused: bool) -> None:
        """Once a wall second: mode, real-time factor, steps per second, lateness, who commands each robot."""
        now = time.monotonic()
        wall = now - self._diag_wall
        if wall < 1.0:
            return
        world, sim = self.sim.world, self.sim
        late = sorted(self.lateness)
        p99 = late[min(len(late) - 1, int(0.99 * len(late)))] * 1e3 if late else 0.0
        report = {
            "mode": sim.mode, "paused": paused, "sim_time": world.time,
            "real_time_factor": (world.time - self._diag_sim) / wall,
            "steps_per_s": (sim.step_count - self._diag_steps) / wall,
            "p99_late_ms": p99, "max_late_ms": late[-1] * 1e3 if late else 0.0,
            "robots": {ns: ("holding" if link.holding else "commanded") for ns, link in self.robots.items()},
        }
        self.diagnostics_pub.publish(String(data=json.dumps(report)))
        self.lateness.clear()
        self._diag_wall, self._diag_sim, self._diag_steps = now, world.time, sim.step_count


def next_due(previous_due: float, now: float, period: float) -> float:
    """The next publication time after ``now`` on the grid ``previous_due + k * period`` (no bursts)."""
    due = previous_due + period
    if due <= now:
        due = previous_due + period * (math.floor((now - previous_due) / period) + 1)
    return due
