"""Squat commander (seed 000's "motion sequence" exercise): start standing, bend the knees to ``depth``
(45°, 0.785 rad) over ``down_time`` s, hold ``hold_time`` s, stand up over ``up_time`` s, repeat
(``cycles`` times, 0 = forever).

Hips and ankles compensate: ``hip + knee + ankle = 0`` keeps the soles parallel to the ground, and the
hip/ankle split keeps the hip straight above the ankle (``thigh·sin(hip) = shin·sin(ankle)``, lengths
from the URDF), so the pelvis goes straight down and the centre of mass stays over the feet. Each phase
is a minimum-jerk profile sampled every ``sample_period`` s into JointTrajectory points carrying
positions, velocities and accelerations (the controller interpolates quintic splines between them).

Before anything is sent, every target is checked against the joint limits of the robot description
fetched at start (``<ns>/robot_description``, latched): a position outside a limit, or a peak speed
above a velocity limit, is refused with the joint, the value and the limit (exit status 2 at start; a
live ``param set`` is refused and the old value kept). Every parameter but ``controller`` and
``description_timeout`` applies live, from the next cycle on.

Publishes ``<ns>/<controller>/joint_trajectory``; waits for ``<ns>/<controller>/controller_state`` (the
controller is active) before the first cycle.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass

from msgs import duration_from_sec
from msgs.control_msgs import JointTrajectoryControllerState as ControllerState
from msgs.std_msgs import String
from msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from nodes.commanders.joint_commander import LEG_JOINTS
from nodes.commanders.live import declare_controller, restart
from nodes.commanders.trajectories import trajectory
from nodes.core import Node, run_node
from nodes.urdf.model import RobotModel, UrdfError, parse_urdf

SIDES = ("left", "right")


class SquatError(ValueError):
    """A squat the robot cannot do (joint limits, geometry); the message names joint, value and limit."""


@dataclass(frozen=True)
class SquatPose:
    """Pitch angles (rad) of one leg at the bottom of the squat."""

    hip_pitch: float
    knee: float
    ankle_pitch: float


def min_jerk(tau: float) -> tuple[float, float, float]:
    """Minimum-jerk blend s(τ), ds/dτ, d²s/dτ² for τ in [0, 1] (zero velocity and acceleration at both ends)."""
    tau = min(max(tau, 0.0), 1.0)
    s = tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))
    ds = 30.0 * tau**2 * (1.0 - tau) ** 2
    dds = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau)
    return s, ds, dds


def leg_lengths(model: RobotModel, side: str) -> tuple[float, float]:
    """Thigh (hip pitch → knee) and shin (knee → ankle pitch) lengths from the joint origins."""
    try:
        knee = model.joints[f"{side}_knee"]
        ankle = model.joints[f"{side}_ankle_pitch"]
    except KeyError as exc:
        raise SquatError(f"the robot has no joint {exc.args[0]!r} (a squat needs {side}_hip_pitch, "
                         f"{side}_knee and {side}_ankle_pitch)") from None
    thigh = math.dist(knee.origin[:3, 3], (0.0, 0.0, 0.0))
    shin = math.dist(ankle.origin[:3, 3], (0.0, 0.0, 0.0))
    if thigh <= 0.0 or shin <= 0.0:
        raise SquatError(f"{side} leg: thigh {thigh:g} m / shin {shin:g} m must be longer than 0")
    return thigh, shin


def squat_pose(depth: float, thigh: float, shin: float) -> SquatPose:
    """Knee at ``depth``; hip and ankle share the rest so the sole stays flat and the hip over the ankle."""
    hip = math.atan2(shin * math.sin(depth), thigh + shin * math.cos(depth))
    return SquatPose(hip_pitch=-hip, knee=depth, ankle_pitch=-(depth - hip))


def leg_targets(pose: SquatPose) -> dict[str, float]:
    """Every leg joint at the bottom of the squat (yaw and roll stay 0)."""
    targets = {name: 0.0 for name in LEG_JOINTS}
    for side in SIDES:
        targets[f"{side}_hip_pitch"] = pose.hip_pitch
        targets[f"{side}_knee"] = pose.knee
        targets[f"{side}_ankle_pitch"] = pose.ankle_pitch
    return targets


def check_limits(model: RobotModel, targets: dict[str, float], move_time: float) -> None:
    """Refuse a target outside a joint's position limits, or a minimum-jerk move from standing (0) to it
    in ``move_time`` s whose peak speed (1.875 × distance / time) exceeds the joint's velocity limit."""
    for name, value in targets.items():
        joint = model.joints.get(name)
        if joint is None or not joint.movable:
            raise SquatError(f"joint {name!r} is not a movable joint of robot {model.name!r}")
        for pose, where in ((0.0, "standing"), (value, "squat")):
            if joint.lower is not None and pose < joint.lower:
                raise SquatError(f"joint {name!r} would reach {pose:.4g} rad ({where}), below its lower limit "
                                 f"{joint.lower:g} rad")
            if joint.upper is not None and pose > joint.upper:
                raise SquatError(f"joint {name!r} would reach {pose:.4g} rad ({where}), above its upper limit "
                                 f"{joint.upper:g} rad")
        peak = 1.875 * abs(value) / move_time
        if joint.velocity and peak > joint.velocity:
            raise SquatError(f"joint {name!r} would move at {peak:.4g} rad/s, above its velocity limit "
                             f"{joint.velocity:g} rad/s (make the move slower)")


