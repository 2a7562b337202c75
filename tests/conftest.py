"""Shared fixtures: a free Zenoh port per test, an embedded router, and real node processes."""

from __future__ import annotations

import atexit
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import _zenroid_interfaces  # noqa: E402 - what zenroid-interfaces.pth does in an installed environment
from bench.common import child_env, free_port, spawn, stop_all  # noqa: E402 - the checkout is on the path now

_zenroid_interfaces.install()   # tests import ``sensor_msgs.msg`` as ROS programs do, this checkout's finder

# converted meshes go to a folder of this run, not the user's cache (child processes inherit it)
if "ZENROID_MESH_CACHE" not in os.environ:
    os.environ["ZENROID_MESH_CACHE"] = tempfile.mkdtemp(prefix="zenroid-mesh-cache-")
    atexit.register(shutil.rmtree, os.environ["ZENROID_MESH_CACHE"], True)

# A suite started in the background (`nohup python -m pytest &`, a CI step run that way) inherits SIGINT and
# SIGQUIT ignored, and every child would inherit that too: the Ctrl-C the tests send would then do nothing
# (a program may honour an inherited SIG_IGN, as POSIX background jobs expect). The children start as from a
# terminal instead.
for _signum, _handler in ((signal.SIGINT, signal.default_int_handler), (signal.SIGQUIT, signal.SIG_DFL)):
    if signal.getsignal(_signum) is signal.SIG_IGN:
        signal.signal(_signum, _handler)

__all__ = ["ROOT", "ProcessGroup", "free_port", "wait_until"]

# ------------------------------------------------------------------ the suite on every CPU (pytest-xdist)

#: Files started first, in this order (xdist hands each worker two at the start, alternately, then the next
#: file to whichever is free). The files with ``alone`` tests come first, beside files of quick unit tests, so
#: each gets the machine within a short test's time; then the longest files, each beside many short ones
#: instead of alone at the end (longest first). A stale list only balances the workers worse.
FIRST_FILES = ("test_viz_screenshot.py", "test_msgs_properties.py", "test_acl.py", "test_launch_supervisor.py",
               "test_hostile.py", "test_bag_files.py", "test_docs.py", "test_lockstep_main_job.py",
               "test_faults.py", "test_rclpy_compat.py", "test_your_robot.py", "test_cli_verbs.py")
#: More workers than this would start more simulated robots at once than the timing of a scenario test
#: (a robot must stand within its timeout) was written for.
MAX_WORKERS = 4


def _cgroup_cpu_limit() -> int | None:
    """The CPUs a cgroup v2 quota allows (``cpu.max``), None when there is none."""
    try:
        quota, period = Path("/sys/fs/cgroup/cpu.max").read_text().split()[:2]
    except (OSError, ValueError):
        return None
    return None if quota == "max" else max(1, int(quota) // int(period))


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """``-n auto`` (the default, pyproject.toml): a worker per CPU this process may use, whatever the machine
    has beyond its affinity or cgroup quota, at most MAX_WORKERS."""
    from nodes.core.cpu import allowed_cpus

    cpus = len(allowed_cpus())
    limit = _cgroup_cpu_limit()
    return max(1, min(cpus, limit or cpus, MAX_WORKERS))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    rank = {name: i for i, name in enumerate(FIRST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))   # stable: files stay whole, in order


@pytest.fixture(autouse=True)
def _share_the_machine(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Under xdist, a test marked ``alone`` waits until the other workers' tests end and keeps theirs waiting
    until it ends: what it is judged on (timing or memory under a realtime job) needs the CPUs to itself.
    Every other test shares the machine. A file lock in the run's temporary directory, which every worker
    sees; an ``alone`` test in the queue lets no new shared test start (no starving it)."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        yield
        return
    import fcntl

    run_dir = tmp_path_factory.getbasetemp().parent   # <basetemp>/popen-gwN: the parent is the run's
    alone = request.node.get_closest_marker("alone") is not None
    with open(run_dir / "machine.lock", "a") as machine, open(run_dir / "gate.lock", "a") as gate:
        fcntl.flock(gate, fcntl.LOCK_EX)
        if alone:
            fcntl.flock(machine, fcntl.LOCK_EX)   # holding the gate: no shared test starts meanwhile
            fcntl.flock(gate, fcntl.LOCK_UN)
        else:
            fcntl.flock(gate, fcntl.LOCK_UN)
            fcntl.flock(machine, fcntl.LOCK_SH)
        try:
            yield
        finally:
            fcntl.flock(machine, fcntl.LOCK_UN)


@pytest.fixture
def zenoh_port() -> int:
    """A fresh loopback port for this test's router (tests never share a Zenoh network)."""
    return free_port()


@pytest.fixture
def router(zenoh_port: int) -> Iterator[str]:
    """An embedded Zenoh router on loopback; yields the endpoint string nodes connect to."""
    from nodes.core.session import loopback_endpoint, open_router

    session = open_router(zenoh_port)
    try:
        yield loopback_endpoint(zenoh_port)
    finally:
        session.close()


@pytest.fixture
def session(router: str):
    """A peer session of the test itself (the 'external client' side), connected to the router."""
    from nodes.core.session import open_peer

    s = open_peer([router])
    try:
        yield s
    finally:
        s.close()


class ProcessGroup:
    """Starts real node processes in their own process groups and always reaps them."""

    def __init__(self, endpoint: str, log_dir: Path) -> None:
        self.endpoint = endpoint
        self.log_dir = log_dir
        self.procs: list[subprocess.Popen] = []

    def env(self, extra: dict[str, str] | None = None) -> dict[str, str]:
        return child_env({"ZENOH_CONNECT": self.endpoint, **(extra or {})})

    def start(self, *argv: str, name: str | None = None, env: dict[str, str] | None = None) -> subprocess.Popen:
        """Start ``python argv...`` (e.g. ``"-m", "nodes.sim"``); output goes to a log file."""
        label = name or argv[-1].replace("/", "_")
        log = self.log_dir / f"{label}-{len(self.procs)}.log"
        proc = spawn([sys.executable, *argv], log=log, env=self.env(env))
        proc.log_path = str(log)  # type: ignore[attr-defined]
        self.procs.append(proc)
        return proc

    def output(self, proc: subprocess.Popen) -> str:
        return Path(proc.log_path).read_text(errors="replace")  # type: ignore[attr-defined]

    def stop_all(self) -> None:
        stop_all(self.procs, timeout=5.0)


@pytest.fixture
def processes(router: str, tmp_path: Path) -> Iterator[ProcessGroup]:
    group = ProcessGroup(router, tmp_path)
    try:
        yield group
    finally:
        group.stop_all()


@pytest.fixture
def context(router, monkeypatch):
    """An rclpy context of this process on the test's router (no signal handlers: pytest keeps its own)."""
    import rclpy
    from rclpy.context import Context

    monkeypatch.setenv("ZENOH_CONNECT", router)
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        yield ctx
    finally:
        ctx.try_shutdown()


def wait_until(predicate, timeout: float = 10.0, interval: float = 0.02, message: str = "condition"):
    """Poll ``predicate`` until it returns a truthy value; fail the test with ``message`` on timeout."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    pytest.fail(f"timed out after {timeout:.1f} s waiting for {message}")
