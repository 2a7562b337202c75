"""A CPU of its own for one busy thread (the simulator's stepping loop in lockstep).

On a machine with few cores, a lockstep simulation's stepping thread spent about a quarter of its time
waiting for a CPU: every Zenoh frame wakes a thread somewhere (the simulator's own I/O threads, the
controller manager's), and the scheduler put them on the CPU that was stepping the physics. Keeping that
one CPU for the stepping thread alone, and every other thread of the launch on the remaining CPUs, made
the main job's lockstep about 1.4x faster on 2 cores (docs/performance.md). ros2_control's controller manager offers the same idea
as its ``cpu_affinity`` parameter.

The launcher chooses the CPU (the last one it may use), starts every process on the others and tells
the one node through ``ZENROID_EXCLUSIVE_CPU``; that node's stepping thread calls ``claim``. Linux only:
elsewhere, or with a single CPU, nothing is pinned.
"""

from __future__ import annotations

import os
from pathlib import Path

EXCLUSIVE_CPU_ENV = "ZENROID_EXCLUSIVE_CPU"


def supported() -> bool:
    return hasattr(os, "sched_setaffinity") and Path("/proc/self/task").is_dir()


def allowed_cpus() -> set[int]:
    """The CPUs this process may run on (its affinity, which honours cgroup and taskset limits)."""
    return set(os.sched_getaffinity(0)) if supported() else set(range(os.cpu_count() or 1))


def choose_exclusive(cpus: set[int]) -> int | None:
    """The CPU to reserve out of ``cpus`` (the highest), or None when fewer than two are available."""
    return max(cpus) if len(cpus) >= 2 else None


_reservation: object | None = None   # the open lock file while this process holds the reservation


def hold_reservation() -> bool:
    """Take this machine's (per user) CPU reservation for the rest of the process; False if another
    process holds it. The lock goes with the process, however it ends."""
    global _reservation
    if _reservation is not None:
        return True
    import fcntl
    import tempfile

    path = Path(tempfile.gettempdir()) / f"zenroid-exclusive-cpu-{os.getuid()}.lock"
    try:
        handle = open(path, "a")  # noqa: SIM115 - held open on purpose until the process ends
    except OSError:
        return False   # no writable temporary directory: no reservation, no pinning
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        return False
    _reservation = handle
    return True


def thread_ids(pid: int | str = "self") -> list[int]:
    """The threads (Linux task ids) of process ``pid``, this one by default."""
    return sorted(int(entry.name) for entry in Path(f"/proc/{pid}/task").iterdir() if entry.name.isdigit())


def move_threads(cpus: set[int], *, keep: int | None = None) -> None:
    """Every thread of this process except ``keep`` (a native thread id) onto ``cpus``."""
    for tid in thread_ids():
        if tid != keep:
            try:
                os.sched_setaffinity(tid, cpus)
            except OSError:   # the thread ended meanwhile
                pass


class ExclusiveCpu:
    """The stepping thread's side: ``claim`` from that thread, ``sweep`` now and then from it.

    Threads started after the claim by the claiming thread inherit its CPU (Zenoh opens some lazily), so
    ``sweep`` moves every other thread back to the rest of the CPUs."""

    def __init__(self, cpu: int) -> None:
        self.cpu = cpu
        self.rest = allowed_cpus() - {cpu} or {cpu}
        self.thread_id: int | None = None

    @classmethod
    def from_environment(cls) -> ExclusiveCpu | None:
        text = os.environ.get(EXCLUSIVE_CPU_ENV, "").strip()
        if not text or not supported():
            return None
        try:
            cpu = int(text)
        except ValueError:
            raise ValueError(f"{EXCLUSIVE_CPU_ENV} must be a CPU number, got {text!r}") from None
        if cpu < 0 or cpu >= (os.cpu_count() or 1):
            raise ValueError(f"{EXCLUSIVE_CPU_ENV}={cpu}: this machine has CPUs 0..{(os.cpu_count() or 1) - 1}")
        return cls(cpu)

    def claim(self) -> None:
        """Pin the calling thread to the CPU and every other thread of the process off it."""
        import threading

        self.thread_id = threading.get_native_id()
        os.sched_setaffinity(0, {self.cpu})   # 0: the calling thread
        self.sweep()

    def sweep(self) -> None:
        move_threads(self.rest, keep=self.thread_id)
