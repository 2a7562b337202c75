"""A stand-in for the simulator and controllers that feeds the visualiser's keys (tests, bench, demos).

``python -m tests.support.viz_feeder --param robots:=[humanoid] --param robot_file:=robots/humanoid.urdf``
publishes, per robot namespace: ``joint_states`` (a knee bend every ``period`` s, the joint commander's
motion), ``joint_trajectory_controller/controller_state`` and ``.../joint_trajectory``,
``humanoid_state``; plus ``sim/clock`` and ``sim/model_states``. Pair it with the state publisher for
``robot_description`` and ``tf``. ``delete_after`` drops the last robot from ``sim/model_states`` (as
``sim/delete_entity`` would). Stamps are sim time from 0, or the wall clock with ``stamp:=wall``
(the bench measures logging lag against them).
"""

from __future__ import annotations

import math
import time
from typing import Any

import msgs
from msgs.control_msgs import JointTrajectoryControllerState as ControllerState
from msgs.gazebo_msgs import ModelStates
from msgs.humanoid_msgs import HumanoidState
from msgs.rosgraph_msgs import Clock
from msgs.sensor_msgs import JointState
from msgs.std_msgs import Header
from msgs.trajectory_msgs import JointTrajectory
from nodes.core import Node, run_node
from nodes.share import robot_file
from nodes.urdf.model import parse_urdf

PELVIS_HEIGHT = 0.91


def bend(t: float, period: float) -> float:
    """Knee angle of a smooth stand -> bend -> stand cycle (0 .. 0.8 rad)."""
    return 0.4 * (1.0 - math.cos(2.0 * math.pi * t / period))


def pelvis_height(knee: float) -> float:
    """Feet flat on the ground: thigh and shin (0.35 m each) both tilt by knee/2."""
    return PELVIS_HEIGHT - 0.7 * (1.0 - math.cos(knee / 2))


def pose_for(knee: float) -> dict[str, float]:
    return {"left_knee": knee, "right_knee": knee, "left_hip_pitch": -knee / 2, "right_hip_pitch": -knee / 2,
            "left_ankle_pitch": -knee / 2, "right_ankle_pitch": -knee / 2}


class Feeder(Node):
    default_name = "viz_feeder"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("viz_feeder", **kwargs)
        self.robots = [r for r in self.declare_parameter("robots", ["humanoid"]) if r]
        model = parse_urdf(robot_file(self.declare_parameter("robot_file", "humanoid")).read_text())
        self.joints = [j.name for j in model.movable_joints()]
        self.rate = self.declare_parameter("rate", 100.0, min_value=1.0, max_value=2000.0)
        self.period = self.declare_parameter("period", 2.0, min_value=0.1)
        self.delete_after = self.declare_parameter("delete_after", 0.0, min_value=0.0)
        self.wall_stamps = self.declare_parameter("stamp", "sim", choices=("sim", "wall")) == "wall"
        controller = self.declare_parameter("controller", "joint_trajectory_controller")
        self.start = time.monotonic()
        self.step = 0
        self.clock_pub = self.create_publisher(Clock, "/sim/clock")
        self.models_pub = self.create_publisher(ModelStates, "/sim/model_states")
        self.pubs = {ns: {
            "js": self.create_publisher(JointState, f"/{ns}/joint_states"),
            "cs": self.create_publisher(ControllerState, f"/{ns}/{controller}/controller_state"),
            "traj": self.create_publisher(JointTrajectory, f"/{ns}/{controller}/joint_trajectory"),
            "hs": self.create_publisher(HumanoidState, f"/{ns}/humanoid_state"),
        } for ns in self.robots}
        self.create_timer(1.0 / self.rate, self.tick, sim_time=False)

    def tick(self) -> None:
        self.step += 1
        t = self.step / self.rate  # sim time advances exactly one period per tick
        stamp = msgs.time_from_sec(time.time() if self.wall_stamps else t)
        header = {"stamp": {"sec": stamp.sec, "nanosec": stamp.nanosec}}
        knee = bend(t, self.period)
        positions = dict.fromkeys(self.joints, 0.0)
        positions.update(pose_for(knee))
        self.clock_pub.publish(Clock(clock=msgs.time_from_sec(t)))
        alive = list(self.robots)
        if self.delete_after and t >= self.delete_after and len(alive) > 0:
            alive = alive[:-1]
        if self.step % max(1, int(self.rate / 50)) == 0:  # model_states at ~50 Hz like the simulator
            self.models_pub.publish(msgs.from_dict(ModelStates, {
                "name": alive,
                "pose": [{"position": {"x": 0.0, "y": 0.6 * i, "z": pelvis_height(knee)},
                          "orientation": {"w": 1.0}} for i in range(len(alive))],
                "twist": [{} for _ in alive]}))
        for ns in alive:
            pubs = self.pubs[ns]
            pubs["js"].publish(JointState(header=Header(stamp=stamp), name=self.joints, position=[positions[j] for j in self.joints],
                                          velocity=[0.0] * len(self.joints), effort=[0.0] * len(self.joints)))
            if self.step % 2 == 0:
                legs = list(pose_for(0.0))
                lagged = pose_for(bend(t - 0.05, self.period))
                pubs["cs"].publish(msgs.from_dict(ControllerState, {
                    "header": header, "joint_names": legs,
                    "reference": {"positions": [positions[j] for j in legs]},
                    "feedback": {"positions": [lagged[j] for j in legs]}}))
            if self.step % 5 == 0:
                sway = 0.02 * math.sin(2 * math.pi * t / self.period)
                pubs["hs"].publish(msgs.from_dict(HumanoidState, {
                    "header": header, "center_of_mass": {"x": sway, "y": 0.0, "z": 0.75 - 0.1 * knee},
                    "support_polygon": [{"x": 0.12, "y": 0.15}, {"x": 0.12, "y": -0.15},
                                        {"x": -0.08, "y": -0.15}, {"x": -0.08, "y": 0.15}],
                    "zmp_x": sway, "zmp_y": 0.0, "is_balanced": True}))
            if self.step % int(self.rate * self.period) == 1:
                target = pose_for(0.8)
                pubs["traj"].publish(msgs.from_dict(JointTrajectory, {
                    "header": header, "joint_names": list(target),
                    "points": [{"positions": list(target.values()),
                                "time_from_start": {"sec": int(self.period / 2)}}]}))


def main(argv: list[str] | None = None) -> int:
    return run_node(Feeder, argv)


if __name__ == "__main__":
    raise SystemExit(main())
