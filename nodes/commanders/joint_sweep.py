"""Joint sweep ("joint_state_publisher"): publishes ``joint_states`` that slowly sweep every movable
joint of a URDF through most of its range — the hands-free stand-in for the URDF lab's
joint_state_publisher_gui sliders, so the state publisher and the viewer show the model moving.
"""

from __future__ import annotations

import math
import sys

from msgs.sensor_msgs import JointState
from nodes.commanders.live import restart
from nodes.core import Node, run_node
from nodes.share import robot_file


def sweep_positions(limits: list[tuple[float, float]], t: float, frequency: float, fraction: float) -> list[float]:
    """Each joint oscillates around the middle of its range over ``fraction`` of it, phase-shifted per joint."""
    out = []
    for i, (lower, upper) in enumerate(limits):
        middle, half = (lower + upper) / 2.0, (upper - lower) / 2.0 * fraction
        out.append(middle + half * math.sin(2.0 * math.pi * frequency * t + i * math.pi / 3.0))
    return out


def movable_joints(robot: str) -> list[tuple[str, float, float]]:
    """(name, lower, upper) of each movable joint; continuous joints sweep ±pi."""
    from nodes.urdf.description import load_robot_description
    from nodes.urdf.model import parse_urdf

    model = parse_urdf(load_robot_description(str(robot_file(robot))))
    joints = []
    for joint in model.joints.values():
        if not joint.movable or joint.mimic is not None:
            continue
        lower = joint.lower if joint.lower is not None else -math.pi
        upper = joint.upper if joint.upper is not None else math.pi
        joints.append((joint.name, lower, upper))
    return joints


class JointSweep(Node):
    default_name = "joint_state_publisher"

    def __init__(self, **kwargs) -> None:
        super().__init__("joint_state_publisher", **kwargs)
        robot = self.declare_parameter("robot", "humanoid_simplified", description="URDF path or robot name",
                                       read_only=restart("robot"))
        rate = self.declare_parameter("rate", 30.0, min_value=0.1, max_value=1000.0, description="Hz")
        self.frequency = self.declare_parameter("frequency", 0.2, min_value=0.0, description="sweep frequency (Hz)")
        self.fraction = self.declare_parameter("fraction", 0.8, min_value=0.0, max_value=1.0,
                                               description="part of each joint's range to sweep")
        joints = movable_joints(robot)
        self.names = [name for name, _, _ in joints]
        self.limits = [(lower, upper) for _, lower, upper in joints]
        self.publisher = self.create_publisher(JointState, "joint_states")
        self.start = self.now()
        self.timer = self.create_timer(1.0 / rate, self.tick)
        self.add_on_set_parameter_callback(self.on_parameter)
        self.logger.info(f"sweeping {len(self.names)} joints of {robot} at {self.frequency:g} Hz")

    def on_parameter(self, name: str, value: float) -> str | None:
        """``rate``, ``frequency`` and ``fraction`` apply at once; ``robot`` is read-only."""
        if name == "rate":
            self.timer.cancel()
            self.timer = self.create_timer(1.0 / value, self.tick)
        elif name in ("frequency", "fraction"):
            setattr(self, name, value)
        return None

    def tick(self) -> None:
        positions = sweep_positions(self.limits, self.now() - self.start, self.frequency, self.fraction)
        self.publisher.publish(JointState(header=self.header(), name=list(self.names), position=positions))


def main(argv: list[str] | None = None) -> int:
    return run_node(JointSweep, argv)


if __name__ == "__main__":
    sys.exit(main())
