"""Pure trajectory builders shared by the commanders (no Zenoh, easy to unit test)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from msgs import duration_from_sec
from msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint


def point(positions: Sequence[float], time_from_start: float) -> JointTrajectoryPoint:
    return JointTrajectoryPoint(positions=[float(p) for p in positions],
                                time_from_start=duration_from_sec(time_from_start))


def trajectory(joint_names: Sequence[str], points: list[JointTrajectoryPoint],
               frame_id: str = "") -> JointTrajectory:
    # header.stamp stays zero: "start now" for the controller, whatever clock each node runs on.
    trajectory_msg = JointTrajectory(joint_names=list(joint_names), points=points)
    trajectory_msg.header.frame_id = frame_id
    return trajectory_msg


def single_point(joint_names: Sequence[str], positions: Sequence[float], seconds: float) -> JointTrajectory:
    if len(positions) != len(joint_names):
        raise ValueError(f"positions has {len(positions)} values for {len(joint_names)} joints")
    return trajectory(joint_names, [point(positions, seconds)])


def waveform_points(kind: str, amplitude: float, frequency: float, duration: float, dt: float,
                    joints: int = 1) -> list[JointTrajectoryPoint]:
    """The controller lab's sine / square waves: ``duration/dt`` points, t = i*dt (the first at 0)."""
    if kind not in ("sine", "square"):
        raise ValueError(f"waveform must be sine or square, got {kind!r}")
    if not (dt > 0 and duration > 0 and math.isfinite(dt) and math.isfinite(duration)):
        raise ValueError("duration and dt must be positive")
    points = []
    for i in range(int(round(duration / dt))):
        t = i * dt
        s = math.sin(2.0 * math.pi * frequency * t)
        value = amplitude * s if kind == "sine" else (amplitude if s >= 0 else -amplitude)
        points.append(point([value] * joints, t))
    return points
