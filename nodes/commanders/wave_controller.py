"""Lab 2.3 wave controller ("robot_controller"): every ``period`` s send each limb's trajectory
controller one point reached in ``move_time`` s — arms ±1.0 rad in anti-phase (sin), legs ±0.5 rad in
anti-phase (cos) — and log the left arm's measured position from ``joint_states``.
"""

from __future__ import annotations

import math
import sys

from msgs.sensor_msgs import JointState
from msgs.trajectory_msgs import JointTrajectory
from nodes.commanders.trajectories import single_point
from nodes.core import Node, run_node

# controller -> the one joint it drives (the lab's four gazebo_ros_joint_trajectory plug-ins)
LIMBS = {
    "left_arm_controller": "left_arm_joint",
    "right_arm_controller": "right_arm_joint",
    "left_leg_controller": "left_leg_joint",
    "right_leg_controller": "right_leg_joint",
}


def wave_targets(time_s: float, arm_amplitude: float = 1.0, leg_amplitude: float = 0.5) -> dict[str, float]:
    """Targets per controller at lab time ``time_s``: arms wave in anti-phase, legs too, a quarter turn later."""
    arm = math.sin(time_s) * arm_amplitude
    leg = math.cos(time_s) * leg_amplitude
    return {"left_arm_controller": arm, "right_arm_controller": -arm,
            "left_leg_controller": leg, "right_leg_controller": -leg}


class WaveController(Node):
    default_name = "robot_controller"

    def __init__(self, **kwargs) -> None:
        super().__init__("robot_controller", **kwargs)
        self.period = self.declare_parameter("period", 0.5, description="seconds between commands", min_value=0.01)
        self.move_time = self.declare_parameter("move_time", 1.0, description="time_from_start of each point (s)",
                                                min_value=0.0)
        self.arm_amplitude = self.declare_parameter("arm_amplitude", 1.0, description="arm wave amplitude (rad)")
        self.leg_amplitude = self.declare_parameter("leg_amplitude", 0.5, description="leg wave amplitude (rad)")
        self.publishers = {controller: self.create_publisher(JointTrajectory, f"{controller}/joint_trajectory")
                           for controller in LIMBS}
        self.current_joint_positions: dict[str, float] = {}
        self.create_subscription(JointState, "joint_states", self.joint_state_callback)
        self.time_step = 0
        self.wave_time = 0.0  # lab time of the next command: time_step * period while the period is unchanged
        self.timer = self.create_timer(self.period, self.control_callback)
        self.add_on_set_parameter_callback(self.on_parameter)
        self.logger.info(f"wave controller ready: arms ±{self.arm_amplitude:.2f} rad, "
                         f"legs ±{self.leg_amplitude:.2f} rad")

    def on_parameter(self, name: str, value: float) -> str | None:
        """Every parameter applies at once (``zenroid param set /lab_robot/robot_controller period 1.0``)."""
        if name not in ("period", "move_time", "arm_amplitude", "leg_amplitude"):
            return None
        setattr(self, name, value)
        if name == "period":
            self.timer.cancel()
            self.timer = self.create_timer(value, self.control_callback)
        self.logger.info(f"{name} is now {value}")
        return None

    def joint_state_callback(self, msg: JointState) -> None:
        for name, position in zip(msg.name, msg.position):
            self.current_joint_positions[name] = position

    def control_callback(self) -> None:
        targets = wave_targets(self.wave_time, self.arm_amplitude, self.leg_amplitude)
        # One start stamp for all four limbs: each controller starts its trajectory at that time (ROS JTC
        # semantics), so the limbs stay in phase even when the messages arrive a few cycles apart.
        stamp = self.now_msg() if self.now() > 0.0 else None
        for controller, target in targets.items():
            trajectory = single_point([LIMBS[controller]], [target], self.move_time)
            if stamp is not None:
                trajectory.header.stamp = stamp
            self.publishers[controller].publish(trajectory)
        self.time_step += 1
        self.wave_time += self.period  # a new period changes the pace, not the phase reached so far
        if "left_arm_joint" in self.current_joint_positions:
            self.logger.info(f"Left arm: {self.current_joint_positions['left_arm_joint']:.2f} rad")


def main(argv: list[str] | None = None) -> int:
    return run_node(WaveController, argv)


if __name__ == "__main__":
    sys.exit(main())
