"""``Spinner``: several nodes' executors spun together, by one thread or by several (rclpy's executors).

Each executor it serves wakes it when work is queued (``Executor.wake``); one ``spin_once`` runs the due
timers of every executor and then at most one queued callback, taking the executors in turn so that a busy
node cannot starve a quiet one. Callbacks run under their callback group (``executor.CallbackGroup``):
several threads may call ``spin_once`` at once and an exclusive group still runs one callback at a time.
A single-threaded spinner whose only waitable is one ``delivery.Spun`` subscription (no timer, no timeout)
receives from that subscription's Zenoh ring itself instead of waiting for a token.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from typing import Any

from nodes.core.executor import Executor


class Spinner:
    """``single_thread``: only one thread ever spins it (rclpy's ``SingleThreadedExecutor``), which may then
    receive a lone subscription's messages from Zenoh's ring itself (``delivery.Spun``)."""

    def __init__(self, *, single_thread: bool = False) -> None:
        self.single_thread = single_thread
        self._executors: list[Executor] = []
        self._lock = threading.Lock()
        # wake-ups: a token in a C queue (a threading.Event costs a Python-level Condition per message);
        # at most one token waits at a time
        self._tokens: queue.SimpleQueue = queue.SimpleQueue()
        self._pending = False
        self._turn = 0
        # the channel (delivery.Spun) the only spinning thread receives from itself, while it waits there
        self._receiving_on: Any = None

    @property
    def executors(self) -> list[Executor]:
        return list(self._executors)

    def add(self, executor: Executor) -> None:
        with self._lock:   # a new list each time: spinning threads read it without the lock
            if executor not in self._executors:
                self._executors = [*self._executors, executor]
        executor.wake = self.wake
        self.wake()

    def remove(self, executor: Executor) -> None:
        with self._lock:
            if executor in self._executors:
                self._executors = [e for e in self._executors if e is not executor]
        if executor.wake == self.wake:
            executor.wake = None
        self.wake()   # a spinning thread may be receiving on one of its channels

    def wake(self) -> None:
        if not self._pending:
            self._pending = True
            # set before _receiving_on is read: the spinning thread sets _receiving_on before it reads
            # _pending, so one of the two sees the other and the wake-up is never lost
            channel = self._receiving_on
            if channel is not None:
                channel.interrupt()
            else:
                self._tokens.put(None)

    def spin_once(self, timeout: float | None = None, stop: Callable[[], bool] | None = None) -> bool:
        """Run due timers and at most one queued callback, waiting up to ``timeout`` s (None: until there is
        work) or until ``stop()`` is true after a ``wake()``. True if a callback ran."""
        end = None if timeout is None else time.monotonic() + max(0.0, timeout)
        tokens = self._tokens
        while True:
            self._pending = False   # before looking: a wake-up after the look is not lost
            if self._run_one():
                return True
            if stop is not None and stop():
                return False
            wait = None if end is None else end - time.monotonic()
            deadline = self._next_deadline()
            if deadline is not None:
                until = max(0.0, deadline - time.monotonic())
                wait = until if wait is None else min(wait, until)
            if wait is not None and wait <= 0:
                if end is not None and time.monotonic() >= end:
                    return self._run_one()
                continue
            channels = [c for e in self._executors for c in e.channels]
            if wait is None and len(channels) == 1 and self.single_thread and channels[0].hold():
                while not tokens.empty():   # meant for a wait on tokens; this wait reads _pending instead
                    tokens.get_nowait()
                ran = channels[0].wait_held(self._receive_on)
                if ran is not None:
                    return ran
                continue
            for channel in channels:   # something else to wait for as well: their messages come queued
                channel.start_pump()
            try:
                tokens.get(timeout=wait)
            except queue.Empty:
                pass
            if end is not None and time.monotonic() >= end:
                return self._run_one()

    def _receive_on(self, channel: Any) -> bool:
        """The spinning thread is about to receive on ``channel`` (None: it has received): True if a wake-up
        came before."""
        self._receiving_on = channel
        return self._pending

    def _next_deadline(self) -> float | None:
        # a peek at each heap first: most executors have no wall timers (the common rclpy subscriber)
        deadlines = [d for e in self._executors if e.wall_timers and (d := e.next_wall_deadline()) is not None]
        return min(deadlines) if deadlines else None

    def _run_one(self) -> bool:
        # the hot path of every message an rclpy node takes: the executors' queues and timer heaps are
        # peeked here rather than through a call each; an empty queue is tested before get_nowait, which is
        # cheaper than the exception it raises
        executors = self._executors
        ran = False
        now = time.monotonic()
        for executor in executors:
            timers = executor.wall_timers
            if timers and timers[0][0] <= now:
                for timer in executor.due_wall_timers():
                    ran = executor.run_item((timer.callback, (), "timer", timer.group)) or ran
        count = len(executors)
        turn = self._turn
        for i in range(count):
            executor = executors[(turn + i) % count] if count > 1 else executors[0]
            waiting = executor.waiting
            while True:
                executor.took()
                if waiting.empty():
                    break
                try:
                    item = waiting.get_nowait()
                except queue.Empty:
                    break
                if not waiting.empty():
                    self.wake()   # more is queued: another spinning thread may take it meanwhile
                if executor.run_item(item):
                    self._turn = (turn + i + 1) % count
                    return True
                # its group was busy: parked until the group's running callback ends
            for channel in executor.channels:   # messages still in Zenoh's ring (no pump takes them)
                took = channel.take_one()
                if took:
                    self._turn = (turn + i + 1) % count
                    return True
        return ran
