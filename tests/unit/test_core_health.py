"""What a node tells the launcher's `_alive` probe: how long its executor has left queued work untaken."""

from __future__ import annotations

import time

from nodes.core.executor import Executor


def test_an_executor_is_stalled_only_while_queued_work_waits_untaken() -> None:
    """The `_alive` probe's figure: 0 for an executor never spun, idle, or taking work; growing while work
    waits and no spinner takes it."""
    executor = Executor(lambda _: None, on_spin_thread=True)
    executor.mark()
    assert executor.stalled_for() == 0.0          # never spun: not watched for progress
    assert executor.spin_once(0.0)                # takes the mark
    assert executor.stalled_for() == 0.0          # nothing waiting
    executor.mark()
    time.sleep(0.2)
    assert executor.stalled_for() >= 0.2          # waiting, and no spinner took it (nor computed)
    time.sleep(0.2)
    assert executor.stalled_for() >= 0.4
    executor.spin_once(0.0)
    assert executor.stalled_for() == 0.0


def test_a_spinner_busy_computing_in_a_long_callback_is_not_stalled() -> None:
    import threading

    executor = Executor(lambda _: None, on_spin_thread=True)
    done = threading.Event()

    def compute() -> None:
        end = time.monotonic() + 3.0
        while time.monotonic() < end:
            sum(range(1000))
        done.set()

    executor.call_soon(compute)
    spinner = threading.Thread(target=executor.spin_once, args=(0.0,))
    spinner.start()
    time.sleep(0.05)
    executor.mark()
    executor.stalled_for()   # the probe before: its CPU time then
    seen = []
    while not done.is_set() and len(seen) < 8:   # probes a third of a second apart, as a loaded machine allows
        time.sleep(0.33)
        seen.append(executor.stalled_for())
    assert min(seen) < 0.1, seen              # it computes: a long callback, not a blocked one
    spinner.join()
    assert done.is_set()
