"""Real-time scheduling for a node's threads: ros2_control's ``thread_priority``.

ros2_control's controller manager asks for ``SCHED_FIFO`` priority 50 for its control loop whatever the
kernel, and goes on at normal priority with a warning when the system refuses. Here the control loop is
carried by Zenoh's threads (network, hand-off to Python) and runs on them, so the whole process is
raised: every thread it has, and, through the threads that start others, every thread it starts later.
Only for a loop that sleeps between periods: a FIFO thread that stays busy starves every normal process
on its CPU.

Measured (``bench/control.py``, controller manager alone raised): a received trajectory reaches the
next control cycle more often (taken a period later: ~45 % -> ~30 %), and the command latency p50 falls
by ~0.1 ms. A woken FIFO thread runs at once instead of waiting for the scheduler to preempt whatever
holds the CPU.
"""

from __future__ import annotations

import os
from pathlib import Path

from nodes.core.cpu import thread_ids

MAX_PRIORITY = 99


def supported() -> bool:
    return hasattr(os, "SCHED_FIFO") and Path("/proc/self/task").is_dir()


def raise_process(priority: int) -> str | None:
    """Put every thread of this process, and every thread started from now on, at ``SCHED_FIFO``
    ``priority`` (1-99). Returns None when done, else why not (nothing is changed then)."""
    if not 1 <= priority <= MAX_PRIORITY:
        raise ValueError(f"priority must be within 1..{MAX_PRIORITY}, got {priority}")
    if not supported():
        return "SCHED_FIFO is not available on this system"
    param = os.sched_param(priority)
    try:
        # The calling thread first: it decides whether we may. Threads inherit their creator's policy.
        os.sched_setscheduler(0, os.SCHED_FIFO, param)
    except OSError as exc:
        return f"{exc.strerror or exc} (needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least {priority})"
    for tid in thread_ids():
        try:
            os.sched_setscheduler(tid, os.SCHED_FIFO, param)
        except ProcessLookupError:
            continue   # the thread ended meanwhile
    return None


def policy_of(tid: int) -> tuple[str, int]:
    """``("fifo", priority)``, ``("other", 0)``, ...: how the kernel schedules thread ``tid`` (any process)."""
    names = {getattr(os, name): name[6:].lower() for name in dir(os) if name.startswith("SCHED_")
             and name not in ("SCHED_RESET_ON_FORK",) and isinstance(getattr(os, name), int)}
    policy = os.sched_getscheduler(tid)
    return names.get(policy, str(policy)), os.sched_getparam(tid).sched_priority
