"""Atlas joint animation (DRCSim "Animate joints", node ``joint_control``): one JointTrajectory of
1500 points, dt 0.01 s, theta = 2*pi*0.05*i*dt, x1 = -0.5*sin(2*theta), x2 = 0.5*sin(theta), each of
the 28 joints following x1 or x2 as in the tutorial, played back kinematically (gravity off, no ground).

The tutorial waits for the sim clock, publishes once and spins. Here the node also waits until the
trajectory controller reports state (so the single message is not lost) and can ``loop``.
The tutorial gives every point ``time_from_start = dt``, which a trajectory controller rejects (times
must increase); points are timed ``(i + 1) * dt`` so the playback runs at dt, as it did in DRCSim.
"""

from __future__ import annotations

import math
import sys

from msgs import time_to_sec
from msgs.control_msgs import JointTrajectoryControllerState as ControllerState
from msgs.rosgraph_msgs import Clock
from msgs.trajectory_msgs import JointTrajectory
from nodes.commanders.live import declare_controller
from nodes.commanders.trajectories import point, trajectory
from nodes.core import Node, run_node

# The tutorial's (Atlas v1/v3) joint order, and which of the two waves each joint follows.
JOINTS_AND_WAVES = [
    ("back_lbz", 1), ("back_mby", 2), ("back_ubx", 2), ("neck_ay", 2),
    ("l_leg_uhz", 2), ("l_leg_mhx", 2), ("l_leg_lhy", 1), ("l_leg_kny", 2), ("l_leg_uay", 1), ("l_leg_lax", 1),
    ("r_leg_lax", 2), ("r_leg_uay", 1), ("r_leg_kny", 2), ("r_leg_lhy", 1), ("r_leg_mhx", 1), ("r_leg_uhz", 2),
    ("l_arm_elx", 2), ("l_arm_ely", 1), ("l_arm_mwx", 1), ("l_arm_shx", 1), ("l_arm_usy", 2), ("l_arm_uwy", 2),
    ("r_arm_elx", 2), ("r_arm_ely", 1), ("r_arm_mwx", 1), ("r_arm_shx", 2), ("r_arm_usy", 1), ("r_arm_uwy", 1),
]
ATLAS_JOINTS = [name for name, _ in JOINTS_AND_WAVES]


def waves(i: int, dt: float = 0.01, rps: float = 0.05) -> tuple[float, float]:
    """(x1, x2) of point ``i``."""
    theta = rps * 2.0 * math.pi * i * dt
    return -0.5 * math.sin(2.0 * theta), 0.5 * math.sin(theta)


def animation(n: int = 1500, dt: float = 0.01, rps: float = 0.05, prefix: str = "") -> JointTrajectory:
    points = []
    for i in range(n):
        x1, x2 = waves(i, dt, rps)
        points.append(point([x1 if wave == 1 else x2 for _, wave in JOINTS_AND_WAVES], (i + 1) * dt))
    return trajectory([prefix + name for name in ATLAS_JOINTS], points, frame_id=f"{prefix}pelvis")


def expected_position(joint: str, t: float, dt: float = 0.01, rps: float = 0.05) -> float:
    """Where ``joint`` should be ``t`` s into the playback (for checks and monitors)."""
    x1, x2 = waves(max(0.0, t / dt - 1.0), dt, rps)
    return x1 if dict(JOINTS_AND_WAVES)[joint] == 1 else x2


class JointAnimation(Node):
    default_name = "joint_control"

    def __init__(self, **kwargs) -> None:
        super().__init__("joint_control", **kwargs)
        controller = declare_controller(self, "the trajectory controller that plays the animation")
        self.points = self.declare_parameter("points", 1500, min_value=1, description="n in the tutorial")
        self.dt = self.declare_parameter("dt", 0.01, min_value=0.0001, description="seconds between points")
        self.rps = self.declare_parameter("rps", 0.05, description="wave frequency (revolutions per second)")
        self.prefix = self.declare_parameter("joint_prefix", "", description="e.g. 'atlas::' for DRCSim names")
        self.loop = self.declare_parameter("loop", False, description="replay when the animation ends")
        self.publisher = self.create_publisher(JointTrajectory, f"{controller}/joint_trajectory")
        self.clock_seen = False
        self.controller_seen = False
        self.sent_at: float | None = None
        self.create_subscription(Clock, "/sim/clock", self.on_clock)
        self.create_subscription(ControllerState, f"{controller}/controller_state", self.on_controller_state)
        self.create_timer(0.1, self.tick)
        self.add_on_set_parameter_callback(self.on_parameter)
        self.logger.info("waiting for the sim clock and the trajectory controller")

    def on_parameter(self, name: str, value) -> str | None:
        """Read when the animation is (re)sent: applies from the next loop on."""
        attribute = {"points": "points", "dt": "dt", "rps": "rps", "joint_prefix": "prefix", "loop": "loop"}.get(name)
        if attribute is not None:
            setattr(self, attribute, value)
        return None

    def on_clock(self, msg: Clock) -> None:
        self.clock_seen = self.clock_seen or time_to_sec(msg.clock) != 0.0

    def on_controller_state(self, _msg: object) -> None:
        self.controller_seen = True

    def tick(self) -> None:
        if not (self.clock_seen and self.controller_seen):
            return
        now = self.now()
        length = self.points * self.dt
        if self.sent_at is None or (self.loop and now - self.sent_at >= length):
            msg = animation(self.points, self.dt, self.rps, self.prefix)
            self.publisher.publish(msg)
            self.sent_at = now
            x1, x2 = waves(self.points - 1, self.dt, self.rps)
            self.logger.info(f"test: angles[{self.points}][{x1:f}, {x2:f}]: published {self.points} points "
                             f"over {length:g} s to {self.publisher_key()}")

    def publisher_key(self) -> str:
        return getattr(self.publisher, "key", "joint_trajectory")


def main(argv: list[str] | None = None) -> int:
    return run_node(JointAnimation, argv)


if __name__ == "__main__":
    sys.exit(main())
