"""Joint commander (tutorial I2): every ``period`` s alternate the humanoid between standing (all zeros)
and a slight knee bend (hips -0.2, knees 0.4, ankles -0.2), each reached in ``move_time`` s.

Publishes ``<ns>/<controller>/joint_trajectory`` (default ``humanoid/joint_trajectory_controller/...``).
"""

from __future__ import annotations

import sys

from msgs import time_from_sec
from msgs.trajectory_msgs import JointTrajectory
from nodes.commanders.live import declare_controller
from nodes.commanders.trajectories import single_point
from nodes.core import Node, run_node

LEG_JOINTS = [
    "left_hip_yaw", "left_hip_roll", "left_hip_pitch", "left_knee", "left_ankle_pitch", "left_ankle_roll",
    "right_hip_yaw", "right_hip_roll", "right_hip_pitch", "right_knee", "right_ankle_pitch", "right_ankle_roll",
]


def knee_bend_pose(joints: list[str], hip_pitch: float, knee: float, ankle_pitch: float) -> list[float]:
    """The tutorial's bend: pitch joints of both legs bent, everything else straight."""
    by_suffix = {"hip_pitch": hip_pitch, "knee": knee, "ankle_pitch": ankle_pitch}
    return [next((v for suffix, v in by_suffix.items() if name.endswith(suffix)), 0.0) for name in joints]


def pose_for(index: int, joints: list[str], bend: list[float]) -> list[float]:
    """Even commands stand, odd commands bend (pose 0, pose 1, pose 0, ...)."""
    return [0.0] * len(joints) if index % 2 == 0 else list(bend)


class JointCommander(Node):
    """Alternates stand / knee bend on the joint trajectory controller."""

    default_name = "joint_commander"

    def __init__(self, **kwargs) -> None:
        super().__init__("joint_commander", **kwargs)
        controller = declare_controller(self, "joint trajectory controller to command")
        self.joints = self.declare_parameter("joints", list(LEG_JOINTS), description="joints to command (URDF names)",
                                             validator=lambda v: None if v else "needs at least one joint")
        period = self.declare_parameter("period", 2.0, description="seconds between commands", min_value=0.05)
        self.move_time = self.declare_parameter("move_time", 1.0, description="time_from_start of each pose (s)",
                                                min_value=0.0)
        self.enabled = self.declare_parameter("enabled", True, description="false: stop sending (hand the robot "
                                              "to someone else), true: resume")
        self.declare_parameter("hip_pitch", -0.2, description="hip pitch of the bend (rad)")
        self.declare_parameter("knee", 0.4, description="knee angle of the bend (rad)")
        self.declare_parameter("ankle_pitch", -0.2, description="ankle pitch of the bend (rad)")
        self.bend = self._bend({})
        self.start_delay = self.declare_parameter(
            "start_delay", 0.2, min_value=0.0, max_value=60.0,
            description="with use_sim_time: stamp each pose to start this long after its tick (s), so it starts "
                        "at the same simulated instant in every lockstep run; 0: start on receipt")
        self.publisher = self.create_publisher(JointTrajectory, f"{controller}/joint_trajectory")
        self.position_index = 0
        self.timer = self.create_timer(period, self.send_command)
        self.add_on_set_parameter_callback(self.on_parameter)
        self.logger.info(f"Joint Commander initialized: {len(self.joints)} joints -> "
                         f"{self.resolve(controller + '/joint_trajectory')} every {period:g} s")

    def _bend(self, changed: dict) -> list[float]:
        value = {n: changed.get(n, self.get_parameter(n)) for n in ("joints", "hip_pitch", "knee", "ankle_pitch")}
        return knee_bend_pose(value["joints"], value["hip_pitch"], value["knee"], value["ankle_pitch"])

    def on_parameter(self, name: str, value) -> str | None:
        """Every parameter but ``controller`` applies at once (``zenroid param set``)."""
        if name == "period":
            self.timer.cancel()
            self.timer = self.create_timer(value, self.send_command)
        elif name == "move_time":
            self.move_time = value
        elif name == "enabled":
            self.enabled = value
        elif name == "start_delay":
            self.start_delay = value
        elif name in ("joints", "hip_pitch", "knee", "ankle_pitch"):
            self.bend = self._bend({name: value})
            if name == "joints":
                self.joints = list(value)
        else:
            return None
        self.logger.info(f"{name} is now {value}")
        return None

    def send_command(self) -> None:
        if not self.enabled:
            return
        positions = pose_for(self.position_index, self.joints, self.bend)
        msg = single_point(self.joints, positions, self.move_time)
        if self.use_sim_time and self.start_delay > 0.0:
            msg.header.stamp = time_from_sec(self.timer.due_time + self.start_delay)
        self.publisher.publish(msg)
        self.logger.info(f"Sent command (pose {self.position_index % 2})")
        self.position_index += 1


def main(argv: list[str] | None = None) -> int:
    return run_node(JointCommander, argv)


if __name__ == "__main__":
    sys.exit(main())
