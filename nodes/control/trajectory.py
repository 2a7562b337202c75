"""Joint trajectories as ros2_controllers' JTC understands them: validation, interpolation, sampling.

Pure logic (no Zenoh, no messages beyond duck-typed ``JointTrajectory``-shaped objects), so it is unit
tested directly. Interpolation follows the fields each pair of points carries: positions only ->
linear, positions + velocities -> cubic, positions + velocities + accelerations -> quintic.

Beyond ros2_controllers' checks, a trajectory is refused when a position is outside the joint's limits,
when it has more than ``max_points`` points, when a time is beyond ``max_duration`` or a stamp is
negative or that far in the future. A trajectory that asks a joint to move faster than its velocity
limit is slowed down in time as a whole (``Trajectory.slow_down``), never refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from msgs import duration_to_sec, time_to_sec

LINEAR, CUBIC, QUINTIC = 1, 3, 5
MAX_POINTS = 100_000  # points per trajectory (the Atlas playback has 1,500)
MAX_DURATION = 3600.0  # s: time_from_start of any point, and how far in the future a stamp may start


class TrajectoryError(ValueError):
    """An incoming trajectory was rejected; the message says which field and why."""


def _field(obj, name: str):
    return obj.get(name) if isinstance(obj, dict) else getattr(obj, name, None)


@dataclass(frozen=True)
class JointLimits:
    """Position and velocity limits of a controller's joints, in its joint order (inf: no limit)."""

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray

    @classmethod
    def unlimited(cls, count: int) -> JointLimits:
        return cls(np.full(count, -math.inf), np.full(count, math.inf), np.full(count, math.inf))

    @classmethod
    def from_hardware(cls, joints: list[str], infos: dict) -> JointLimits:
        """From the hardware's joint descriptions (``JointInfo``-like; unknown joints are unlimited).

        ``hardware/info`` says "no limit" with 0: min = max = 0 for positions, <= 0 for velocity."""
        limits = cls.unlimited(len(joints))
        for i, name in enumerate(joints):
            info = infos.get(name)
            if info is None:
                continue
            lo, hi = float(info.min_position), float(info.max_position)
            if not (lo == 0.0 and hi == 0.0) and lo <= hi:
                limits.lower[i], limits.upper[i] = lo, hi
            if math.isfinite(info.max_velocity) and info.max_velocity > 0.0:
                limits.velocity[i] = float(info.max_velocity)
        return limits


@dataclass
class Sample:
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    before_start: bool  # t is before the trajectory's start time (holding the start state)
    past_end: bool  # t is at or after the last point


