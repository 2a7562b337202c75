"""Shared helpers of the simulator integration tests (no tests here): start the simulator process, call
its services, and drive it as the controller manager would, from this (separate) test process."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import msgpack
import pytest

from nodes.core import Node
from nodes.core.delivery import Inline, Raw
from nodes.sim.interfaces import GetPhysicsProperties
from tests.support.hardware_client import HardwareClient

ROOT = Path(__file__).resolve().parents[2]
HUMANOID_ENTITY = "entities:=[{name: humanoid, file: humanoid, z: 0.915}]"


def start_sim(processes, *params: str, name: str = "sim") -> subprocess.Popen:
    argv = ["-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml")]
    for param in params:
        argv += ["--param", param]
    return processes.start(*argv, name=name)


def call(node: Node, srv_type: Any, key: str, request: Any = None, timeout: float = 10.0) -> Any:
    return node.create_client(srv_type, key).call(request, timeout=timeout)


def wait_ready(node: Node, processes, proc, timeout: float = 60.0) -> Any:
    """Wait until the simulator answers get_physics_properties (fail with its log if it died)."""
    deadline = time.monotonic() + timeout
    last_error = ""
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"simulator exited with {proc.returncode}:\n{processes.output(proc)}")
        try:
            return call(node, GetPhysicsProperties, "/sim/get_physics_properties", timeout=2.0)
        except Exception as exc:  # noqa: BLE001 - not up yet
            last_error = str(exc)
            time.sleep(0.2)
    pytest.fail(f"simulator not ready after {timeout} s ({last_error}):\n{processes.output(proc)}")


def run_cli(processes, *argv: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nodes.tools.cli", *argv], env=processes.env(), cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout)


class ModelStatesProbe:
    """The latest sim/model_states as {name: (x, y, z, qx, qy, qz, qw)}."""

    def __init__(self, node: Node) -> None:
        self.latest: dict[str, tuple[float, ...]] = {}
        self.count = 0
        self._lock = threading.Lock()
        from nodes.sim.interfaces import ModelStates

        node.create_subscription(ModelStates, "/sim/model_states", self._on_msg,
                                 delivery=Inline(), message=Raw())

    def _on_msg(self, payload: bytes) -> None:
        msg = msgpack.unpackb(payload, raw=False)
        table = {}
        for name, pose in zip(msg["name"], msg["pose"], strict=True):
            p, q = pose["position"], pose["orientation"]
            table[name] = (p["x"], p["y"], p["z"], q["x"], q["y"], q["z"], q["w"])
        with self._lock:
            self.latest = table
            self.count += 1

    def get(self) -> dict[str, tuple[float, ...]]:
        with self._lock:
            return dict(self.latest)


def connect_controller(node: Node, namespace: str, policy=None, record: bool = False) -> HardwareClient:
    """A lockstep partner answering every hardware/state of ``namespace`` (the test is the controller)."""
    return HardwareClient(node, namespace, policy=policy, record=record)


def sim_time_of(state: dict) -> float:
    return state["stamp"]["sec"] + state["stamp"]["nanosec"] * 1e-9
