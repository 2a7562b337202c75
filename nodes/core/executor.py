"""How a node's callbacks run: one at a time, as under rclpy's single-threaded executor.

Two ways to get there:

- **direct** (the default): a subscription's or service's callback runs on the Zenoh thread that
  delivered it, holding the node's executor lock; timers and ``call_soon`` work run on the thread that
  spins, holding the same lock. No thread hand-off per message, so a hop costs what raw Zenoh costs.
- **on the spin thread** (``Node.callbacks_on_spin_thread = True``): every callback is queued and run by
  whoever calls ``spin_once``. The simulator uses it: DART is only touched from its stepping loop, which
  serves requests between control periods.

While a node's constructor runs it holds the lock, so no callback sees a half-built node.

Nodes that run every callback on the spinning thread may also sort them into **callback groups**
(rclpy's model): the callbacks of an exclusive group never overlap, those of a reentrant group may, and
callbacks without a group share the node's lock. Several such nodes can be spun together, by one thread or
by several (``Spinner``): each executor wakes the spinner that serves it when work arrives.
"""

from __future__ import annotations

import heapq
import itertools
import queue
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable
from typing import Any

from nodes.core import panic

# How long an in-process hand-off waits for the receiving node's lock before queueing the callback for its
# spinning thread (a callback of that node is running; longer than any callback should take).
IN_PROCESS_LOCK_WAIT_S = 0.5


class Timer:
    """A periodic callback on the wall clock or on sim time (``now`` gives the current time)."""

    def __init__(self, period: float, callback: Callable[[], None], sim_time: bool, now: Callable[[], float]) -> None:
        if not period > 0:
            raise ValueError(f"timer period must be > 0, got {period}")
        self.period = float(period)
        self.callback = callback
        self.sim_time = sim_time
        self._now = now
        self.next_due = now() + self.period
        self.due_time = self.next_due   # while its callback runs: the time this tick was due
        self.cancelled = False
        self.group: CallbackGroup | None = None   # its callback group under a Spinner (None: the node's)

    def cancel(self) -> None:
        self.cancelled = True

    def reset(self) -> None:
        self.next_due = self._now() + self.period


class CallbackGroup:
    """Callbacks that never run at once (``exclusive``) or may run side by side on several spinning threads.

    A callback whose exclusive group is busy is parked, not waited for: a spinning thread never blocks on a
    group, so another group's work (a service response a running callback waits for) still gets a thread."""

    def __init__(self, exclusive: bool = True) -> None:
        self.exclusive = exclusive
        self._lock = threading.Lock()
        self._busy = False
        self._parked: deque[tuple[Executor, tuple[Any, ...]]] = deque()

    def enter(self, executor: Executor, item: tuple[Any, ...]) -> bool:
        """True when the callback may run now; else it is parked until the running one ends."""
        if not self.exclusive:
            return True
        with self._lock:
            if self._busy:
                self._parked.append((executor, item))
                return False
            self._busy = True
            return True

    def leave(self) -> None:
        if not self.exclusive:
            return
        with self._lock:
            self._busy = False
            parked = self._parked.popleft() if self._parked else None
        if parked is not None:
            executor, item = parked
            executor.put(item)


MIN_WORK_S = 0.01   # CPU s the spinner must have spent since the last probe to count as computing


