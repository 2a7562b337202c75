"""Controller lab trajectory sender: FollowJointTrajectory goals to the joint trajectory controller.

``waveforms`` runs in order: ``point`` (the lab's simple trajectory controller: one point at
``amplitude`` reached in ``point_time`` s), ``sine`` (amplitude 1.57, 0.1 Hz) and ``square`` (0.05 Hz),
each ``duration`` s sampled every ``dt`` s as in the lab. Each goal's result is logged; with
``exit_when_done`` the node exits afterwards, as the lab's script does.
"""

from __future__ import annotations

import sys
import threading

from msgs import duration_to_sec
from msgs.control_msgs import FollowJointTrajectory
from nodes.commanders.live import declare_controller, restart
from nodes.commanders.trajectories import single_point, trajectory, waveform_points
from nodes.core import Node, run_node

WAVEFORMS = ("point", "sine", "square")
DEFAULT_FREQUENCY = {"sine": 0.1, "square": 0.05}
STATUS_NAMES = {4: "SUCCEEDED", 5: "CANCELED", 6: "ABORTED"}


def _check_waveforms(value: list) -> str | None:
    bad = [w for w in value if w not in WAVEFORMS]
    return f"unknown waveform(s) {bad} (choose from {', '.join(WAVEFORMS)})" if bad else None


class TrajectorySender(Node):
    default_name = "trajectory_sender"

    def __init__(self, **kwargs) -> None:
        super().__init__("trajectory_sender", **kwargs)
        controller = declare_controller(self, "the JTC whose follow_joint_trajectory action is used")
        self.joints = self.declare_parameter("joints", ["joint1"], description="joints of the goal")
        self.waveforms = self.declare_parameter("waveforms", ["sine"], description="goals to send, in order",
                                                validator=_check_waveforms, read_only=restart("waveforms"))
        self.amplitude = self.declare_parameter("amplitude", 1.57, description="rad")
        self.frequency = self.declare_parameter("frequency", 0.0, min_value=0.0,
                                                description="Hz (0: the lab's 0.1 for sine, 0.05 for square)")
        self.duration = self.declare_parameter("duration", 10.0, min_value=0.01, description="wave length (s)")
        self.dt = self.declare_parameter("dt", 0.1, min_value=0.001, description="time between wave points (s)")
        self.point_time = self.declare_parameter("point_time", 3.0, min_value=0.0,
                                                 description="time to reach the 'point' target (s)")
        self.server_timeout = self.declare_parameter("server_timeout", 60.0, min_value=0.0,
                                                     description="seconds to wait for the action server",
                                                     read_only=restart("server_timeout"))
        self.exit_when_done = self.declare_parameter("exit_when_done", True, description="exit after the goals")
        # The rest is read when each goal is built: a change applies from the next goal on.
        self.add_on_set_parameter_callback(self.on_parameter)
        self.client = self.create_action_client(FollowJointTrajectory, f"{controller}/follow_joint_trajectory")
        # Goals block for their whole length: run them off the executor thread so SIGINT stays prompt.
        self.worker = threading.Thread(target=self.run_sequence, name="trajectory-goals", daemon=True)
        self.worker.start()

    def on_parameter(self, name: str, value) -> str | None:
        if name in ("joints", "amplitude", "frequency", "duration", "dt", "point_time", "exit_when_done"):
            setattr(self, name, value)
        return None

    def build_goal(self, waveform: str):
        if waveform == "point":
            traj = single_point(self.joints, [self.amplitude] * len(self.joints), self.point_time)
        else:
            frequency = self.frequency or DEFAULT_FREQUENCY[waveform]
            traj = trajectory(self.joints, waveform_points(waveform, self.amplitude, frequency, self.duration,
                                                           self.dt, len(self.joints)))
        return FollowJointTrajectory.Goal(trajectory=traj)

    def run_sequence(self) -> None:
        self.logger.info("Waiting for joint trajectory controller action server...")
        if not self.client.wait_for_server(self.server_timeout):
            self.logger.error(f"no action server at {self.client.key} after {self.server_timeout:g} s")
            self.request_shutdown()
            return
        self.logger.info("Connected to joint trajectory controller action server")
        for waveform in self.waveforms:
            if not self.ok:
                return
            goal = self.build_goal(waveform)
            points = len(goal.trajectory.points)
            self.logger.info(f"Sending {waveform} trajectory with {points} points")
            try:
                handle = self.client.send_goal(goal)
                if not handle.accepted:
                    self.logger.error(f"{waveform} trajectory goal was rejected")
                    continue
                length = goal.trajectory.points[-1].time_from_start
                status, result = handle.get_result(timeout=duration_to_sec(length) + 60.0)
            except Exception as exc:  # ServiceError / timeouts: report and go on with the next goal
                self.logger.error(f"{waveform} trajectory failed: {exc}")
                continue
            outcome = STATUS_NAMES.get(status, str(status))
            detail = f" ({result.error_string})" if getattr(result, "error_string", "") else ""
            self.logger.info(f"{waveform.capitalize()} trajectory execution completed: {outcome}{detail}")
        if self.exit_when_done:
            self.request_shutdown()


def main(argv: list[str] | None = None) -> int:
    return run_node(TrajectorySender, argv)


if __name__ == "__main__":
    sys.exit(main())
