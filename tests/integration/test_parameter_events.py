"""``/parameter_events`` as ROS 2 has it, proved from both sides: an rclpy program's parameters change (its
own timer, a ROS 2 client's ``set_parameters_atomically``) and so do a ``nodes.core`` node's (``zenroid param
set``); another rclpy program's ParameterEventHandler gets its callbacks, zenoh-ros2-sdk (an independent
rmw_zenoh client, with Jazzy's type hash captured from a real ROS 2 graph) decodes the same events, and
``zenroid topic echo /parameter_events`` shows them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bench.common import child_env
from msgs.schema_text import full_definition
from nodes.core import Node
from tests.conftest import ROOT, wait_until
from tests.integration.test_ros2_parameters import DOUBLE, STRING, ros2_param, value_of
from tests.support.ros_shim import shim_env

pytestmark = pytest.mark.slow

PROGRAMS = ROOT / "tests" / "support" / "rclpy_programs"
PEER = ROOT / "tests" / "support" / "ros2_peer.py"
EVENT = "rcl_interfaces/msg/ParameterEvent"
JAZZY_EVENT_HASH = "RIHS01_043e627780fcad87a22d225bc2a037361dba713fca6a6b9f4b869a5aa0393204"


def zenroid(router: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nodes.tools.cli", *args], capture_output=True, text=True,
                          env=child_env({"ZENOH_CONNECT": router}), cwd=ROOT, timeout=60)


def heard(path: Path) -> list[dict]:
    """The peer's complete JSON lines so far (the last one may still be being written)."""
    lines = path.read_text().split("\n")[:-1]
    return [json.loads(line) for line in lines if line.startswith("{")]


def changed(event: dict) -> dict:
    return {p["name"]: value_of(p["value"]) for p in event["changed_parameters"]}


def test_parameter_events_reach_an_event_handler_zenoh_ros2_sdk_and_the_cli(processes, router, zenoh_port,
                                                                            tmp_path) -> None:
    env = shim_env(tmp_path / "shim", child_env()["PYTHONPATH"])
    peer_out = tmp_path / "peer.jsonl"
    peer_env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ZENOH_CONNECT", "ROS_DOMAIN_ID")}
    with peer_out.open("w") as out:
        listener = subprocess.Popen([sys.executable, str(PEER), "listen", str(zenoh_port), "/parameter_events",
                                     EVENT, full_definition(EVENT), JAZZY_EVENT_HASH, "90"],
                                    stdout=out, stderr=subprocess.STDOUT, env=peer_env, cwd=PEER.parent)
    core = Node("core", namespace="lab", connect=[router])
    try:
        core.declare_parameter("rate", 10.0)
        watcher = processes.start(str(PROGRAMS / "parameter_watcher.py"), "--ros-args", "-r", "__ns:=/lab",
                                  name="watcher", env=env)
        tuner = processes.start(str(PROGRAMS / "parameter_tuner.py"), "--ros-args", "-r", "__ns:=/lab",
                                name="tuner", env=env)
        # the tuner's own ticks: both sides hear the node before anything is asked of it
        wait_until(lambda: "event /lab/tuner new=[] changed=[('tick'," in processes.output(watcher), timeout=60,
                   message="the watcher hearing the tuner tick\n" + processes.output(watcher)[-1500:]
                   + processes.output(tuner)[-1500:])
        wait_until(lambda: any(e["node"] == "/lab/tuner" and "tick" in changed(e) for e in heard(peer_out)),
                   timeout=60, message="zenoh-ros2-sdk hearing the tuner tick\n" + peer_out.read_text()[-1500:])

        done = zenroid(router, "param", "set", "/lab/core", "rate", "20.0")
        assert done.returncode == 0, done.stdout + done.stderr
        answers = ros2_param(zenoh_port, "/lab/tuner", ["set_atomically", [["gain", DOUBLE, 4.0],
                                                                           ["mode", STRING, "run"]]])
        assert answers["set_atomically"][0]["result"]["successful"], answers
        echoed = zenroid(router, "topic", "echo", "/parameter_events", "--once")
        assert echoed.returncode == 0 and "node: /lab/tuner" in echoed.stdout, echoed.stdout + echoed.stderr
        assert "name: tick" in echoed.stdout and "integer_value:" in echoed.stdout, echoed.stdout

        wait_until(lambda: "gain callback: 4.0" in processes.output(watcher), timeout=20,
                   message="the handler's gain callback\n" + processes.output(watcher)[-2000:])
        out = processes.output(watcher)
        assert "event /lab/tuner new=[] changed=[('gain', 4.0), ('mode', 'run')] deleted=[]" in out, out[-2000:]
        assert "event /lab/core new=[] changed=[('rate', 20.0)] deleted=[]" in out, out[-2000:]
        wait_until(lambda: any(e["node"] == "/lab/core" for e in heard(peer_out)), timeout=20,
                   message="zenoh-ros2-sdk hearing the core node\n" + peer_out.read_text()[-1500:])
    finally:
        core.destroy()
        listener.terminate()
        listener.wait(timeout=30)
    events = heard(peer_out)
    atomically = [e for e in events if e["node"] == "/lab/tuner" and "gain" in changed(e)]
    assert [changed(e) for e in atomically] == [{"gain": 4.0, "mode": "run"}], events[-5:]
    gain, mode = atomically[0]["changed_parameters"]
    assert (gain["value"]["type"], mode["value"]["type"]) == (DOUBLE, STRING)
    assert atomically[0]["stamp"]["sec"] > 0 and not atomically[0]["new_parameters"]
    # the peer hears core's declaration of "rate" too when it subscribed in time (it starts beside core)
    core_events = [e for e in events if e["node"] == "/lab/core"]
    assert [changed(e) for e in core_events if e["changed_parameters"]] == [{"rate": 20.0}], core_events
    declared = [[p["name"] for p in e["new_parameters"]] for e in core_events if not e["changed_parameters"]]
    assert declared in ([], [["rate"]]), core_events