class Executor:
    def __init__(self, report_error: Callable[[str], None], *, on_spin_thread: bool = False) -> None:
        self.report_error = report_error
        self.on_spin_thread = on_spin_thread
        self.lock = threading.RLock()
        # True: a callback's exception ends the spin that ran it (rclpy), instead of being reported
        self.propagate_errors = False
        # the group of callbacks dispatched without one (None: the node's lock)
        self.default_group: CallbackGroup | None = None
        self.wake: Callable[[], None] | None = None   # set by a Spinner that serves this executor
        self.waiting: queue.SimpleQueue = queue.SimpleQueue()
        # subscriptions whose messages wait in Zenoh's ring for a spinning thread (delivery.Spun); a new
        # list on each change: spinning threads read it without a lock
        self.channels: list[Any] = []
        self.wall_timers: list[tuple[float, int, Timer]] = []
        self._sim_timers: list[Timer] = []
        self._timer_seq = itertools.count()
        self._timer_lock = threading.Lock()
        self._stop = threading.Event()
        self._taken_at: float | None = None   # when a spinner last took queued work or found none (None: never)
        self._spinner: int | None = None       # the thread that did
        self._working: tuple[float, float] | None = None   # (when, its CPU time then): it last computed

    def stalled_for(self) -> float:
        """How long queued work has waited while no spinner took any and the spinner did not compute either:
        0 while it keeps up (idle, or busy in a long callback), growing while it is blocked. A node never
        spun is not stalled. (A spinner that loops for ever computing is busy, not blocked: not seen here.)"""
        taken = self._taken_at
        if taken is None or self.waiting.empty():
            return 0.0
        now = time.monotonic()
        cpu = self._spinner_cpu()
        if cpu is not None:
            if self._working is None:
                self._working = (taken, cpu)    # the baseline: its CPU time now, counted from the last take
            elif cpu - self._working[1] >= MIN_WORK_S:
                self._working = (now, cpu)
            taken = max(taken, self._working[0])
        return max(0.0, now - taken)

    def took(self) -> None:
        """A spinner is at this executor now (what the stall watch reads)."""
        self._taken_at, self._spinner, self._working = time.monotonic(), threading.get_ident(), None

    def _spinner_cpu(self) -> float | None:
        try:
            return time.clock_gettime(time.pthread_getcpuclockid(self._spinner))  # type: ignore[arg-type]
        except (AttributeError, OSError, TypeError, OverflowError):   # not Linux, or the thread is gone
            return None

    def mark(self) -> None:
        """Queue a no-op: the next ``stalled_for`` shows whether a spinner still takes work."""
        self.put((_nothing, (), "health", None))

    # ---------------------------------------------------------------- running callbacks
    def run_callback(self, fn: Callable[..., None], *args: Any, where: str = "callback") -> None:
        """Call ``fn(*args)`` here and now; an exception is reported and swallowed (the node lives on)."""
        try:
            fn(*args)
        except BaseException as exc:  # noqa: BLE001 - a failing callback is reported, the node keeps running
            if not isinstance(exc, Exception):
                if panic.is_zenoh_panic(exc):
                    panic.die(exc, where)
                raise
            tb = traceback.extract_tb(exc.__traceback__)
            at = f" at {tb[-1].filename}:{tb[-1].lineno}" if tb else ""
            self.report_error(f"exception in {where}: {type(exc).__name__}: {exc}{at}")

    def put(self, item: tuple[Any, ...]) -> None:
        """Queue ``(fn, args, where, group)`` for the spinning thread and wake whoever spins this executor."""
        self.waiting.put(item)
        wake = self.wake
        if wake is not None:
            wake()

    def dispatch(self, fn: Callable[..., None], *args: Any, where: str = "callback",
                 group: CallbackGroup | None = None) -> None:
        """Run a delivered callback one-at-a-time with the node's others (from a Zenoh thread)."""
        if self.on_spin_thread:
            self.put((fn, args, where, group))
            return
        with self.lock:
            self.run_callback(fn, *args, where=where)

    def dispatch_in_process(self, fn: Callable[..., None], *args: Any, where: str = "callback",
                            group: CallbackGroup | None = None) -> None:
        """Run a callback handed over in-process by another node of the same container, on the publishing
        thread when this node's lock is free soon. Waiting for it without end could deadlock two nodes that
        publish to each other from two threads, each holding its own lock: after ``IN_PROCESS_LOCK_WAIT_S`` the
        callback goes to this node's spinning thread instead."""
        if self.on_spin_thread:
            self.put((fn, args, where, group))
            return
        if not self.lock.acquire(timeout=IN_PROCESS_LOCK_WAIT_S):
            self.put((fn, args, where, group))
            return
        try:
            self.run_callback(fn, *args, where=where)
        finally:
            self.lock.release()

    def call_soon(self, fn: Callable[..., None], *args: Any, where: str = "callback",
                  group: CallbackGroup | None = None) -> None:
        """Queue ``fn(*args)`` for the spinning thread (from any thread)."""
        self.put((fn, args, where, group))

    def run_item(self, item: tuple[Any, ...]) -> bool:
        """Run one queued callback under its group (or the node's lock); False when its group was busy and it
        was parked. With ``propagate_errors`` the callback's exception reaches the caller."""
        fn, args, where, group = item
        group = group or self.default_group
        if group is None:
            with self.lock:
                self._call(fn, args, where)
            return True
        if not group.enter(self, item):
            return False
        try:
            if self.propagate_errors:   # rclpy's: the exception ends the spin (one call less per callback)
                fn(*args)
            else:
                self.run_callback(fn, *args, where=where)
        finally:
            group.leave()
        return True

    def _call(self, fn: Callable[..., None], args: tuple[Any, ...], where: str) -> None:
        if self.propagate_errors:
            fn(*args)
        else:
            self.run_callback(fn, *args, where=where)

    @property
    def idle(self) -> bool:
        return self.waiting.empty()

    def add_channel(self, channel: Any) -> None:
        self.channels = [*self.channels, channel]
        self.call_soon(_nothing, where="wake")   # a spinner waiting on another channel looks again

    def remove_channel(self, channel: Any) -> None:
        self.channels = [c for c in self.channels if c is not channel]

    # ---------------------------------------------------------------- timers
    def add_timer(self, timer: Timer) -> None:
        with self._timer_lock:
            if timer.sim_time:
                self._sim_timers.append(timer)
            else:
                heapq.heappush(self.wall_timers, (timer.next_due, next(self._timer_seq), timer))
        self.call_soon(_nothing, where="wake")   # so a waiting spin sees the new deadline

    def restart_sim_timers(self, now: float) -> None:
        """Sim time jumped back (a reset): every sim timer is next due one period from ``now``."""
        with self._timer_lock:
            for timer in self._sim_timers:
                timer.next_due = now + timer.period

    def run_sim_timers(self, now: float) -> None:
        with self._timer_lock:
            self._sim_timers = [t for t in self._sim_timers if not t.cancelled]
            due = [t for t in self._sim_timers if t.next_due <= now + 1e-12]
        for timer in due:
            timer.due_time = timer.next_due
            # Catch up without bursts: one call, next deadline after now.
            timer.next_due += timer.period * max(1, int((now - timer.next_due) // timer.period) + 1)
            self._call(timer.callback, (), "timer")

    def _next_wall_deadline(self) -> float | None:
        if not self.wall_timers:   # a peek without the lock: no timers at all
            return None
        with self._timer_lock:
            while self.wall_timers and self.wall_timers[0][2].cancelled:
                heapq.heappop(self.wall_timers)
            return self.wall_timers[0][0] if self.wall_timers else None

    def next_wall_deadline(self) -> float | None:
        return self._next_wall_deadline()

    def due_wall_timers(self) -> list[Timer]:
        """The wall timers due now, each moved to its next deadline (the caller runs them)."""
        now = time.monotonic()
        due: list[Timer] = []
        timers = self.wall_timers
        if not timers or timers[0][0] > now:   # a peek without the lock: the common case, nothing due
            return due
        with self._timer_lock:
            while self.wall_timers and self.wall_timers[0][0] <= now:
                _, _, timer = heapq.heappop(self.wall_timers)
                if timer.cancelled:
                    continue
                due.append(timer)
                timer.due_time = timer.next_due
                timer.next_due += timer.period
                if timer.next_due < now:  # fell behind: skip missed ticks instead of bursting
                    timer.next_due = now + timer.period
                heapq.heappush(self.wall_timers, (timer.next_due, next(self._timer_seq), timer))
        return due

    def _run_wall_timers(self) -> None:
        due = self.due_wall_timers()
        if due:
            with self.lock:
                for timer in due:
                    self.run_callback(timer.callback, where="timer")

    # ---------------------------------------------------------------- spinning
    def spin_once(self, timeout: float | None = None) -> bool:
        """Run due timers and at most one queued callback, waiting up to ``timeout`` s. True if work ran."""
        self._run_wall_timers()
        deadline = self._next_wall_deadline()
        wait = timeout
        if deadline is not None:
            until_timer = max(0.0, deadline - time.monotonic())
            wait = until_timer if wait is None else min(wait, until_timer)
        try:
            item = self.waiting.get(timeout=wait) if wait is None or wait > 0 else self.waiting.get_nowait()
        except queue.Empty:
            self.took()
            self._run_wall_timers()
            return False
        self.took()
        fn, args, where, group = item
        if group is None and self.default_group is None:
            with self.lock:
                self.run_callback(fn, *args, where=where)
            return True
        return self.run_item(item)

    def request_shutdown(self) -> None:
        self._stop.set()
        self.call_soon(_nothing, where="wake")

    def clear_shutdown(self) -> None:
        """Spin again after a ``request_shutdown`` (rclpy's spin_once after spin_until_future_complete)."""
        self._stop.clear()

    @property
    def shutdown_requested(self) -> bool:
        return self._stop.is_set()


def _nothing() -> None:
    return None