@dataclass
class Trajectory:
    """A validated trajectory over ``joint_indices`` (indices into the controller's joint list)."""

    joint_names: list[str]
    joint_indices: list[int]
    times: np.ndarray  # time_from_start of each point, strictly increasing
    positions: np.ndarray  # (points, joints)
    velocities: np.ndarray | None  # (points, joints) or None when no point carries them
    accelerations: np.ndarray | None
    has_velocity: list[bool]
    has_acceleration: list[bool]
    start_time: float  # absolute (sim) seconds
    starts_on_receipt: bool = True  # header.stamp was zero: the controller starts it when it takes it
    start_positions: np.ndarray | None = None  # state before the trajectory, set by ``set_start_state``
    start_velocities: np.ndarray | None = None
    start_accelerations: np.ndarray | None = None
    # per joint, the fastest the points themselves ask for (``peak_speeds``); the segment from the start
    # state is added by ``speed_ratio`` once that state is known
    peak_speeds: list[float] | None = None

    @property
    def end_time(self) -> float:
        return self.start_time + float(self.times[-1])

    def set_start_state(self, positions: np.ndarray, velocities: np.ndarray,
                        accelerations: np.ndarray | None = None) -> None:
        """Where the first segment starts: the joint state when the trajectory takes over (no jump)."""
        self.start_positions = np.asarray(positions, dtype=float)
        self.start_velocities = np.asarray(velocities, dtype=float)
        self.start_accelerations = (np.zeros_like(self.start_positions) if accelerations is None
                                    else np.asarray(accelerations, dtype=float))

    def speed_ratio(self, max_velocity) -> tuple[float, int, float]:
        """How much faster than its velocity limit the trajectory asks a joint to move.

        Returns ``(ratio, joint, speed)``: the largest ``speed / limit`` over the explicit ``velocities``
        and the average speed of every segment, the first one starting from the start state (a first
        point at time 0 is a jump no timing can slow: the controller's output limiter handles it), with
        the position in ``joint_names`` and the speed (rad/s) of the worst joint.

        Plain Python on the per-joint peaks found at validation: it runs in the control cycle that takes the
        trajectory, where a dozen numpy calls on arrays this small cost more than the loop (measured)."""
        limits = _floats_at(max_velocity, self.joint_indices)
        if not any(math.isfinite(limit) for limit in limits):
            return 0.0, 0, 0.0
        if self.peak_speeds is None:
            self.peak_speeds = peak_speeds(self.times.tolist(), self.positions.tolist(),
                                           self.velocities.tolist() if self.velocities is not None else [])
        speed = list(self.peak_speeds)
        first_time = float(self.times[0])
        if self.start_positions is not None and first_time > 0.0:
            _raise_peaks(speed, self.start_positions.tolist(), self.positions[0].tolist(), first_time)
        ratio, worst = -1.0, 0
        for k, (joint_speed, limit) in enumerate(zip(speed, limits, strict=True)):
            joint_ratio = joint_speed / (limit if limit > 0.0 else 1.0) if math.isfinite(limit) else 0.0
            if joint_ratio > ratio:
                ratio, worst = joint_ratio, k
        return ratio, worst, speed[worst]

    def scale_time(self, factor: float) -> None:
        """Stretch the timing by ``factor`` (> 1 slows down): times x f, velocities / f, accelerations / f²."""
        self.times = self.times * factor
        if self.peak_speeds is not None:
            self.peak_speeds = [speed / factor for speed in self.peak_speeds]
        if self.velocities is not None:
            self.velocities = self.velocities / factor
        if self.accelerations is not None:
            self.accelerations = self.accelerations / (factor * factor)

    def sample(self, t: float, interpolate_points: bool = True) -> Sample:
        """Desired positions/velocities/accelerations at absolute time ``t``.

        ``interpolate_points=False`` is ``interpolation_method: none``: the desired state steps from one
        point to the next when its time is reached."""
        rel = t - self.start_time
        n_joints = len(self.joint_indices)
        if rel < 0.0:
            p = self.start_positions if self.start_positions is not None else self.positions[0]
            return Sample(p.copy(), np.zeros(n_joints), np.zeros(n_joints), True, False)
        times = self.times
        last = len(times) - 1
        if rel >= times[last]:
            return Sample(self.positions[last].copy(), self._vel(last), self._acc(last), False, True)
        if rel < times[0]:
            if self.start_positions is None:
                raise TrajectoryError("trajectory sampled before its start state was set")
            degree = self._degree_from_start(0)
            p0, v0, a0 = self.start_positions, self.start_velocities, self.start_accelerations
            t0 = 0.0
            i1 = 0
            if not interpolate_points:
                return Sample(p0.copy(), np.zeros(n_joints), np.zeros(n_joints), False, False)
        else:
            i0 = int(np.searchsorted(times, rel, side="right")) - 1  # times[i0] <= rel < times[i0+1]
            i1 = i0 + 1
            degree = self._degree(i0, i1)
            p0, v0, a0 = self.positions[i0], self._vel(i0), self._acc(i0)
            t0 = float(times[i0])
            if not interpolate_points:
                return Sample(p0.copy(), v0, a0, False, False)
        p1, v1, a1 = self.positions[i1], self._vel(i1), self._acc(i1)
        return interpolate(degree, float(times[i1]) - t0, rel - t0, p0, v0, a0, p1, v1, a1)

    def _vel(self, i: int) -> np.ndarray:
        if self.velocities is not None and self.has_velocity[i]:
            return self.velocities[i].copy()
        return np.zeros(len(self.joint_indices))

    def _acc(self, i: int) -> np.ndarray:
        if self.accelerations is not None and self.has_acceleration[i]:
            return self.accelerations[i].copy()
        return np.zeros(len(self.joint_indices))

    def _degree(self, i0: int, i1: int) -> int:
        if self.has_velocity[i0] and self.has_velocity[i1]:
            if self.has_acceleration[i0] and self.has_acceleration[i1]:
                return QUINTIC
            return CUBIC
        return LINEAR

    def _degree_from_start(self, i1: int) -> int:
        # The start state always has velocity and acceleration: the first point decides.
        if self.has_velocity[i1]:
            return QUINTIC if self.has_acceleration[i1] else CUBIC
        return LINEAR


