"""Pacing and the lockstep inbox, with a fake clock (no real sleeping, no timing asserts)."""

from __future__ import annotations

import pytest

from msgs import time_map
from nodes.sim import stepping
from nodes.sim.robot_link import Command
from nodes.sim.stepping import CommandInbox, Pacer


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0
        self.idles: list[float] = []

    def perf_counter(self) -> float:
        self.now += 1e-6          # reading the clock takes a little time, so spinning ends
        return self.now

    def idle(self, wait: float) -> None:
        self.idles.append(wait)
        self.now += wait


@pytest.fixture
def clock(monkeypatch):
    fake = FakeClock()
    monkeypatch.setattr(stepping, "wall_clock", fake.perf_counter)
    return fake


def test_pacer_keeps_sim_time_on_the_wall_clock(clock):
    pacer = Pacer(1.0)
    assert pacer.wait_until_due(5.0, clock.idle) == 0.0          # first call sets the origin
    assert pacer.wait_until_due(5.010, clock.idle) == 0.0
    assert clock.now == pytest.approx(100.010, abs=stepping.SPIN_WINDOW_S + 1e-9)
    clock.now = 100.030                                           # a slow step: 10 ms late for t = 5.020
    assert pacer.wait_until_due(5.020, clock.idle) == pytest.approx(0.010, abs=1e-5)
    clock.now += 1.0                                              # far behind: the grid restarts, no burst
    assert pacer.wait_until_due(5.030, clock.idle) > stepping.MAX_CATCH_UP_S
    idles = len(clock.idles)
    assert pacer.wait_until_due(5.030, clock.idle) < 1e-5 and len(clock.idles) == idles   # on the new grid


def test_pacer_real_time_factor_scales_waits(clock):
    pacer = Pacer(2.0)
    pacer.wait_until_due(0.0, clock.idle)
    start = clock.now
    pacer.wait_until_due(1.0, clock.idle)                          # 1 sim second at 2x = 0.5 wall seconds
    assert clock.now - start == pytest.approx(0.5, abs=stepping.SPIN_WINDOW_S + 1e-9)


def command(step: int) -> Command:
    return Command(step=step, update_rate=1000, name=[], interface=[], value=[])


def test_inbox_keeps_commands_by_step():
    inbox = CommandInbox()
    inbox.put(command(4))
    assert inbox.take_step(5) is None                              # an answer to another step does not count
    inbox.put(command(5))
    assert inbox.take_step(5).step == 5
    assert inbox.take() is None                                    # consumed, and the older 4 with it
    inbox.put(command(6))
    inbox.put(command(7))
    assert inbox.take().step == 7                                  # realtime: the newest wins
    inbox.put(command(8))
    inbox.clear()
    assert inbox.take() is None


def test_time_map_splits_seconds_exactly():
    assert time_map(1.5) == {"sec": 1, "nanosec": 500_000_000}
    assert time_map(0.0) == {"sec": 0, "nanosec": 0}
    assert time_map(2.9999999999) == {"sec": 3, "nanosec": 0}
