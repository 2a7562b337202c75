"""``Clock``/``ROSClock``: system, steady or ROS time; a node's ROSClock follows ``sim/clock`` when
``use_sim_time`` is true (the node's ``nodes.core`` clock)."""

from __future__ import annotations

import threading
import time as _time
from collections.abc import Callable
from typing import Any

from rclpy.clock_type import ClockType
from rclpy.duration import Duration
from rclpy.time import Time

__all__ = ["Clock", "ClockChange", "ClockType", "JumpHandle", "JumpThreshold", "ROSClock", "TimeJump"]


class ClockChange:
    ROS_TIME_NO_CHANGE = 1
    ROS_TIME_ACTIVATED = 2
    ROS_TIME_DEACTIVATED = 3
    SYSTEM_TIME_NO_CHANGE = 4


class JumpThreshold:
    def __init__(self, *, min_forward: Duration | None, min_backward: Duration | None,
                 on_clock_change: bool = True) -> None:
        self.min_forward, self.min_backward, self.on_clock_change = min_forward, min_backward, on_clock_change


class TimeJump:
    def __init__(self, clock_change: int, delta: Duration) -> None:
        self.clock_change, self.delta = clock_change, delta


class JumpHandle:
    def __init__(self, clock: Clock, threshold: JumpThreshold, pre: Callable | None, post: Callable | None) -> None:
        self.clock, self.threshold, self.pre, self.post = clock, threshold, pre, post

    def unregister(self) -> None:
        return None


class Clock:
    def __init__(self, *, clock_type: ClockType = ClockType.SYSTEM_TIME) -> None:
        if not isinstance(clock_type, ClockType):
            raise TypeError("Clock type must be a ClockType enum")
        self._clock_type = clock_type
        self._sim_source: Callable[[], float] | None = None   # a node's sim time (seconds), when active

    def __new__(cls, *, clock_type: ClockType = ClockType.SYSTEM_TIME) -> Clock:
        if cls is Clock and clock_type == ClockType.ROS_TIME:
            return super().__new__(ROSClock)
        return super().__new__(cls)

    @property
    def clock_type(self) -> ClockType:
        return self._clock_type

    def __repr__(self) -> str:
        return f"Clock(clock_type={self._clock_type.name})"

    def now(self) -> Time:
        if self._clock_type == ClockType.STEADY_TIME:
            return Time(nanoseconds=_time.monotonic_ns(), clock_type=self._clock_type)
        if self._sim_source is not None:
            return Time(nanoseconds=int(round(self._sim_source() * 1e9)), clock_type=self._clock_type)
        return Time(nanoseconds=_time.time_ns(), clock_type=self._clock_type)

    def create_jump_callback(self, threshold: JumpThreshold, *, pre_callback: Callable | None = None,
                             post_callback: Callable | None = None) -> JumpHandle:
        return JumpHandle(self, threshold, pre_callback, post_callback)

    def sleep_until(self, until: Time, context: Any = None) -> bool:
        """Sleep until this clock reaches ``until``; False when the context shut down first."""
        from rclpy.context import get_default_context

        context = context or get_default_context()
        if until.clock_type != self._clock_type:
            raise ValueError("Time clock type does not match this clock's type")
        while True:
            if not context.ok():
                return False
            remaining = (until - self.now()).nanoseconds / 1e9
            if remaining <= 0:
                return True
            # sim time advances by messages: look again often; wall time: sleep it out in slices
            _time.sleep(min(remaining, 0.01 if self._sim_source is not None else 0.1))

    def sleep_for(self, rel_time: Duration, context: Any = None) -> bool:
        return self.sleep_until(self.now() + rel_time, context)


class ROSClock(Clock):
    def __init__(self, *, clock_type: ClockType = ClockType.ROS_TIME) -> None:
        super().__init__(clock_type=ClockType.ROS_TIME)
        self._lock = threading.Lock()

    @property
    def ros_time_is_active(self) -> bool:
        return self._sim_source is not None

    def _set_ros_time_is_active(self, enabled: bool) -> None:
        raise NotImplementedError("rclpy ROSClock._set_ros_time_is_active is not implemented by zenroid's "
                                  "rclpy: set the node's use_sim_time parameter (see docs/rclpy.md)")
