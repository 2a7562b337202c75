"""Per-stream rate limits: drop, never queue, so a slow viewer can never build up lag."""

from __future__ import annotations

import time


class RateLimiter:
    """``ready()`` is True at most ``max_hz`` times per second of the monotonic clock (0 = unlimited)."""

    def __init__(self, max_hz: float, clock=time.monotonic) -> None:
        self.period = 1.0 / max_hz if max_hz > 0 else 0.0
        self.clock = clock
        self.next_allowed = float("-inf")

    def ready(self) -> bool:
        now = self.clock()
        if now < self.next_allowed:
            return False
        # Schedule from the previous slot (not from now) so the average rate is exact; resync after a gap.
        late = now - self.next_allowed
        self.next_allowed = now + self.period if late > self.period else self.next_allowed + self.period
        return True
