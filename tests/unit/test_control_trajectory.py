"""Trajectory validation and interpolation (pure logic, no Zenoh)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodes.control.trajectory import TrajectoryError, validate_trajectory

JOINTS = ["a", "b"]


def point(t: float, positions, velocities=None, accelerations=None) -> dict:
    sec = int(t)
    p = {"positions": positions, "time_from_start": {"sec": sec, "nanosec": int(round((t - sec) * 1e9))}}
    if velocities is not None:
        p["velocities"] = velocities
    if accelerations is not None:
        p["accelerations"] = accelerations
    return p


def traj(points, joints=JOINTS, stamp=0.0) -> dict:
    return {"header": {"stamp": {"sec": int(stamp), "nanosec": int((stamp % 1) * 1e9)}},
            "joint_names": joints, "points": points}


def test_linear_interpolation_starts_from_the_start_state_without_a_jump():
    t = validate_trajectory(traj([point(1.0, [1.0, -1.0])]), JOINTS, now=10.0)
    t.start_time = 10.0
    t.set_start_state(np.array([0.2, 0.0]), np.zeros(2))
    s0 = t.sample(10.0)
    assert np.allclose(s0.positions, [0.2, 0.0])  # the first command equals the start state
    mid = t.sample(10.5)
    assert np.allclose(mid.positions, [0.6, -0.5])
    assert np.allclose(mid.velocities, [0.8, -1.0])
    end = t.sample(11.0)
    assert end.past_end and np.allclose(end.positions, [1.0, -1.0])


def test_cubic_matches_positions_and_velocities_at_both_ends():
    t = validate_trajectory(traj([point(0.0, [0.0, 0.0], [0.0, 0.0]), point(2.0, [1.0, 2.0], [0.5, 0.0])]),
                            JOINTS, now=0.0)
    t.set_start_state(np.zeros(2), np.zeros(2))
    eps = 1e-6
    near_end = t.sample(2.0 - eps)
    assert np.allclose(near_end.positions, [1.0, 2.0], atol=1e-5)
    assert np.allclose(near_end.velocities, [0.5, 0.0], atol=1e-4)
    start = t.sample(0.0)
    assert np.allclose(start.velocities, [0.0, 0.0])
    # Cubic with zero end velocities on joint b is symmetric: half way at half time.
    assert t.sample(1.0).positions[1] == pytest.approx(1.0)


def test_quintic_matches_accelerations_at_both_ends():
    t = validate_trajectory(traj([
        point(0.0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]),
        point(1.0, [1.0, 1.0], [0.0, 1.0], [0.0, -2.0])]), JOINTS, now=0.0)
    t.set_start_state(np.zeros(2), np.zeros(2))
    s = t.sample(1.0 - 1e-7)
    assert np.allclose(s.positions, [1.0, 1.0], atol=1e-5)
    assert np.allclose(s.velocities, [0.0, 1.0], atol=1e-4)
    assert np.allclose(s.accelerations, [0.0, -2.0], atol=1e-3)
    assert np.allclose(t.sample(0.0).accelerations, [0.0, 0.0])
    # A quintic rest-to-rest move is at half way at half time, a linear one would be too but with
    # a velocity jump; here the velocity at the start is zero.
    assert t.sample(0.5).positions[0] == pytest.approx(0.5)


def test_interpolation_none_steps_at_points():
    t = validate_trajectory(traj([point(1.0, [1.0, 1.0]), point(2.0, [2.0, 2.0])]), JOINTS, now=0.0)
    t.set_start_state(np.zeros(2), np.zeros(2))
    assert np.allclose(t.sample(1.5, interpolate_points=False).positions, [1.0, 1.0])
    assert np.allclose(t.sample(1.5).positions, [1.5, 1.5])


@pytest.mark.parametrize("msg, reason", [
    (traj([point(1.0, [1.0, 1.0])], joints=["a", "zz"]), "unknown joint 'zz'"),
    (traj([point(1.0, [1.0])]), "positions has 1 values, expected 2"),
    (traj([point(1.0, [1.0, 1.0]), point(1.0, [2.0, 2.0])]), "must increase strictly"),
    (traj([point(1.0, [1.0, 1.0]), point(0.5, [2.0, 2.0])]), "must increase strictly"),
    (traj([point(1.0, [1.0, 1.0])], stamp=3.0), "ends in the past"),
    (traj([point(1.0, [math.nan, 1.0])]), "positions[0] is not finite"),
    (traj([point(1.0, [1.0, 1.0], [0.0, math.inf])]), "velocities[1] is not finite"),
    (traj([]), "points is empty"),
    (traj([point(1.0, [1.0])], joints=["a"]), "missing joints ['b']"),
    (traj([point(1.0, [1.0, 1.0])], joints=["a", "a"]), "appears twice"),
    (traj([point(1.0, [1.0, 1.0], [1.0])]), "velocities has 1 values"),
])
def test_invalid_trajectories_are_rejected_with_the_reason(msg, reason):
    with pytest.raises(TrajectoryError) as info:
        validate_trajectory(msg, JOINTS, now=10.0)
    assert reason in str(info.value)


def test_partial_goal_allowed_when_configured():
    t = validate_trajectory(traj([point(1.0, [1.0])], joints=["b"]), JOINTS, now=0.0,
                            allow_partial_joints_goal=True)
    assert t.joint_indices == [1]


def test_stamped_trajectory_in_the_future_waits_at_its_start_state():
    t = validate_trajectory(traj([point(1.0, [1.0, 1.0])], stamp=20.0), JOINTS, now=10.0)
    assert not t.starts_on_receipt and t.start_time == pytest.approx(20.0)
    t.set_start_state(np.array([0.3, 0.3]), np.zeros(2))
    s = t.sample(15.0)
    assert s.before_start and np.allclose(s.positions, [0.3, 0.3])


finite = st.floats(-3.0, 3.0, allow_nan=False)


def _random_trajectory(data, with_velocity: bool, with_acceleration: bool):
    n = data.draw(st.integers(1, 6))
    gaps = data.draw(st.lists(st.floats(0.05, 2.0), min_size=n, max_size=n))
    times = np.cumsum(gaps)
    points = []
    for t in times:
        p = {"positions": [data.draw(finite), data.draw(finite)],
             "time_from_start": {"sec": int(t), "nanosec": int(round((t % 1) * 1e9)) % 1_000_000_000}}
        if with_velocity:
            p["velocities"] = [data.draw(finite), data.draw(finite)]
        if with_acceleration:
            p["accelerations"] = [data.draw(finite), data.draw(finite)]
        points.append(p)
    return traj(points)


@pytest.mark.parametrize("with_velocity, with_acceleration", [(False, False), (True, False), (True, True)])
def test_interpolation_passes_through_every_point_and_is_continuous(with_velocity, with_acceleration):
    @settings(max_examples=60, deadline=None)
    @given(st.data())
    def check(data):
        t = validate_trajectory(_random_trajectory(data, with_velocity, with_acceleration), JOINTS, now=0.0)
        start = np.array([data.draw(finite), data.draw(finite)])
        t.set_start_state(start, np.zeros(2))
        assert np.allclose(t.sample(0.0).positions, start)  # no jump at the start
        eps = 1e-7
        for k, knot in enumerate(t.times):
            assert np.allclose(t.sample(float(knot)).positions, t.positions[k], atol=1e-6)
            left, right = t.sample(float(knot) - eps), t.sample(float(knot) + eps)
            assert np.allclose(left.positions, right.positions, atol=1e-4)  # continuous position
            if with_velocity and k < len(t.times) - 1:
                assert np.allclose(left.velocities, right.velocities, atol=1e-2)  # and velocity

    check()


# --- limits -----------------------------------------------------------------------------------------------
def test_speed_ratio_counts_the_start_segment_every_segment_and_explicit_velocities():
    from nodes.control.trajectory import JointLimits
    limits = JointLimits(np.array([-1.0, -1.0]), np.array([1.0, 1.0]), np.array([2.0, np.inf]))
    t = validate_trajectory(traj([point(0.1, [0.8, 5.0])]), JOINTS, now=0.0)
    t.set_start_state(np.zeros(2), np.zeros(2))
    ratio, worst, speed = t.speed_ratio(limits.velocity)
    assert (ratio, worst, speed) == (pytest.approx(4.0), 0, pytest.approx(8.0))    # b has no limit
    t.scale_time(ratio)
    assert t.speed_ratio(limits.velocity)[0] == pytest.approx(1.0)
    assert t.sample(t.start_time + 0.4).positions[0] == pytest.approx(0.8)
    fast_velocity = validate_trajectory(traj([point(1.0, [0.1, 0.0], [3.0, 0.0])]), JOINTS, now=0.0)
    fast_velocity.set_start_state(np.zeros(2), np.zeros(2))
    assert fast_velocity.speed_ratio(limits.velocity)[0] == pytest.approx(1.5)
    # a first point at time 0 is a jump (the controller's output limiter handles it), not a segment
    jump = validate_trajectory(traj([point(0.0, [0.9, 0.0]), point(1.0, [1.0, 0.0])]), JOINTS, now=0.0)
    jump.set_start_state(np.zeros(2), np.zeros(2))
    assert jump.speed_ratio(limits.velocity)[0] == pytest.approx(0.05)


def test_position_limits_and_hardware_zero_meaning_none():
    from nodes.control.interfaces import JointInfo
    from nodes.control.trajectory import JointLimits
    limits = JointLimits.from_hardware(JOINTS, {"a": JointInfo("a", min_position=-0.5, max_position=0.5,
                                                               max_velocity=0.0),
                                                "b": JointInfo("b", min_position=0.0, max_position=0.0)})
    assert list(limits.upper) == [0.5, math.inf] and list(limits.velocity) == [math.inf, math.inf]
    validate_trajectory(traj([point(1.0, [0.5, 99.0])]), JOINTS, now=0.0, limits=limits)   # at the limit: fine
    with pytest.raises(TrajectoryError, match=r"points\[0\]\.positions\[0\]: joint 'a' -0.6 rad is outside its "
                                              r"lower limit -0.5 rad"):
        validate_trajectory(traj([point(1.0, [-0.6, 0.0])]), JOINTS, now=0.0, limits=limits)


# --- the plain-Python speed and limit checks against numpy references -------------------------------------
def _numpy_speed_ratio(t, max_velocity: np.ndarray) -> tuple[float, int, float]:
    """The vectorised form of ``Trajectory.speed_ratio`` (what it computed before it became a loop)."""
    limits = np.asarray(max_velocity, dtype=float)[t.joint_indices]
    if not np.isfinite(limits).any():
        return 0.0, 0, 0.0
    positions, times = t.positions, t.times
    if t.start_positions is not None and times[0] > 0.0:
        positions = np.vstack([t.start_positions, positions])
        times = np.concatenate([[0.0], times])
    speeds = [np.zeros(len(limits))]
    if len(times) > 1:
        with np.errstate(invalid="ignore", over="ignore"):
            segment = np.abs(np.diff(positions, axis=0)) / np.diff(times)[:, None]
        speeds.append(np.nanmax(np.where(np.isfinite(segment), segment, 0.0), axis=0))
    if t.velocities is not None:
        speeds.append(np.max(np.abs(t.velocities), axis=0))
    speed = np.max(speeds, axis=0)
    ratio = np.where(np.isfinite(limits), speed / np.where(limits > 0, limits, 1.0), 0.0)
    worst = int(np.argmax(ratio))
    return float(ratio[worst]), worst, float(speed[worst])


_value = st.floats(-4.0, 4.0, allow_nan=False)
_limit = st.sampled_from([0.5, 1.0, 3.0, math.inf, 0.0])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.floats(0.001, 2.0), st.lists(_value, min_size=3, max_size=3),
                          st.one_of(st.none(), st.lists(_value, min_size=3, max_size=3)),
                          st.booleans()), min_size=1, max_size=6),
       st.lists(_limit, min_size=3, max_size=3), st.lists(_value, min_size=3, max_size=3),
       st.floats(-2.0, 2.0), st.booleans())
def test_speed_ratio_and_position_limits_match_their_numpy_forms(steps, max_velocity, start, bound, first_at_zero):
    from nodes.control.trajectory import JointLimits, _check_position_limits
    joints = ["a", "b", "c"]
    points, t = [], 0.0 if first_at_zero else None
    for dt, positions, velocities, velocity_only in steps:
        t = dt if t is None else t + dt
        p = point(t, [] if velocity_only and velocities is not None else positions, velocities)
        points.append(p)
    if first_at_zero:
        points[0]["time_from_start"] = {"sec": 0, "nanosec": 0}
    msg = traj(points, joints)
    try:
        trajectory = validate_trajectory(msg, joints, now=0.0, require_positions=False)
    except TrajectoryError:
        return  # e.g. two points at one time after rounding to nanoseconds
    velocity = np.array(max_velocity)
    trajectory.set_start_state(np.array(start), np.zeros(3))
    assert trajectory.speed_ratio(velocity) == _numpy_speed_ratio(trajectory, velocity)
    ratio = trajectory.speed_ratio(velocity)[0]
    if ratio > 1.0:
        trajectory.scale_time(ratio)
        assert trajectory.speed_ratio(velocity)[0] == pytest.approx(_numpy_speed_ratio(trajectory, velocity)[0])

    # position limits: the first value outside, in point-major order, as numpy's argwhere finds it
    limits = JointLimits(np.full(3, -abs(bound)), np.full(3, abs(bound)), velocity)
    positions = trajectory.positions
    with np.errstate(invalid="ignore"):
        outside = np.argwhere((positions < limits.lower) | (positions > limits.upper))
    try:
        _check_position_limits(positions.tolist(), joints, [0, 1, 2], limits)
        assert len(outside) == 0
    except TrajectoryError as exc:
        i, k = (int(v) for v in outside[0])
        assert str(exc).startswith(f"points[{i}].positions[{k}]: joint '{joints[k]}' {positions[i, k]:g} rad")


def test_an_infinite_segment_speed_counts_zero_as_numpy_did():
    t = validate_trajectory(traj([point(0.0, [1e308, 0.0]), point(1.0, [-1e308, 1.0])]), JOINTS, now=0.0)
    t.set_start_state(np.zeros(2), np.zeros(2))
    limits = np.array([1.0, 1.0])
    assert t.speed_ratio(limits) == _numpy_speed_ratio(t, limits) == (1.0, 1, 1.0)