def interpolate(degree: int, duration: float, s: float, p0, v0, a0, p1, v1, a1) -> Sample:
    """Polynomial between two states over ``duration``, evaluated at ``s`` seconds into it."""
    T = duration
    if T <= 0.0:
        return Sample(np.array(p1, dtype=float), np.array(v1, dtype=float), np.array(a1, dtype=float),
                      False, False)
    if degree == LINEAR:
        slope = (p1 - p0) / T
        return Sample(p0 + slope * s, slope.copy(), np.zeros_like(p0), False, False)
    if degree == CUBIC:
        # p(s) = c0 + c1 s + c2 s^2 + c3 s^3 matching p and v at both ends.
        c0, c1 = p0, v0
        c2 = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * T) / T**2
        c3 = (2.0 * (p0 - p1) + (v0 + v1) * T) / T**3
        pos = c0 + s * (c1 + s * (c2 + s * c3))
        vel = c1 + s * (2.0 * c2 + 3.0 * c3 * s)
        acc = 2.0 * c2 + 6.0 * c3 * s
        return Sample(pos, vel, acc, False, False)
    # Quintic matching p, v, a at both ends.
    T2, T3, T4, T5 = T * T, T**3, T**4, T**5
    c0, c1, c2 = p0, v0, 0.5 * a0
    c3 = (20.0 * (p1 - p0) - (8.0 * v1 + 12.0 * v0) * T - (3.0 * a0 - a1) * T2) / (2.0 * T3)
    c4 = (30.0 * (p0 - p1) + (14.0 * v1 + 16.0 * v0) * T + (3.0 * a0 - 2.0 * a1) * T2) / (2.0 * T4)
    c5 = (12.0 * (p1 - p0) - (6.0 * v1 + 6.0 * v0) * T - (a0 - a1) * T2) / (2.0 * T5)
    pos = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
    vel = c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)))
    acc = 2.0 * c2 + s * (6.0 * c3 + s * (12.0 * c4 + s * 20.0 * c5))
    return Sample(pos, vel, acc, False, False)


def peak_speeds(times: list[float], positions: list[list[float]], velocities: list[list[float] | None]) -> list[float]:
    """Per joint: the largest of every explicit velocity's magnitude and the average speed of every segment
    between two points (a segment with a velocity-only point, NaN positions, or an infinite speed counts 0)."""
    peaks = [0.0] * len(positions[0])
    for i in range(1, len(times)):
        _raise_peaks(peaks, positions[i - 1], positions[i], times[i] - times[i - 1])
    for point_velocities in velocities:
        if point_velocities is not None:
            for k, value in enumerate(point_velocities):
                if abs(value) > peaks[k]:
                    peaks[k] = abs(value)
    return peaks


def _floats_at(values, indices: list[int]) -> list[float]:
    """``values[i]`` for each index, as Python floats (a per-joint limit array read for a trajectory's joints)."""
    return [float(values[i]) for i in indices]


def _raise_peaks(peaks: list[float], before: list[float], after: list[float], duration: float) -> None:
    for k, (p0, p1) in enumerate(zip(before, after, strict=True)):
        speed = abs(p1 - p0) / duration
        if speed > peaks[k] and speed != math.inf:   # NaN compares false
            peaks[k] = speed


def _float_list(values, where: str, expected: int) -> list[float] | None:
    """A point's array: None when empty, else exactly ``expected`` finite floats."""
    if values is None:
        return None
    values = list(values)
    if not values:
        return None
    if len(values) != expected:
        raise TrajectoryError(f"{where} has {len(values)} values, expected {expected} (one per joint)")
    out = []
    for k, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise TrajectoryError(f"{where}[{k}] is not a number: {v!r}")
        if not math.isfinite(v):
            raise TrajectoryError(f"{where}[{k}] is not finite ({v})")
        out.append(float(v))
    return out


