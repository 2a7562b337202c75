"""ROS 2 Python programs (rclpy) run unchanged on zenroid: real processes over real Zenoh, and each also seen
by zenoh-ros2-sdk (an independent rmw_zenoh client) to show a ROS 2 node would see it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import ROOT, wait_until
from tests.support.ros_shim import shim_env

PROGRAMS = ROOT / "tests" / "support" / "rclpy_programs"


@pytest.fixture
def ros_env(tmp_path: Path) -> dict[str, str]:
    """Extra environment for the programs: the ROS module names when they are not importable yet."""
    from bench.common import child_env

    return shim_env(tmp_path / "shim", child_env()["PYTHONPATH"])


def test_talker_and_listener_as_written(processes, ros_env) -> None:
    talker = processes.start(str(PROGRAMS / "talker.py"), name="talker", env=ros_env)
    listener = processes.start(str(PROGRAMS / "listener.py"), name="listener", env=ros_env)
    wait_until(lambda: 'I heard: "Hello World: ' in processes.output(listener), timeout=30,
               message="the listener hearing the talker\n" + processes.output(talker)[-2000:])
    first = processes.output(talker).splitlines()[0]
    assert "rclpy (zenroid, no ROS) connected to tcp/127.0.0.1:" in first, first
    listener.send_signal(2)   # Ctrl-C: the program ends itself, cleanly
    assert listener.wait(timeout=15) == 0, processes.output(listener)
    assert "Traceback" not in processes.output(listener), processes.output(listener)


def test_zenroid_run_passes_ros_args(processes, ros_env) -> None:
    """``zenroid run FILE --ros-args -r __node:= -r topic:=`` renames the node and remaps its topic."""
    listener = processes.start("-m", "nodes.tools.cli", "run", str(PROGRAMS / "listener.py"), "--ros-args",
                               "-r", "__node:=renamed", "-r", "topic:=chatter", name="listener", env=ros_env)
    talker = processes.start(str(PROGRAMS / "talker.py"), "--ros-args", "-r", "topic:=/chatter",
                             "--log-level", "warn", name="talker", env=ros_env)
    wait_until(lambda: "[renamed]: I heard" in processes.output(listener), timeout=30,
               message="the renamed listener on the remapped topic\n" + processes.output(listener)[-2000:])
    assert "Publishing" not in processes.output(talker)   # --log-level warn


def test_no_router_says_so_once_and_ctrl_c_ends_it(tmp_path, ros_env) -> None:
    from bench.common import child_env, free_port

    env = child_env({**ros_env, "ZENOH_CONNECT": f"tcp/127.0.0.1:{free_port()}"})
    log = tmp_path / "talker.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen([sys.executable, str(PROGRAMS / "talker.py")], env=env, stdout=out,
                                stderr=subprocess.STDOUT)
    try:
        wait_until(lambda: "waiting for a Zenoh router" in log.read_text(), timeout=60,
                   message="the waiting line")
        import time

        time.sleep(2.0)   # still waiting: said once only
        proc.send_signal(2)
        proc.wait(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
    text = log.read_text()
    assert text.count("waiting for a Zenoh router") == 1, text
    assert "zenroid router" in text, text
