"""Shared fixtures: a free Zenoh port per test, an embedded router, and real node processes."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


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
        env = dict(os.environ)
        env["ZENOH_CONNECT"] = self.endpoint
        env.pop("ZENOH_CONFIG", None)
        env["PYTHONUNBUFFERED"] = "1"
        env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
        env.update(extra or {})
        return env

    def start(self, *argv: str, name: str | None = None, env: dict[str, str] | None = None) -> subprocess.Popen:
        """Start ``python argv...`` (e.g. ``"-m", "nodes.sim"``); output goes to a log file."""
        label = name or argv[-1].replace("/", "_")
        log = open(self.log_dir / f"{label}-{len(self.procs)}.log", "wb")
        proc = subprocess.Popen(
            [sys.executable, *argv], stdout=log, stderr=subprocess.STDOUT, env=self.env(env),
            cwd=ROOT, start_new_session=True,
        )
        proc.log_path = log.name  # type: ignore[attr-defined]
        self.procs.append(proc)
        return proc

    def output(self, proc: subprocess.Popen) -> str:
        return Path(proc.log_path).read_text(errors="replace")  # type: ignore[attr-defined]

    def stop_all(self) -> None:
        for proc in self.procs:
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGINT)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + 5
        for proc in self.procs:
            try:
                proc.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                proc.wait()


@pytest.fixture
def processes(router: str, tmp_path: Path) -> Iterator[ProcessGroup]:
    group = ProcessGroup(router, tmp_path)
    try:
        yield group
    finally:
        group.stop_all()


def wait_until(predicate, timeout: float = 10.0, interval: float = 0.02, message: str = "condition"):
    """Poll ``predicate`` until it returns a truthy value; fail the test with ``message`` on timeout."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    pytest.fail(f"timed out after {timeout:.1f} s waiting for {message}")
