"""Lab 2.3 joint-state monitor ("robot_monitor"): logs every joint's position and velocity.

The lab logs each message; at 100 Hz that floods the terminal, so by default one report per
``log_period`` s is printed (``log_period: 0.0`` logs every message as the lab does).
"""

from __future__ import annotations

import sys

from msgs.sensor_msgs import JointState
from nodes.core import Node, run_node


def report(msg: JointState) -> list[str]:
    lines = ["=== Joint States ==="]
    for i, name in enumerate(msg.name):
        position = msg.position[i] if i < len(msg.position) else 0.0
        velocity = msg.velocity[i] if i < len(msg.velocity) else 0.0
        lines.append(f"{name}: pos={position:.2f}, vel={velocity:.2f}")
    return lines


class JointMonitor(Node):
    default_name = "robot_monitor"

    def __init__(self, **kwargs) -> None:
        super().__init__("robot_monitor", **kwargs)
        self.log_period = self.declare_parameter("log_period", 1.0, description="seconds between reports (0: every "
                                                 "message)", min_value=0.0)
        self.last_report: float | None = None
        self.add_on_set_parameter_callback(self.on_parameter)
        self.create_subscription(JointState, "joint_states", self.joint_state_callback)

    def on_parameter(self, name: str, value: float) -> str | None:
        if name == "log_period":  # read at every message: applies at once
            self.log_period = value
        return None

    def joint_state_callback(self, msg: JointState) -> None:
        now = self.now()
        if self.last_report is not None and now < self.last_report:  # the sim clock was reset
            self.last_report = None
        if self.last_report is not None and now - self.last_report < self.log_period:
            return
        self.last_report = now
        for line in report(msg):
            self.logger.info(line)


def main(argv: list[str] | None = None) -> int:
    return run_node(JointMonitor, argv)


if __name__ == "__main__":
    sys.exit(main())
