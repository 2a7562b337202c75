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
