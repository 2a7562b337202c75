"""Rendered sensors read a frame at a time: subscribed for one frame every period, not all the time.

The renderer, like gazebo_ros' lazy camera and ray plugins, draws a stream only while someone subscribes to
it. A viewer that stayed subscribed to the head camera would make it cast the camera at its 30 Hz (measured
on the 2-core machine: ~35-40 % of a core for the camera alone, lidar 7 %, laser 3 %; with that the served
page fell minutes behind even when the viewer drew none of it) for the 2 frames a second the page is sent.
So a ``FramePull`` subscribes when a frame is due, takes the first complete frame (every ``part``: the
colour and the depth image of a camera, each lidar and laser of a robot), hands it to ``on_frame`` and
unsubscribes: the renderer draws a few frames per pull instead of all of them.

The price: each pull declares and undeclares its subscriptions (about 1.5 ms; ``zenroid topic list`` and a
ROS 2 graph see them come and go). ``continuous=True`` keeps them (``sensor_pull:=false``): every frame
arrives, and ``on_frame`` runs at most once a period.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Any

from .ratelimit import RateLimiter

PATIENCE = 1.0  # s a pull waits for the rest of a frame once part of it came, then draws what it has


class FramePull:
    """One sensor group's subscriptions, open for a frame every ``period`` s (see the module docstring).

    ``open_subscriptions()`` declares them and returns them; ``arrived(part)`` is called by their callbacks
    (under the caller's lock) and close the pull as soon as its frame is complete; ``tick()`` by a timer
    (also under it) opens the next one when it is due, and closes one whose frame came only in part after
    ``PATIENCE``. A pull with nothing yet stays open: no churn while the renderer is not running."""

    def __init__(self, parts: Iterable[str], open_subscriptions: Callable[[], list[Any]],
                 on_frame: Callable[[], None], period: float, continuous: bool = False, ordered: bool = False,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.order = list(parts)
        self.parts = frozenset(self.order)
        # ordered: the parts of one frame come in this order (a camera's colour image, then its depth image),
        # so the last part completes a frame only after the others came since the last one did.
        self.ordered = ordered
        self.open_subscriptions = open_subscriptions
        self.on_frame = on_frame
        self.period = period
        self.continuous = continuous
        self.clock = clock
        self.limiter = RateLimiter(1.0 / period, clock=clock)
        self.subscriptions: list[Any] = []
        self.seen: set[str] = set()
        self.done = False
        self.opened = 0.0
        self.next_open = float("-inf")
        self.frames = 0  # frames handed to on_frame
        self.pulls = 0  # times the subscriptions were opened

    def arrived(self, part: str) -> None:
        if not self.subscriptions:
            return  # a message that was on its way when the pull closed
        if self.continuous:
            if self.limiter.ready():
                self._frame()
            return
        if self.ordered and part == self.order[-1] and not self.seen >= self.parts - {part}:
            self.seen = set()  # the end of a frame whose beginning came before we subscribed
            return
        self.seen.add(part)
        if not self.done and self.seen >= self.parts:
            self.done = True
            self._frame()
            self.close()  # at once, from the callback (Zenoh allows it): every ms open is frames drawn for nobody

    def tick(self) -> None:
        now = self.clock()
        if self.subscriptions and not self.continuous:
            if not self.done and self.seen and now - self.opened > PATIENCE:
                self.done = True  # part of the sensors came: draw those, not nothing
                self._frame()
            if self.done:
                self.close()
        if not self.subscriptions and now >= self.next_open:
            self.subscriptions = list(self.open_subscriptions())
            self.seen, self.done, self.opened = set(), False, now
            self.next_open = now + self.period
            self.pulls += 1

    def close(self) -> None:
        subscriptions, self.subscriptions = self.subscriptions, []
        for subscription in subscriptions:
            subscription.destroy()

    def _frame(self) -> None:
        self.frames += 1
        self.on_frame()