def phase_points(joints: list[str], start: dict[str, float], goal: dict[str, float], t0: float, duration: float,
                 dt: float) -> list[JointTrajectoryPoint]:
    """Minimum-jerk from ``start`` to ``goal`` over ``duration``, sampled every ``dt`` after ``t0`` (the
    last point exactly at ``t0 + duration``)."""
    count = max(1, math.ceil(duration / dt - 1e-9))
    points = []
    for k in range(1, count + 1):
        tau = k / count
        s, ds, dds = min_jerk(tau)
        delta = [goal[j] - start[j] for j in joints]
        points.append(JointTrajectoryPoint(
            positions=[start[j] + s * d for j, d in zip(joints, delta, strict=True)],
            velocities=[ds * d / duration for d in delta],
            accelerations=[dds * d / duration**2 for d in delta],
            time_from_start=duration_from_sec(t0 + tau * duration)))
    return points


def squat_cycle(joints: list[str], bottom: dict[str, float], down: float, hold: float, up: float,
                dt: float) -> JointTrajectory:
    """One cycle from standing: down, hold (one point at the bottom, zero velocity), up."""
    standing = {j: 0.0 for j in joints}
    points = phase_points(joints, standing, bottom, 0.0, down, dt)
    if hold > 0.0:
        points.append(JointTrajectoryPoint(positions=[bottom[j] for j in joints], velocities=[0.0] * len(joints),
                                           accelerations=[0.0] * len(joints),
                                           time_from_start=duration_from_sec(down + hold)))
    points += phase_points(joints, bottom, standing, down + hold, up, dt)
    return trajectory(joints, points)


