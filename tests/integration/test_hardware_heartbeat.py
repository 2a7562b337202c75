"""A paused simulator is not a lost link: while paused it sends ``hardware/heartbeat``, and the controller
manager reports the hardware "paused" (no error); a simulator that is gone sends nothing, and the manager
reports it "lost" (an error). Real simulator and controller manager over Zenoh."""

from __future__ import annotations

import json
import os
import signal
import time

import pytest

import msgs
from nodes.core import Node
from tests.conftest import wait_until

pytestmark = pytest.mark.slow

Trigger = msgs.get_type("std_srvs/srv/Trigger")
Empty = msgs.get_type("std_srvs/srv/Empty")


def test_paused_simulator_reads_paused_and_a_killed_one_lost(processes, router):
    sim = processes.start("-m", "nodes.sim", "--params-file", "config/sim.yaml", "--param", "mode:=lockstep",
                          "--param", "entities:=[{name: humanoid, file: humanoid, z: 0.93}]", name="sim")
    manager = processes.start("-m", "nodes.control", "--ns", "humanoid", "--params-file", "config/controllers.yaml",
                              "--param", "activate:=[joint_state_broadcaster]", name="controller_manager")
    node = Node("heartbeat_test_client", connect=[router])

    def status() -> dict:
        reply = node.create_client(Trigger, "/humanoid/controller_manager/statistics").call(timeout=5.0)
        return json.loads(reply.message)

    def call_sim(name: str) -> None:
        node.create_client(Empty, f"/sim/{name}").call(Empty.Request(), timeout=10.0)

    try:
        wait_until(lambda: "controller manager ready" in processes.output(manager), timeout=90,
                   message="controller manager ready")
        wait_until(lambda: status()["cycles"] > 100, timeout=60, message="control cycles")
        assert status()["hardware"] == "ok"

        call_sim("pause_physics")
        time.sleep(3.0)   # three hardware_timeouts without a frame
        stats = status()
        assert stats["hardware"] == "paused", stats
        cycles = stats["cycles"]
        log = processes.output(manager)
        assert "hardware paused: the simulator is paused" in log and "lost the hardware" not in log, log[-3000:]

        call_sim("unpause_physics")
        wait_until(lambda: status()["cycles"] > cycles + 100, timeout=60, message="cycles after unpausing")
        assert status()["hardware"] == "ok"
        assert "hardware resumed (the simulator unpaused)" in processes.output(manager)

        os.killpg(sim.pid, signal.SIGKILL)    # gone without a word: no frames, no heartbeat
        sim.wait(10)
        wait_until(lambda: status()["hardware"] == "lost", timeout=20, message="the hardware reported lost")
        assert "lost the hardware: no hardware/state and no heartbeat" in processes.output(manager)
    finally:
        node.destroy()