def validate_trajectory(msg, controller_joints: list[str], *, now: float,
                        allow_partial_joints_goal: bool = False,
                        require_positions: bool = True,
                        limits: JointLimits | None = None,
                        max_points: int = MAX_POINTS,
                        max_duration: float = MAX_DURATION) -> Trajectory:
    """Turn a JointTrajectory into a ``Trajectory`` or raise TrajectoryError with the reason.

    Checks as ros2_controllers does: joint names known, not duplicated and (unless partial goals are
    allowed) complete; at least one point; each point's arrays the right length and finite; strictly
    increasing ``time_from_start``; a trajectory with a start stamp must not end in the past. And more:
    at most ``max_points`` points (checked before anything else is looked at), no ``time_from_start``
    beyond ``max_duration``, no negative stamp or one more than ``max_duration`` ahead of ``now``, every
    position inside the joint's ``limits``."""
    joint_names = list(_field(msg, "joint_names") or [])
    points = _field(msg, "points") or []
    if len(points) > max_points:
        raise TrajectoryError(f"points: {len(points)} points, more than the {max_points} allowed "
                              "(max_trajectory_points)")
    points = list(points)
    if not joint_names:
        raise TrajectoryError("joint_names is empty")
    if not points:
        raise TrajectoryError("points is empty (the trajectory has no points)")
    index_of = {name: i for i, name in enumerate(controller_joints)}
    seen: set[str] = set()
    for name in joint_names:
        if name not in index_of:
            raise TrajectoryError(f"joint_names: unknown joint '{name}' (controller joints: "
                                  f"{', '.join(controller_joints)})")
        if name in seen:
            raise TrajectoryError(f"joint_names: joint '{name}' appears twice")
        seen.add(name)
    if not allow_partial_joints_goal and len(joint_names) != len(controller_joints):
        missing = [j for j in controller_joints if j not in seen]
        raise TrajectoryError(f"joint_names: missing joints {missing} (allow_partial_joints_goal is false)")
    n = len(joint_names)
    times: list[float] = []
    positions: list[list[float]] = []
    velocities: list[list[float] | None] = []
    accelerations: list[list[float] | None] = []
    for i, point in enumerate(points):
        where = f"points[{i}]"
        tfs_raw = _field(point, "time_from_start")
        tfs = duration_to_sec(tfs_raw) if tfs_raw is not None else 0.0
        if not math.isfinite(tfs) or tfs < 0.0:
            raise TrajectoryError(f"{where}.time_from_start is negative or not finite ({tfs})")
        if tfs > max_duration:
            raise TrajectoryError(f"{where}.time_from_start {tfs:.6g} s is longer than the {max_duration:g} s "
                                  "allowed (max_trajectory_duration)")
        if times and tfs <= times[-1]:
            raise TrajectoryError(f"{where}.time_from_start ({tfs:.6g} s) is not after the previous point's "
                                  f"({times[-1]:.6g} s): time_from_start must increase strictly")
        pos = _float_list(_field(point, "positions"), f"{where}.positions", n)
        vel = _float_list(_field(point, "velocities"), f"{where}.velocities", n)
        acc = _float_list(_field(point, "accelerations"), f"{where}.accelerations", n)
        _float_list(_field(point, "effort"), f"{where}.effort", n)
        if pos is None:
            if require_positions:
                raise TrajectoryError(f"{where}.positions is empty (the controller commands positions)")
            pos = [math.nan] * n
        if acc is not None and vel is None:
            raise TrajectoryError(f"{where} has accelerations but no velocities")
        times.append(tfs)
        positions.append(pos)
        velocities.append(vel)
        accelerations.append(acc)
    joint_indices = [index_of[name] for name in joint_names]
    if limits is not None:
        _check_position_limits(positions, joint_names, joint_indices, limits)
    header = _field(msg, "header")
    stamp = time_to_sec(_field(header, "stamp")) if header is not None and _field(header, "stamp") is not None else 0.0
    if stamp < 0.0 or not math.isfinite(stamp):
        raise TrajectoryError(f"header.stamp is negative ({stamp:.9g} s)")
    if stamp > now + max_duration:
        raise TrajectoryError(f"header.stamp {stamp:.6g} s starts more than {max_duration:g} s after now "
                              f"({now:.3f} s) (max_trajectory_duration)")
    start_time = stamp if stamp > 0.0 else now
    if stamp > 0.0 and start_time + times[-1] < now:
        raise TrajectoryError(f"header.stamp {stamp:.3f} s + last time_from_start {times[-1]:.3f} s ends in the "
                              f"past (now {now:.3f} s)")
    has_vel = [v is not None for v in velocities]
    has_acc = [a is not None for a in accelerations]
    zeros = [0.0] * n
    vel_arr = np.array([v if v is not None else zeros for v in velocities]) if any(has_vel) else None
    acc_arr = np.array([a if a is not None else zeros for a in accelerations]) if any(has_acc) else None
    return Trajectory(
        joint_names=joint_names,
        joint_indices=joint_indices,
        times=np.array(times, dtype=float),
        positions=np.array(positions, dtype=float),
        velocities=vel_arr,
        accelerations=acc_arr,
        has_velocity=has_vel,
        has_acceleration=has_acc,
        start_time=start_time,
        starts_on_receipt=stamp <= 0.0,
        peak_speeds=peak_speeds(times, positions, velocities),
    )


def _check_position_limits(positions: list[list[float]], joint_names: list[str], joint_indices: list[int],
                           limits: JointLimits) -> None:
    """Refuse the first position outside its joint's [lower, upper] (NaN = velocity-only: not checked).

    A plain loop: the values were just checked one by one in Python anyway, and numpy's calls on a short
    trajectory cost more than the loop (this runs on every trajectory received)."""
    lower, upper = _floats_at(limits.lower, joint_indices), _floats_at(limits.upper, joint_indices)
    for i, point in enumerate(positions):
        for k, value in enumerate(point):
            if value < lower[k] or value > upper[k]:
                bound = f"lower limit {lower[k]:g}" if value < lower[k] else f"upper limit {upper[k]:g}"
                raise TrajectoryError(f"points[{i}].positions[{k}]: joint '{joint_names[k]}' {value:g} rad is "
                                      f"outside its {bound} rad (limits [{lower[k]:g}, {upper[k]:g}])")
