"""How simulated time advances: wall-clock pacing and the lockstep hand-off with controller managers.

``Pacer`` keeps sim time on the wall clock at a real-time factor. ``CommandInbox`` is where a robot's
``hardware/command`` messages land once the physics thread has taken them from Zenoh, and tracks whether a
controller manager is connected (lockstep waits for it) or gone (hold position).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

# Give up pacing catch-up after falling this far behind (a pause, a hiccup): restart the origin instead
# of running a burst of steps with no sleep.
MAX_CATCH_UP_S = 0.25
# Sleep until this close to the deadline, then spin: precise enough for sub-ms lateness while keeping
# the CPU a free-running simulator burns low on a shared machine.
SPIN_WINDOW_S = 0.0001

wall_clock = time.perf_counter   # the pacing clock (tests substitute a fake one)


class Pacer:
    """Maps sim time to wall time: sim time t is due at ``origin_wall + (t - origin_sim) / rtf``."""

    def __init__(self, real_time_factor: float = 1.0) -> None:
        self.real_time_factor = real_time_factor
        self._origin_wall: float | None = None
        self._origin_sim = 0.0

    def restart(self) -> None:
        self._origin_wall = None

    def wait_until_due(self, sim_time: float, idle: Callable[[float], None] | None = None) -> float:
        """Block until ``sim_time`` is due; returns how late (s) we are, 0 if on time.

        ``idle(max_wait_s)`` is called while there is more than the spin window left (the node processes
        service requests there); the last fraction of a millisecond is spun for precision.
        """
        now = wall_clock()
        if self._origin_wall is None or self.real_time_factor <= 0:
            self._origin_wall, self._origin_sim = now, sim_time
            return 0.0
        due = self._origin_wall + (sim_time - self._origin_sim) / self.real_time_factor
        late = now - due
        if late > MAX_CATCH_UP_S:
            self._origin_wall, self._origin_sim = now, sim_time
            return late
        while True:
            remaining = due - wall_clock()
            if remaining <= 0:
                break
            if remaining > SPIN_WINDOW_S:
                wait = remaining - SPIN_WINDOW_S
                if idle is not None:
                    idle(wait)
                else:
                    time.sleep(wait)
        return max(0.0, late)


class CommandInbox:
    """The recent ``hardware/command`` messages of one robot and its controller manager's connection state.

    Pipelined lockstep waits for the answer to the *previous* state while the answer to the newest one may
    already be in, so the last few commands are kept by step. Only the physics thread touches it: the
    commands are pulled from Zenoh's buffer on that thread (``RobotLink``).
    """

    KEEP = 8

    def __init__(self) -> None:
        self._by_step: dict[int, Any] = {}   # insertion order = arrival order
        self.connected = False           # set by the physics thread when a command is taken
        self.last_wall = 0.0              # monotonic time of the last command received

    def put(self, command: Any) -> None:
        self._by_step.pop(command.step, None)
        self._by_step[command.step] = command
        if len(self._by_step) > self.KEEP:
            del self._by_step[next(iter(self._by_step))]
        self.last_wall = time.monotonic()

    def take(self) -> Any:
        """The newest unread command, or None (realtime: whatever arrived last wins)."""
        if not self._by_step:
            return None
        newest = self._by_step[next(reversed(self._by_step))]
        self._by_step.clear()
        return newest

    def take_step(self, step: int) -> Any:
        """The command answering ``step`` (lockstep), or None; older ones are dropped with it."""
        command = self._by_step.pop(step, None)
        if command is not None:
            for older in [s for s in self._by_step if s < step]:
                del self._by_step[older]
        return command

    def clear(self) -> None:
        self._by_step.clear()
