"""Composable nodes (``humanoid.yaml composed:=true``): the simulator and the controller manager in one container
process, handing the hardware frames to each other in-process, and still two nodes on Zenoh.

- in lockstep, two composed runs started paused and unpaused once the controllers are active give bit-identical
  joint_states, and the same joint_states as the separate processes for the same input (a knee bend);
- ``zenroid node list`` shows both nodes of the container (and the container itself); ``kill -9`` of the
  container process respawns both: they come back on the graph and joint_states flow again.

Watched by a client that imports only zenoh and msgpack, on a free loopback port per run.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import msgpack
import pytest
import zenoh

from bench.common import ROOT, Launch, free_port
from tests.integration.test_lockstep_main_job import call, client_session

RECORD_UNTIL = 2.0   # sim s: the knee bend below starts at 0.5 s and takes 1 s
# The input, sent while physics is paused and stamped to start at 0.5 s of sim time: it starts at the same step
# in every run however late it arrives (the joint commander's own stamps leave 0.2 s of sim time, 60 ms of wall
# time composed, which a loaded machine can miss).
KNEE_BEND = {"header": {"stamp": {"sec": 0, "nanosec": 500_000_000}},
             "joint_names": ["left_hip_pitch", "left_knee", "left_ankle_pitch", "right_hip_pitch", "right_knee",
                             "right_ankle_pitch"],
             "points": [{"positions": [-0.2, 0.4, -0.2, -0.2, 0.4, -0.2], "time_from_start": {"sec": 1, "nanosec": 0}}]}
ACTIVE = ("joint_state_broadcaster", "joint_trajectory_controller")
# the smallest main job: no rendered sensors (their broadcasters then fail to configure: expected), the bare ground
QUICK = ("sensors:=false", "world:=empty.world")


def controllers_active(session: zenoh.Session) -> bool:
    listed = call(session, "humanoid/controller_manager/list_controllers", {}, timeout=1.0)
    states = {c["name"]: c["state"] for c in (listed or {}).get("controller", [])}
    return all(states.get(name) == "active" for name in ACTIVE)


def lockstep_joint_states(log_dir: Path, *args: str) -> dict[tuple[int, int], list[float]]:
    """Positions by stamp up to RECORD_UNTIL of the main job in lockstep, started paused and unpaused once every
    controller is active and the knee bend has been sent."""
    launch = Launch("humanoid.yaml", "mode:=lockstep", "paused:=true", "commander:=none", *QUICK, *args,
                    log_dir=log_dir, port=free_port())
    session = None
    try:
        launch.wait_output(Launch.ROUTER_UP, 60)
        session = client_session(launch.port)
        joint_states = session.declare_subscriber("humanoid/joint_states", zenoh.handlers.FifoChannel(100_000))
        launch.wait(lambda: controllers_active(session), 60, "the controllers active")
        session.put("humanoid/joint_trajectory_controller/joint_trajectory", msgpack.packb(KNEE_BEND))
        time.sleep(0.5)   # taken by the controller in the first cycle after the unpause
        assert call(session, "sim/unpause_physics", {}) is not None
        positions: dict[tuple[int, int], list[float]] = {}
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            msg = msgpack.unpackb(joint_states.recv().payload.to_bytes())
            stamp = msg["header"]["stamp"]
            positions[(stamp["sec"], stamp["nanosec"])] = msg["position"]
            if stamp["sec"] + stamp["nanosec"] * 1e-9 >= RECORD_UNTIL:
                break
        joint_states.undeclare()
        return positions
    finally:
        if session is not None:
            session.close()
        launch.close()


@pytest.mark.slow
def test_composed_lockstep_is_bit_identical_and_equals_separate_processes(tmp_path: Path) -> None:
    runs = {}
    for label, args in (("composed a", ("composed:=true",)), ("composed b", ("composed:=true",)),
                        ("separate", ())):
        (tmp_path / label).mkdir()
        runs[label] = lockstep_joint_states(tmp_path / label, *args)
    first, second, separate = runs["composed a"], runs["composed b"], runs["separate"]
    assert len(first) >= RECORD_UNTIL * 1000 * 0.99, f"{len(first)} joint_states"   # 1 kHz, every one delivered
    common = sorted(set(first) & set(second) & set(separate))
    assert len(common) >= 0.99 * len(first)
    assert [first[t] for t in common] == [second[t] for t in common], "two composed runs differ"
    assert [first[t] for t in common] == [separate[t] for t in common], "composed and separate runs differ"
    # the knees bent (the trajectory was followed), so the equality means something
    start, end = first[common[0]], first[common[-1]]
    assert max(abs(a - b) for a, b in zip(start, end, strict=True)) > 0.05


def node_list(port: int) -> list[str]:
    result = subprocess.run([sys.executable, "-m", "nodes.tools.cli", "node", "list", "--zenoh-port", str(port)],
                            capture_output=True, text=True, timeout=30, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    return result.stdout.split()


@pytest.mark.slow
def test_node_list_shows_both_composed_nodes_and_kill_9_of_the_container_respawns_both(tmp_path: Path) -> None:
    both = {"/simulator", "/humanoid/controller_manager"}
    with Launch("humanoid.yaml", "composed:=true", "commander:=none", *QUICK, log_dir=tmp_path,
                port=free_port()) as launch:
        session = client_session_after(launch)
        launch.wait(lambda: controllers_active(session), 60, "the controllers active")
        listed = node_list(launch.port)
        assert both | {"/simulation"} <= set(listed), listed
        assert launch.node_pids("simulator") == [] and launch.node_pids("controller_manager") == []
        (container,) = launch.node_pids("simulation")   # one process holds both

        os.kill(container, signal.SIGKILL)
        killed = time.monotonic()
        launch.wait(lambda: len(launch.node_pids("simulation")) >= 2, 30, "the container respawned")
        launch.wait(lambda: both <= set(node_list(launch.port)), 30, "both nodes back on the graph")
        launch.wait(lambda: controllers_active(session), 30, "the controllers active again")
        joint_states = session.declare_subscriber("humanoid/joint_states", zenoh.handlers.FifoChannel(1000))
        sample = joint_states.recv()
        assert msgpack.unpackb(sample.payload.to_bytes())["name"], "joint_states flow again"
        assert time.monotonic() - killed < 60
        session.close()


def client_session_after(launch: Launch) -> zenoh.Session:
    launch.wait_output(Launch.ROUTER_UP, 60)
    return client_session(launch.port)
