"""When a QoS event is due: deadline, liveliness and lease bookkeeping, on whatever clock the caller passes.

No threads, no Zenoh, no executor here (``rclpy/_qos_events.py`` wires these to them), so the timing is
tested with a fake clock. Times are seconds on a monotonic clock.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Hashable
from dataclasses import dataclass


class DeadlineWatch:
    """A deadline of ``period`` s: every whole period that passes without an event is one miss, counted from
    the first event on (as DDS counts per instance, and an instance exists once its first sample does)."""

    def __init__(self, period: float) -> None:
        if not period > 0:
            raise ValueError(f"deadline period must be > 0 s, got {period}")
        self.period = period
        self.total_count = 0
        self._due: float | None = None
        self._lock = threading.Lock()

    def event(self, now: float) -> None:
        """A message arrived (subscription) or was published (publisher)."""
        with self._lock:
            self._due = now + self.period

    def poll(self, now: float) -> tuple[int, int] | None:
        """``(total_count, total_count_change)`` when periods were missed since the last poll, else None."""
        with self._lock:
            if self._due is None or now < self._due:
                return None
            missed = int((now - self._due) // self.period) + 1
            self._due += missed * self.period
            self.total_count += missed
            return self.total_count, missed


class LeaseWatch:
    """A MANUAL_BY_TOPIC publisher's own lease: lost once when ``lease`` s pass without an assertion (counted
    from the first one), alive again at the next."""

    def __init__(self, lease: float) -> None:
        self.lease = lease
        self.total_count = 0
        self._last: float | None = None
        self._lost = False
        self._lock = threading.Lock()

    def asserted(self, now: float) -> None:
        with self._lock:
            self._last, self._lost = now, False

    def poll(self, now: float) -> tuple[int, int] | None:
        """``(total_count, total_count_change)`` when the lease lapsed since the last poll, else None."""
        with self._lock:
            if self._last is None or self._lost or now - self._last <= self.lease:
                return None
            self._lost = True
            self.total_count += 1
            return self.total_count, 1


@dataclass
class _Writer:
    present: bool = True
    manual: bool = False
    alive: bool = True
    last: float = 0.0


@dataclass(frozen=True)
class LivelinessStatus:
    alive_count: int
    not_alive_count: int
    alive_count_change: int
    not_alive_count_change: int


class LivelinessTracker:
    """The publishers a subscription matches, alive or not. A publisher is alive from when it appears until
    it goes away (its graph token is dropped: destroyed, or its process died), and a manual one only while
    it asserts at least once every ``lease`` s (None: no lease). One that went away stays counted as not
    alive (Zenoh does not tell a destroyed publisher from a killed one), the ``MAX_GONE`` latest of them:
    publishers that come and go for days do not grow the count, or the memory, without bound."""

    MAX_GONE = 256

    def __init__(self, lease: float | None) -> None:
        self.lease = lease
        self._writers: dict[Hashable, _Writer] = {}
        self._reported = (0, 0)
        self._lock = threading.Lock()

    def writer(self, writer: Hashable, present: bool, now: float) -> None:
        with self._lock:
            state = self._writers.get(writer)
            if present:
                if state is None:
                    self._writers[writer] = _Writer(last=now)
                elif not state.present:
                    state.present, state.alive, state.last = True, True, now
            elif state is not None:
                state.present = state.alive = False
                self._writers[writer] = self._writers.pop(writer)   # the latest gone last
                gone = [w for w, s in self._writers.items() if not s.present]
                for old in gone[:max(0, len(gone) - self.MAX_GONE)]:
                    del self._writers[old]

    def manual(self, writer: Hashable, now: float) -> None:
        """``writer`` asserts its liveliness by hand (MANUAL_BY_TOPIC)."""
        with self._lock:
            state = self._writers.setdefault(writer, _Writer(last=now))
            state.manual = True

    def asserted(self, writer: Hashable, now: float) -> None:
        with self._lock:
            state = self._writers.get(writer)
            if state is None:
                self._writers[writer] = _Writer(manual=True, last=now)
                return
            state.last = now
            if state.present:
                state.alive = True

    def expire(self, now: float) -> None:
        """Manual publishers whose lease passed without an assertion are not alive any more."""
        if self.lease is None:
            return
        with self._lock:
            for state in self._writers.values():
                if state.alive and state.manual and now - state.last > self.lease:
                    state.alive = False

    def report(self) -> LivelinessStatus | None:
        """The counts when they changed since the last report, with the changes; else None."""
        with self._lock:
            alive = sum(1 for s in self._writers.values() if s.alive)
            not_alive = len(self._writers) - alive
            before = self._reported
            if (alive, not_alive) == before:
                return None
            self._reported = (alive, not_alive)
        return LivelinessStatus(alive, not_alive, alive - before[0], not_alive - before[1])


class MatchedCounter:
    """The peers an endpoint matches (a publisher's subscriptions, a subscription's publishers): how many now
    and how many ever."""

    def __init__(self) -> None:
        self._current: set[Hashable] = set()
        self.total_count = 0
        self._reported = (0, 0)
        self._lock = threading.Lock()

    def change(self, peer: Hashable, present: bool) -> None:
        with self._lock:
            if present and peer not in self._current:
                self._current.add(peer)
                self.total_count += 1
            elif not present:
                self._current.discard(peer)

    def report(self) -> tuple[int, int, int, int] | None:
        """``(total_count, total_count_change, current_count, current_count_change)`` when either changed since
        the last report, else None."""
        with self._lock:
            now = (self.total_count, len(self._current))
            before, self._reported = self._reported, now
        if now == before:
            return None
        return now[0], now[0] - before[0], now[1], now[1] - before[1]


def check_period(period: float) -> float:
    """How often a watch of ``period`` s is polled: a quarter of it, between 2 ms and 100 ms."""
    return min(max(period / 4.0, 0.002), 0.1)


def seconds(duration: object) -> float | None:
    """A QoS duration (rclpy Duration; 0 means unspecified) in s, None when infinite or unspecified."""
    ns = getattr(duration, "nanoseconds", 0) or 0
    if ns <= 0 or ns >= 9223372036854775807 or math.isinf(ns):
        return None
    return ns / 1e9
