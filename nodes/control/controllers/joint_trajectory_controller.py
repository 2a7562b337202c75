"""joint_trajectory_controller/JointTrajectoryController: follow JointTrajectory messages and
FollowJointTrajectory goals, interpolating between points, with path/goal tolerances (ros2_controllers).

Joint limits come from the hardware (URDF + ``<ros2_control>``): a trajectory with a position outside a
limit is refused; one that asks a joint for more than its velocity limit is slowed down in time as a
whole when it takes over (logged with the joint, the speed and the limit); and, like ros2_control's
joint limiter, every command is clamped into the position limits and moves at most
``max_velocity * period`` per update (what remains of a spline's overshoot, a first point at time 0).

Parameters as ros2_controllers' (``JtcParameters``). Velocity-only and effort command interfaces close the
position loop with ``gains.<joint>`` (a PID per joint), except velocity-only with ``open_loop_control``,
which sends the desired velocity as it is. Without a ``velocity`` state interface the measured velocity is
unknown: velocity errors count as zero and velocity tolerances are not checked.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import msgs
from msgs import duration_to_sec
from msgs.control_msgs import FollowJointTrajectory, JointTrajectoryControllerState
from msgs.std_msgs import Header
from msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from nodes.control.controller import Controller, ControllerError
from nodes.control.interfaces import read_values, write_values
from nodes.control.pid import Gains, Pid
from nodes.control.trajectory import (
    MAX_DURATION,
    MAX_POINTS,
    JointLimits,
    Trajectory,
    TrajectoryError,
    validate_trajectory,
)
from nodes.core.param_schema import namespace, param, per_key

# control_msgs/FollowJointTrajectory.Result error codes
SUCCESSFUL = 0
INVALID_GOAL = -1
INVALID_JOINTS = -2
OLD_HEADER_TIMESTAMP = -3
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5


@dataclass
class Tolerances:
    """Per-joint limits on |desired - actual|; 0 means "not checked" (as in ros2_controllers)."""

    path_position: np.ndarray
    path_velocity: np.ndarray
    goal_position: np.ndarray
    goal_velocity: np.ndarray
    goal_time: float  # 0: wait forever for the goal tolerance


@dataclass
class _Incoming:
    trajectory: Trajectory
    goal: Any = None  # ServerGoalHandle for action goals
    tolerances: Tolerances | None = None
    label: str = "topic"


@dataclass
class _Active:
    trajectory: Trajectory
    goal: Any
    tolerances: Tolerances
    last_feedback: float = -math.inf
    started: bool = field(default=False)


def _merge_tolerances(default: np.ndarray, joint_index: dict[str, int], entries, attr: str) -> np.ndarray:
    """Goal-supplied JointTolerance[] over the defaults: >0 replaces, -1 disables, 0 keeps the default."""
    merged = default.copy()
    for entry in entries or []:
        name = entry.get("name") if isinstance(entry, dict) else entry.name
        value = entry.get(attr, 0.0) if isinstance(entry, dict) else getattr(entry, attr, 0.0)
        if name not in joint_index:
            raise TrajectoryError(f"tolerance for unknown joint '{name}'")
        if value is None or not math.isfinite(value):
            raise TrajectoryError(f"tolerance {attr} of joint '{name}' is not finite")
        if value > 0.0:
            merged[joint_index[name]] = value
        elif value < 0.0:
            merged[joint_index[name]] = 0.0
    return merged


@dataclass(frozen=True)
class JointGains(Gains):
    """``gains.<joint>.*``: the closed-loop adapter of velocity-only and effort command interfaces."""

    ff_velocity_scale: float = param(0.0, description="feed-forward: this times the desired velocity is added")

    def pid(self) -> Pid:
        limit = self.i_clamp if self.i_clamp > 0 else math.inf
        return Pid(self.p, self.i, self.d, -limit, limit, -math.inf, math.inf, antiwindup=True)


@dataclass(frozen=True)
class JointConstraints:
    """``constraints.<joint>.*``: default tolerances of one joint (0: not checked)."""

    trajectory: float = param(0.0, min_value=0.0, description="path tolerance (rad) while the trajectory runs")
    goal: float = param(0.0, min_value=0.0, description="goal tolerance (rad) at the end")


@dataclass(frozen=True)
class Constraints:
    stopped_velocity_tolerance: float = param(0.01, min_value=0.0,
                                              description="rad/s every joint must be below at the goal")
    goal_time: float = param(0.0, min_value=0.0,
                             description="s after the end to meet the goal tolerances (0: wait forever)")
    per_joint: dict[str, JointConstraints] = per_key(JointConstraints, keys="joints", inline=True)


@dataclass(frozen=True)
class JtcParameters:
    joints: list[str] = param([], description="controlled joints")
    command_interfaces: list[str] = param(
        ["position"], choices=("position", "velocity", "effort"),
        description="position, velocity, position+velocity, or effort (PID from gains)")
    state_interfaces: list[str] = param(
        ["position", "velocity"], choices=("position", "velocity", "acceleration"),
        description="state interfaces read; must include position")
    state_publish_rate: float = param(50.0, min_value=0.0, description="controller_state Hz (0: never)")
    action_monitor_rate: float = param(20.0, min_value=0.0, description="feedback Hz (0: never)")
    allow_partial_joints_goal: bool = param(False, description="accept trajectories naming a subset of the joints")
    open_loop_control: bool = param(
        False, description="velocity-only command interface: send the desired velocity, no PID on the error")
    interpolation_method: str = param("splines", choices=("splines", "none"), description="between points")
    cmd_timeout: float = param(0.0, min_value=0.0, description="s after the last point a topic trajectory is stale")
    max_trajectory_points: int = param(MAX_POINTS, min_value=1, description="more points: the trajectory is refused")
    max_trajectory_duration: float = param(
        MAX_DURATION, min_value=0.0, description="s; a later time_from_start or a stamp further ahead is refused")
    constraints: Constraints = namespace(Constraints)
    gains: dict[str, JointGains] = per_key(JointGains, keys="joints")


class JointTrajectoryController(Controller):
    type_name = "joint_trajectory_controller/JointTrajectoryController"
    Params = JtcParameters
    params: JtcParameters

    # --- configuration ------------------------------------------------------------------------------
    def on_configure(self) -> None:
        params = self.params
        joints = self.take_joints(list(params.joints))
        command = list(params.command_interfaces)
        if not command:
            raise ControllerError("parameter 'command_interfaces' is empty")
        if "position" not in params.state_interfaces:
            raise ControllerError("parameter 'state_interfaces' must include 'position'")
        self.joint_index = {name: i for i, name in enumerate(joints)}
        self.command_kinds: list[str] = command
        self.state_kinds = list(dict.fromkeys(params.state_interfaces))
        n = len(joints)
        path = np.array([params.constraints.per_joint[j].trajectory for j in joints], dtype=float)
        goal = np.array([params.constraints.per_joint[j].goal for j in joints], dtype=float)
        goal_vel = np.full(n, params.constraints.stopped_velocity_tolerance)
        self.pids: list[Pid] = [params.gains[j].pid() for j in joints]
        self.ff_velocity_scale = np.array([params.gains[j].ff_velocity_scale for j in joints], dtype=float)
        if command == ["effort"]:
            missing = [j for j in joints if params.gains[j].all_zero]
            if missing:
                raise ControllerError(f"effort commands need gains: gains.<joint>.p/i/d are all zero for {missing}")
        elif "effort" in command:
            raise ControllerError("'effort' cannot be combined with other command interfaces")
        # ros2_controllers' use_closed_loop_pid_adapter: velocity-only (unless open loop) or effort
        self.closed_loop = command == ["effort"] or (command == ["velocity"] and not params.open_loop_control)
        if "velocity" not in self.state_kinds:  # nothing measures it: velocity tolerances cannot be checked
            goal_vel = np.zeros(n)
        self.default_tolerances = Tolerances(path, np.zeros(n), goal, goal_vel, params.constraints.goal_time)
        self.limits = JointLimits.from_hardware(joints, self.joint_info)
        self.max_points = params.max_trajectory_points
        self.max_duration = params.max_trajectory_duration
        self._limit_output = bool(np.isfinite(self.limits.lower).any() or np.isfinite(self.limits.upper).any()
                                  or np.isfinite(self.limits.velocity).any())
        self._last_output: np.ndarray | None = None
        self.interpolate_points = params.interpolation_method == "splines"
        self.cmd_timeout = params.cmd_timeout
        state_rate = params.state_publish_rate
        monitor_rate = params.action_monitor_rate
        self.state_period = 1.0 / state_rate if state_rate > 0 else math.inf
        self.feedback_period = 1.0 / monitor_rate if monitor_rate > 0 else math.inf

        self._inbox: collections.deque[_Incoming] = collections.deque()
        self._active: _Active | None = None
        self._desired_pos: np.ndarray | None = None
        self._desired_vel = np.zeros(n)
        self._desired_acc = np.zeros(n)
        self._last_state_pub = -math.inf
        self.rejected_count = 0

        ctx = self.context
        ctx.create_subscription(JointTrajectory, "~/joint_trajectory", self._on_trajectory_msg)
        self._state_pub = ctx.create_publisher(JointTrajectoryControllerState, "~/controller_state")
        self._action = ctx.create_action_server(
            FollowJointTrajectory, "~/follow_joint_trajectory", goal_callback=self._on_goal,
            cancel_callback=self._on_cancel, accepted_callback=self._on_accepted)

    def command_interface_configuration(self) -> list[str]:
        return [f"{j}/{k}" for k in self.command_kinds for j in self.joints]

    def state_interface_configuration(self) -> list[str]:
        return [f"{j}/{k}" for k in self.state_kinds for j in self.joints]

    def on_activate(self) -> None:
        cmd, state = self.loans_by_name()
        self._pos_state = [state[f"{j}/position"] for j in self.joints]
        self._vel_state = [state[f"{j}/velocity"] for j in self.joints] if "velocity" in self.state_kinds else []
        self._pos_cmd = [cmd[f"{j}/position"] for j in self.joints] if "position" in self.command_kinds else []
        self._vel_cmd = [cmd[f"{j}/velocity"] for j in self.joints] if "velocity" in self.command_kinds else []
        self._eff_cmd = [cmd[f"{j}/effort"] for j in self.joints] if "effort" in self.command_kinds else []
        for pid in self.pids:
            pid.reset()
        # Hold where the joints are; resolved at the first update if no state has arrived yet.
        self._desired_pos = None
        self._last_output = None
        self._inbox.clear()

    def on_deactivate(self) -> None:
        self._finish_goal("abort", INVALID_GOAL, "controller deactivated")
        self._active = None
        for incoming in list(self._inbox):
            self._end(incoming.goal, "abort", INVALID_GOAL, "controller deactivated")
        self._inbox.clear()

    # --- inputs (any thread) ------------------------------------------------------------------------
    def _validate(self, msg) -> Trajectory:
        return validate_trajectory(
            msg, self.joints, now=self.context.now(),
            allow_partial_joints_goal=self.params.allow_partial_joints_goal,
            limits=self.limits, max_points=self.max_points, max_duration=self.max_duration)

    def _on_trajectory_msg(self, msg) -> None:
        if self.state != "active":
            self.logger.warn(f"{self.name}: trajectory ignored: controller is {self.state}")
            return
        try:
            trajectory = self._validate(msg)
        except TrajectoryError as exc:
            self.rejected_count += 1
            self.logger.error(f"{self.name}: trajectory rejected: {exc}")
            return
        self._inbox.append(_Incoming(trajectory))

    def _on_goal(self, goal) -> tuple[bool, str]:
        if self.state != "active":
            return False, f"controller '{self.name}' is {self.state}, not active"
        try:
            trajectory = self._validate(_get(goal, "trajectory"))
            tolerances = self._goal_tolerances(goal)
        except TrajectoryError as exc:
            self.rejected_count += 1
            self.logger.error(f"{self.name}: goal rejected: {exc}")
            return False, str(exc)
        # Stash for the accepted callback (it receives the handle, not the parsed trajectory).
        self._last_validated = (id(goal), trajectory, tolerances)
        return True, ""

    def _goal_tolerances(self, goal) -> Tolerances:
        d = self.default_tolerances
        goal_time = d.goal_time
        raw_time = _get(goal, "goal_time_tolerance")
        if raw_time is not None:
            value = duration_to_sec(raw_time)
            if value > 0.0:
                goal_time = value
        tolerances = Tolerances(
            _merge_tolerances(d.path_position, self.joint_index, _get(goal, "path_tolerance"), "position"),
            _merge_tolerances(d.path_velocity, self.joint_index, _get(goal, "path_tolerance"), "velocity"),
            _merge_tolerances(d.goal_position, self.joint_index, _get(goal, "goal_tolerance"), "position"),
            _merge_tolerances(d.goal_velocity, self.joint_index, _get(goal, "goal_tolerance"), "velocity"),
            goal_time,
        )
        if "velocity" not in self.state_kinds:  # no measured velocity to hold them against
            tolerances.path_velocity[:] = 0.0
            tolerances.goal_velocity[:] = 0.0
        return tolerances

    def _on_accepted(self, handle) -> None:
        goal = handle.goal
        cached = getattr(self, "_last_validated", None)
        if cached is not None and cached[0] == id(goal):
            _, trajectory, tolerances = cached
        else:  # validated on another path: parse again (cheap, and already known to be valid)
            trajectory, tolerances = self._validate(_get(goal, "trajectory")), self._goal_tolerances(goal)
        self._inbox.append(_Incoming(trajectory, handle, tolerances, "goal"))

    def _on_cancel(self, handle) -> bool:
        return True  # the update loop sees is_cancel_requested and holds position

    # --- real-time loop -----------------------------------------------------------------------------
    def update(self, time: float, period: float) -> None:
        actual_pos = np.array(read_values(self._pos_state))
        # not measured (no velocity state interface): as desired, so velocity errors are zero
        actual_vel = np.array(read_values(self._vel_state)) if self._vel_state else self._desired_vel.copy()
        if self._desired_pos is None:
            if not np.all(np.isfinite(actual_pos)):
                return  # no state yet: command nothing
            self._hold(actual_pos)

        self._take_new_trajectory(time, actual_pos)
        active = self._active
        if active is not None:
            goal = active.goal
            if goal is not None and goal.is_cancel_requested:
                self._hold(actual_pos)
                self._finish_goal("canceled", SUCCESSFUL, "goal canceled")
            else:
                self._follow(active, time, actual_pos, actual_vel)

        self._write_commands(actual_pos, actual_vel, period)
        if time - self._last_state_pub >= self.state_period - 1e-6:  # float ticks: 0.01 * 2 < 0.02
            self._last_state_pub = time
            self._publish_state(time, actual_pos, actual_vel)

    def _take_new_trajectory(self, time: float, actual_pos: np.ndarray) -> None:
        newest: _Incoming | None = None
        while self._inbox:
            incoming = self._inbox.popleft()
            if newest is not None:
                self._end(newest.goal, "abort", INVALID_GOAL, "preempted by a newer trajectory")
            newest = incoming
        if newest is None:
            return
        if self._active is not None:
            self._finish_goal("abort", INVALID_GOAL, f"preempted by a new {newest.label}")
        trajectory = newest.trajectory
        if trajectory.starts_on_receipt:
            trajectory.start_time = time
        idx = trajectory.joint_indices
        # Start from the last commanded state: the first command equals the previous one (no jump).
        # (the last output when the limiter held the command back from the desired state)
        start = self._desired_pos if self._last_output is None else self._last_output
        trajectory.set_start_state(start[idx], self._desired_vel[idx], self._desired_acc[idx])
        ratio, worst, speed = trajectory.speed_ratio(self.limits.velocity)
        if ratio > 1.0:
            # Slower, never refused: the whole timing stretches so the fastest joint meets its limit.
            trajectory.scale_time(ratio)
            joint = trajectory.joint_names[worst]
            self.logger.warn(f"{self.name}: {newest.label} slowed down {ratio:.3g}x: joint '{joint}' would need "
                             f"{speed:.4g} rad/s, its velocity limit is {self.limits.velocity[idx[worst]]:g} rad/s")
        if newest.goal is not None:
            newest.goal.execute()
        self._active = _Active(trajectory, newest.goal, newest.tolerances or self.default_tolerances)

    def _follow(self, active: _Active, time: float, actual_pos: np.ndarray, actual_vel: np.ndarray) -> None:
        trajectory = active.trajectory
        sample = trajectory.sample(time, self.interpolate_points)
        idx = trajectory.joint_indices
        self._desired_pos[idx] = sample.positions
        self._desired_vel[idx] = sample.velocities
        self._desired_acc[idx] = sample.accelerations
        goal = active.goal
        if goal is None:
            if self.cmd_timeout > 0.0 and time > trajectory.end_time + self.cmd_timeout:
                self.logger.warn(f"{self.name}: command timed out ({self.cmd_timeout} s after the last point): "
                                 "holding position")
                self._hold(actual_pos)
                self._active = None
            elif sample.past_end and self.cmd_timeout <= 0.0:
                self._active = None  # keep the last point as the hold command
            return
        tol = active.tolerances
        pos_err = sample.positions - actual_pos[idx]
        if time - active.last_feedback >= self.feedback_period - 1e-6:
            active.last_feedback = time
            self._publish_feedback(goal, time, sample, actual_pos[idx], actual_vel[idx])
        if not sample.past_end:
            if not sample.before_start:
                bad = _violations(pos_err, tol.path_position[idx])
                vel_err = sample.velocities - actual_vel[idx]
                bad += _violations(vel_err, tol.path_velocity[idx])
                if bad:
                    names = ", ".join(f"{trajectory.joint_names[i]} (error {pos_err[i]:+.4f})" for i in bad)
                    self._hold(actual_pos)
                    self._finish_goal("abort", PATH_TOLERANCE_VIOLATED, f"path tolerance violated by {names}")
            return
        outside = _violations(pos_err, tol.goal_position[idx]) + _violations(actual_vel[idx],
                                                                             tol.goal_velocity[idx])
        if not outside:
            self._finish_goal("succeed", SUCCESSFUL, "")
            self._active = None  # hold the final point
        elif tol.goal_time > 0.0 and time > trajectory.end_time + tol.goal_time:
            names = ", ".join(f"{trajectory.joint_names[i]} (error {pos_err[i]:+.4f})" for i in sorted(set(outside)))
            self._hold(actual_pos)
            self._finish_goal("abort", GOAL_TOLERANCE_VIOLATED,
                              f"goal tolerance not met {tol.goal_time} s after the end: {names}")

    def _hold(self, actual_pos: np.ndarray) -> None:
        self._desired_pos = np.array(actual_pos, dtype=float)
        self._desired_vel = np.zeros(len(self.joints))
        self._desired_acc = np.zeros(len(self.joints))

    def _limit_command(self, period: float) -> np.ndarray:
        """ros2_control's joint limiter on the position command: inside the position limits, and no
        faster than the velocity limit from the previous command (the desired state is left alone, so
        the command keeps moving towards it)."""
        output = self._desired_pos
        last = self._last_output
        if last is not None and period > 0.0:
            step = self.limits.velocity * period
            output = np.minimum(np.maximum(output, last - step), last + step)
        output = np.minimum(np.maximum(output, self.limits.lower), self.limits.upper)
        self._last_output = output
        return output

    def _write_commands(self, actual_pos: np.ndarray, actual_vel: np.ndarray, period: float) -> None:
        desired = self._desired_pos
        if self._pos_cmd:
            write_values(self._pos_cmd, (self._limit_command(period) if self._limit_output else desired).tolist())
            if self._vel_cmd:
                velocity = self._desired_vel
                if self._limit_output:
                    velocity = np.minimum(np.maximum(velocity, -self.limits.velocity), self.limits.velocity)
                write_values(self._vel_cmd, velocity.tolist())
            return
        if not self.closed_loop:  # velocity-only, open loop: the desired velocity as it is
            velocity = self._desired_vel
            if self._limit_output:
                velocity = np.minimum(np.maximum(velocity, -self.limits.velocity), self.limits.velocity)
            write_values(self._vel_cmd, velocity.tolist())
            return
        # Velocity-only or effort: close the position loop with the gains (as ros2_controllers does):
        # command = ff_velocity_scale * desired velocity + PID(position error, velocity error).
        position_error = (desired - actual_pos).tolist()
        velocity_error = (self._desired_vel - actual_vel).tolist()
        feedforward = (self.ff_velocity_scale * self._desired_vel).tolist()
        output = [ff + pid.compute(e, de, period) for ff, pid, e, de
                  in zip(feedforward, self.pids, position_error, velocity_error, strict=True)]
        if self._vel_cmd and self._limit_output:
            output = np.minimum(np.maximum(output, -self.limits.velocity), self.limits.velocity).tolist()
        write_values(self._vel_cmd or self._eff_cmd, output)

    # --- goal bookkeeping ---------------------------------------------------------------------------
    def _finish_goal(self, how: str, code: int, text: str) -> None:
        active = self._active
        if active is None:
            return
        self._active = None
        self._end(active.goal, how, code, text)

    def _end(self, goal, how: str, code: int, text: str) -> None:
        if goal is None:
            if how == "abort" and text:
                self.logger.info(f"{self.name}: trajectory stopped: {text}")
            return
        if how != "succeed":
            self.logger.warn(f"{self.name}: goal {how}: {text}")
        result = _result(code, text)
        try:
            getattr(goal, {"succeed": "succeed", "abort": "abort", "canceled": "canceled"}[how])(result)
        except Exception as exc:  # a goal that already ended (client vanished) must not stop control
            self.logger.warn(f"{self.name}: could not report goal result: {exc}")

    # --- outputs ------------------------------------------------------------------------------------
    def _publish_feedback(self, goal, time: float, sample, actual_pos, actual_vel) -> None:
        names = self._active.trajectory.joint_names if self._active else []
        feedback = build_feedback(time, names, sample.positions, sample.velocities, actual_pos, actual_vel)
        try:
            goal.publish_feedback(feedback)
        except Exception as exc:
            self.logger.warn(f"{self.name}: feedback not sent: {exc}")

    def _publish_state(self, time: float, actual_pos: np.ndarray, actual_vel: np.ndarray) -> None:
        # fields for the generated packer (packed after the hardware command), no message instances
        desired = _point_map(self._desired_pos, self._desired_vel)
        output = desired if self._last_output is None else _point_map(self._last_output, self._desired_vel)
        actual = _point_map(actual_pos, actual_vel)
        error = _point_map(self._desired_pos - actual_pos, self._desired_vel - actual_vel)
        self._state_pub.publish_fields(
            header=_header(stamp=msgs.time_map(time)), joint_names=self.joints,
            reference=desired, feedback=actual, error=error, output=output, speed_scaling_factor=1.0)


def _violations(error: np.ndarray, tolerance: np.ndarray) -> list[int]:
    """Indices where a tolerance is set (> 0) and |error| exceeds it."""
    return [i for i in np.nonzero((tolerance > 0.0) & (np.abs(error) > tolerance))[0].tolist()]


def _get(obj, name: str):
    return obj.get(name) if isinstance(obj, dict) else getattr(obj, name, None)


def _result(code: int, text: str):
    return FollowJointTrajectory.Result(error_code=code, error_string=text)


_header = msgs.builder("std_msgs/msg/Header")
_point = msgs.builder("trajectory_msgs/msg/JointTrajectoryPoint")


def _point_map(positions, velocities) -> dict:
    return _point(positions=np.asarray(positions, dtype=float).tolist(),
                  velocities=np.asarray(velocities, dtype=float).tolist())


def build_feedback(time: float, names, desired_pos, desired_vel, actual_pos, actual_vel):
    """FollowJointTrajectory feedback built from the classes directly (no dict validation on this path)."""
    point = JointTrajectoryPoint
    header = Header(stamp=msgs.time_from_sec(time), frame_id="")
    desired_pos, desired_vel = np.asarray(desired_pos, dtype=float), np.asarray(desired_vel, dtype=float)
    actual_pos, actual_vel = np.asarray(actual_pos, dtype=float), np.asarray(actual_vel, dtype=float)
    return FollowJointTrajectory.Feedback(
        header=header, joint_names=list(names),
        desired=point(positions=desired_pos.tolist(), velocities=desired_vel.tolist()),
        actual=point(positions=actual_pos.tolist(), velocities=actual_vel.tolist()),
        error=point(positions=(desired_pos - actual_pos).tolist(), velocities=(desired_vel - actual_vel).tolist()),
    )