class Squat(Node):
    """Squats the humanoid: down over 2 s, hold 1 s, up over 2 s, repeat."""

    default_name = "squat"

    def __init__(self, **kwargs) -> None:
        super().__init__("squat", **kwargs)
        self.controller = declare_controller(self, "joint trajectory controller to command")
        self.declare_parameter("depth", 0.785, description="knee angle at the bottom (rad); 0.785 = 45°")
        self.declare_parameter("down_time", 2.0, description="s to go down", min_value=0.1)
        self.declare_parameter("hold_time", 1.0, description="s at the bottom", min_value=0.0)
        self.declare_parameter("up_time", 2.0, description="s to stand up", min_value=0.1)
        self.declare_parameter("stand_time", 0.0, description="s standing between cycles", min_value=0.0)
        self.declare_parameter("cycles", 0, description="squats to do, 0 = forever", min_value=0)
        self.declare_parameter("sample_period", 0.1, min_value=0.005, max_value=1.0,
                               description="s between trajectory points")
        timeout = self.declare_parameter("description_timeout", 30.0, min_value=0.0,
                                         description="s to wait for robot_description at start",
                                         read_only=restart("description_timeout"))
        self.joints = list(LEG_JOINTS)
        self.model = self._fetch_model(timeout)
        self.lengths = {side: leg_lengths(self.model, side) for side in SIDES}
        try:
            self.bottom = self._validated_bottom(self.get_parameter("depth"), self.get_parameter("down_time"),
                                                 self.get_parameter("up_time"))
        except SquatError as exc:
            self.logger.error(f"squat refused: {exc}")   # on rosout too; nothing has been sent
            raise
        self.add_on_set_parameter_callback(self._on_set_parameter)
        self.publisher = self.create_publisher(JointTrajectory, f"{self.controller}/joint_trajectory")
        self.create_subscription(ControllerState, f"{self.controller}/controller_state", self._on_controller_state)
        self.controller_active = False
        self.done = 0
        self.next_start: float | None = None
        self.create_timer(0.05, self._tick)
        bottom = ", ".join(f"{j} {self.bottom[j]:+.3f}" for j in ("left_hip_pitch", "left_knee", "left_ankle_pitch"))
        self.logger.info(f"squat ready: {bottom} rad; waiting for {self.resolve(self.controller)} to be active")

    # --- set-up -------------------------------------------------------------------------------------
    def _fetch_model(self, timeout: float) -> RobotModel:
        deadline = time.monotonic() + timeout
        while True:
            msg = self.fetch_latched(String, "robot_description", timeout=1.0)
            if msg is not None and msg.data.strip():
                try:
                    return parse_urdf(msg.data)
                except UrdfError as exc:
                    raise SquatError(f"robot_description: {exc}") from None
            if time.monotonic() >= deadline:
                raise SquatError(f"no robot description on {self.resolve('robot_description')} within {timeout:g} s")
            self.logger.info(f"waiting for {self.resolve('robot_description')}")

    def _validated_bottom(self, depth: float, down: float, up: float) -> dict[str, float]:
        if not math.isfinite(depth) or depth <= 0.0:
            raise SquatError(f"depth must be a positive knee angle in rad, got {depth}")
        targets: dict[str, float] = {}
        for side in SIDES:
            pose = squat_pose(depth, *self.lengths[side])
            targets.update({k: v for k, v in leg_targets(pose).items() if k.startswith(side)})
        check_limits(self.model, targets, min(down, up))
        return targets

    def _on_set_parameter(self, name: str, value) -> str | None:
        if name not in ("depth", "down_time", "up_time"):
            return None
        values = {k: self.get_parameter(k) for k in ("depth", "down_time", "up_time")} | {name: value}
        try:
            bottom = self._validated_bottom(values["depth"], values["down_time"], values["up_time"])
        except SquatError as exc:
            self.logger.error(f"{name} {value} refused: {exc}")
            return str(exc)
        self.bottom = bottom   # from the next cycle on
        return None

    # --- running ------------------------------------------------------------------------------------
    def _on_controller_state(self, msg) -> None:
        self.controller_active = True

    def _tick(self) -> None:
        if not self.controller_active:
            return
        now = self.now()
        if self.next_start is not None and now < self.next_start:
            return
        cycles = self.get_parameter("cycles")
        if cycles and self.done >= cycles:
            self.logger.info(f"squat: {self.done} cycles done")
            self.request_shutdown()
            return
        down, hold, up = (self.get_parameter(k) for k in ("down_time", "hold_time", "up_time"))
        self.publisher.publish(squat_cycle(self.joints, self.bottom, down, hold, up,
                                           self.get_parameter("sample_period")))
        self.done += 1
        self.next_start = now + down + hold + up + self.get_parameter("stand_time")
        total = f"/{cycles}" if cycles else ""
        self.logger.info(f"squat {self.done}{total}: down {down:g} s to knee {self.bottom['left_knee']:.3f} rad, "
                         f"hold {hold:g} s, up {up:g} s")


def main(argv: list[str] | None = None) -> int:
    return run_node(Squat, argv)


if __name__ == "__main__":
    sys.exit(main())
