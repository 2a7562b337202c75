"""A node's clock: the wall clock, or sim time from ``sim/clock`` when ``use_sim_time`` is set."""

from __future__ import annotations

import time
from typing import Any

import msgs
from nodes.core.executor import Executor
from nodes.core.log import Logger


class NodeClock:
    def __init__(self, use_sim_time: bool, executor: Executor, logger: Logger) -> None:
        self.use_sim_time = use_sim_time
        self.sim_now = 0.0
        self._executor = executor
        self._logger = logger

    def on_clock(self, msg: Any) -> None:
        """A rosgraph_msgs/Clock message (subscribed inline, on Zenoh's thread)."""
        t = msgs.time_to_sec(msg.clock)
        if t < self.sim_now - 1e-9:
            self._logger.info(f"sim time jumped back from {self.sim_now:.3f} to {t:.3f} s (reset): timers restart")
            self._executor.restart_sim_timers(t)
        self.sim_now = t
        # each clock message checks the sim timers at its own time, on the spinning thread
        self._executor.call_soon(self._executor.run_sim_timers, t, where="sim timers")

    def now(self) -> float:
        """Seconds: sim time when ``use_sim_time`` (0 before the first clock message), else wall."""
        return self.sim_now if self.use_sim_time else time.time()

    def stamp(self, wall: float) -> Any:
        """builtin_interfaces/Time for an event at wall time ``wall`` (a log line), on this clock."""
        return msgs.time_from_sec(self.sim_now if self.use_sim_time else wall)
