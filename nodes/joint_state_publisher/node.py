"""``joint_state_publisher``: ``joint_states`` for every movable joint of the robot description, as ROS's does.

- The description comes from the ``robot_description`` parameter (URDF or xacro text, e.g. from
  ``Command(['xacro ', file])``) or, when that is empty, from the latched ``robot_description`` topic (and
  follows it when it changes).
- Each joint starts at 0, or at the middle of its limits when 0 is outside them; ``zeros`` (a mapping) sets
  other starting values. Mimic joints follow their joint. Continuous joints have no limits.
- ``source_list``: joint_states topics whose values replace ours for the joints they name.
- ``rate`` (Hz, default 10) is how often it publishes.

``joint_state_publisher_gui`` (nodes/joint_state_publisher/gui.py) is this node with sliders on a web page.
"""

from __future__ import annotations

import math
import sys
import threading
from dataclasses import dataclass
from typing import Any

from msgs.sensor_msgs import JointState
from msgs.std_msgs import String
from nodes.core import Node, ParameterError, run_node
from nodes.urdf import UrdfError, load_robot_description, parse_urdf


@dataclass
class JointRange:
    name: str
    lower: float
    upper: float
    continuous: bool
    zero: float


def joint_ranges(urdf: str, zeros: dict[str, float]) -> tuple[list[JointRange], dict[str, tuple[str, float, float]]]:
    """(the free movable joints in URDF order, mimic joint -> (joint, multiplier, offset))."""
    model = parse_urdf(urdf)
    free: list[JointRange] = []
    mimics: dict[str, tuple[str, float, float]] = {}
    for joint in model.joints.values():
        if not joint.movable:
            continue
        if joint.mimic is not None:
            mimics[joint.name] = (joint.mimic.joint, joint.mimic.multiplier, joint.mimic.offset)
            continue
        continuous = joint.type == "continuous" or joint.lower is None or joint.upper is None
        lower = -math.pi if continuous else float(joint.lower)
        upper = math.pi if continuous else float(joint.upper)
        if joint.name in zeros:
            zero = float(zeros[joint.name])
        else:
            zero = 0.0 if lower <= 0.0 <= upper else (lower + upper) / 2.0
        free.append(JointRange(joint.name, lower, upper, continuous, zero))
    return free, mimics


class JointStatePublisher(Node):
    default_name = "joint_state_publisher"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(self.default_name, **kwargs)
        self.rate = self.declare_parameter("rate", 10.0, min_value=0.1, max_value=1000.0, description="Hz")
        self.declare_parameter("robot_description", "", description="URDF or xacro text (else the topic)")
        self.declare_parameter("zeros", {}, type=object, validator=_zeros_valid,
                               description="joint -> starting position")
        sources = self.declare_parameter("source_list", [], type=object, validator=_sources_valid,
                                         description="joint_states topics merged in")
        self.declare_parameter("use_gui", False, description="(ROS 1; use joint_state_publisher_gui)")
        self.declare_parameter("publish_default_positions", True, description="publish joints no source has")
        self.lock = threading.Lock()
        self.joints: list[JointRange] = []
        self.mimics: dict[str, tuple[str, float, float]] = {}
        self.positions: dict[str, float] = {}
        self.from_sources: dict[str, float] = {}
        self.publisher = self.create_publisher(JointState, "joint_states")
        text = self.get_parameter("robot_description")
        if text:
            self.set_description(text)
        else:
            self.create_subscription(String, "robot_description", self.on_description)
            latched = self.fetch_latched(String, "robot_description", timeout=2.0)
            if latched is not None and latched.data and not self.joints:
                self.set_description(latched.data)
            if not self.joints:
                self.logger.info("waiting for the robot description on the robot_description topic")
        for topic in sources:
            self.create_subscription(JointState, topic, self.on_source)
        self.add_on_set_parameter_callback(self.on_parameter)
        self.timer = self.create_timer(1.0 / self.rate, self.tick)

    # --------------------------------------------------------------------------------------- inputs
    def set_description(self, text: str) -> str | None:
        try:
            urdf = load_robot_description(xml=text)
            joints, mimics = joint_ranges(urdf, self.get_parameter("zeros"))
        except (UrdfError, ValueError) as exc:
            self.logger.error(f"robot description refused: {exc}")
            return str(exc)
        with self.lock:
            old = self.positions
            self.joints, self.mimics = joints, mimics
            self.positions = {j.name: old.get(j.name, j.zero) for j in joints}
        self.logger.info(f"publishing {len(joints)} movable joints ({len(mimics)} mimic) at {self.rate:g} Hz")
        self.on_joints_changed()
        return None

    def on_joints_changed(self) -> None:
        """Called when the set of joints changes (the GUI rebuilds its sliders)."""

    def on_description(self, msg: Any) -> None:
        if msg.data:
            self.set_description(msg.data)

    def on_source(self, msg: Any) -> None:
        if msg.position and len(msg.position) == len(msg.name):
            with self.lock:
                self.from_sources.update(zip(msg.name, (float(p) for p in msg.position)))

    def on_parameter(self, name: str, value: Any) -> str | None:
        if name == "robot_description" and value:
            return self.set_description(value)
        if name == "rate":
            self.rate = value
            self.timer.cancel()
            self.timer = self.create_timer(1.0 / value, self.tick)
        return None

    def set_position(self, name: str, value: float) -> str | None:
        """Move one free joint (clamped to its limits); an error text for an unknown joint or a bad value."""
        with self.lock:
            joint = next((j for j in self.joints if j.name == name), None)
            if joint is None:
                return f"unknown joint '{name}'"
            if not math.isfinite(value):
                return f"position of '{name}' must be a finite number"
            self.positions[name] = min(max(value, joint.lower), joint.upper)
        return None

    # -------------------------------------------------------------------------------------- output
    def current(self) -> tuple[list[str], list[float]]:
        """Names and positions as published: free joints (sources win), then mimic joints."""
        with self.lock:
            values = {name: self.from_sources.get(name, value) for name, value in self.positions.items()}
            for name, (leader, multiplier, offset) in self.mimics.items():
                base = self.from_sources.get(leader, values.get(leader))
                if base is not None:
                    values[name] = self.from_sources.get(name, base * multiplier + offset)
        return list(values), list(values.values())

    def tick(self) -> None:
        if not self.joints:
            return
        names, positions = self.current()
        self.publisher.publish(JointState(header=self.header(), name=names, position=positions))


def _zeros_valid(value: Any) -> str | None:
    if not isinstance(value, dict) or not all(isinstance(v, (int, float)) for v in value.values()):
        return "zeros must map joint names to numbers"
    return None


def _sources_valid(value: Any) -> str | None:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        return "source_list must be a list of topic names"
    return None


def main(argv: list[str] | None = None) -> int:
    return run_node(JointStatePublisher, argv)


__all__ = ["JointRange", "JointStatePublisher", "ParameterError", "joint_ranges", "main"]

if __name__ == "__main__":
    sys.exit(main())
