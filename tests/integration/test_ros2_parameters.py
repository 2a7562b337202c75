"""rcl_interfaces' parameter services on the ROS 2 wire, proved from the other side: zenoh-ros2-sdk
(tests/support/ros2_peer.py, an independent rmw_zenoh client that builds the types and computes the hashes
from rcl_interfaces' upstream definitions) gets, lists, describes and sets the parameters of an rclpy program
and of a nodes.core node; rclpy's AsyncParameterClient describes, types, sets atomically and deletes, on an
rclpy program and on a ROS 2 node's parameter services played by zenoh-ros2-sdk."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import msgs
from bench.common import child_env
from nodes.core import Node
from tests.conftest import ROOT, wait_until
from tests.support.ros_shim import DEFINITIONS, shim_env
from tests.unit.test_parameter_values import JAZZY_HASHES

pytestmark = pytest.mark.slow

PROGRAMS = ROOT / "tests" / "support" / "rclpy_programs"
PEER = ROOT / "tests" / "support" / "ros2_peer.py"
RCL_INTERFACES = ROOT / "msgs" / "definitions" / "rcl_interfaces"
BOOL, INTEGER, DOUBLE, STRING = 1, 2, 3, 4
# zenoh-ros2-sdk hashes bounded sequences (ParameterDescriptor's ranges) unlike rosidl: Jazzy's value
HASHES = {"DescribeParameters": JAZZY_HASHES["DescribeParameters"]}


@pytest.fixture
def ros_env(tmp_path: Path) -> dict[str, str]:
    env = shim_env(tmp_path / "shim", child_env()["PYTHONPATH"])
    if env:
        msgs.add_search_path(DEFINITIONS)
    return env


def _peer_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ZENOH_CONNECT", "ROS_DOMAIN_ID")}


def ros2_param(zenoh_port: int, node: str, *requests: list) -> dict[str, list]:
    """The peer's answers to ``requests`` (ros2_peer.py ``param``), by operation in order."""
    done = subprocess.run([sys.executable, str(PEER), "param", str(zenoh_port), str(RCL_INTERFACES), node,
                           json.dumps(list(requests)), json.dumps(HASHES)],
                          capture_output=True, text=True, timeout=120, env=_peer_env(), cwd=PEER.parent)
    assert done.returncode == 0, done.stdout + done.stderr[-3000:]
    answers: dict[str, list] = {}
    for line in done.stdout.splitlines():
        if line.startswith("{"):
            answer = json.loads(line)
            answers.setdefault(answer["op"], []).append(answer["response"])
    return answers


def zenroid(router: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nodes.tools.cli", *args], capture_output=True, text=True,
                          env=child_env({"ZENOH_CONNECT": router}), cwd=ROOT, timeout=60)


def value_of(value: dict):
    field = [None, "bool_value", "integer_value", "double_value", "string_value", "byte_array_value",
             "bool_array_value", "integer_array_value", "double_array_value", "string_array_value"][value["type"]]
    return None if field is None else value[field]


def test_a_ros2_client_gets_lists_describes_and_sets_an_rclpy_programs_parameters(processes, zenoh_port,
                                                                                   ros_env) -> None:
    node = processes.start(str(PROGRAMS / "parameters.py"), "--ros-args", "-p", "gain:=1.5", name="gain",
                           env=ros_env)
    wait_until(lambda: "gain 1.5 mode idle" in processes.output(node), timeout=30,
               message="the program up\n" + processes.output(node)[-1500:])
    answers = ros2_param(
        zenoh_port, "/gain_node",
        ["get", ["gain", "gain_doubled", "mode"]],
        ["list", [], 0],
        ["describe", ["gain", "mode"]],
        ["types", ["gain", "mode"]],
        ["set", [["gain", DOUBLE, 2.5], ["gain", DOUBLE, -1.0], ["mode", STRING, "run"], ["gain", INTEGER, 3]]],
        ["get", ["gain", "gain_doubled", "mode"]],
        ["get", ["gain", "no_such_parameter"]])
    first, after, unknown = answers["get"]
    assert [value_of(v) for v in first["values"]] == [1.5, 2.0, "idle"], first
    assert {"use_sim_time", "gain", "gain_doubled", "mode"} <= set(answers["list"][0]["result"]["names"])
    gain, mode = answers["describe"][0]["descriptors"]
    assert (gain["name"], gain["type"], gain["description"], gain["read_only"]) == ("gain", DOUBLE,
                                                                                   "controller gain", False)
    assert (mode["name"], mode["type"], mode["read_only"]) == ("mode", STRING, True)
    assert answers["types"][0]["types"] == [DOUBLE, STRING]
    ok, negative, read_only, wrong_type = answers["set"][0]["results"]
    assert ok["successful"] and not negative["successful"] and negative["reason"] == "gain must be >= 0"
    assert not read_only["successful"] and read_only["reason"] == "Trying to set a read-only parameter: mode."
    assert not wrong_type["successful"] and "Wrong parameter type" in wrong_type["reason"], wrong_type
    assert [value_of(v) for v in after["values"]] == [2.5, 5.0, "idle"]   # the pre-set callback's gain_doubled
    assert unknown["values"] == []                                         # rclpy: an undeclared name, no values
    assert "applied gain = 2.5" in processes.output(node)                  # the node's post-set callback ran

    inspector = processes.start(str(PROGRAMS / "parameter_inspector.py"), name="inspector", env=ros_env)
    assert inspector.wait(timeout=60) == 0, processes.output(inspector)
    out = processes.output(inspector)
    assert "describe: [('gain', 3, 'controller gain', False), ('mode', 4, '', True)]" in out, out
    assert "types: [3, 4]" in out, out
    assert ("atomically with mode: successful=False reason='Trying to set a read-only parameter: mode.'"
            in out), out
    assert "gain after the refused set: 2.5" in out, out                   # all or nothing
    assert "atomically: successful=True" in out, out
    assert "delete: successful=False reason='Static parameter cannot be undeclared'" in out, out
    assert "list: ['gain', 'gain_doubled', 'mode', 'use_sim_time']" in out, out
    assert "values now [4.0, 8.0]" in out, out


def test_a_ros2_client_gets_lists_describes_and_sets_a_core_nodes_parameters(router, zenoh_port) -> None:
    node = Node("tuned", namespace="lab", connect=[router])
    seen: list[tuple[str, object]] = []

    def on_set(name: str, value: object) -> str | None:
        seen.append((name, value))
        return "seven is unlucky" if value == 7 else None

    try:
        node.declare_parameter("gain", 1.5, description="controller gain", min_value=0.0, max_value=10.0)
        node.declare_parameter("count", 3)
        node.declare_parameter("joints", ["hip", "knee"])
        node.declare_parameter("mode", "idle", read_only=True)
        node.declare_parameter("gains", {"hip": {"p": 100.0}})
        node.add_on_set_parameter_callback(on_set)
        answers = ros2_param(
            zenoh_port, "/lab/tuned",
            ["get", ["gain", "count", "joints", "mode", "gains"]],
            ["list", [], 0],
            ["describe", ["gain", "mode"]],
            ["types", ["gain", "count", "joints", "gains"]],
            ["set", [["gain", DOUBLE, 2.5], ["gain", DOUBLE, 70.0], ["count", INTEGER, 7], ["mode", STRING, "run"],
                     ["gains", STRING, "{hip: {p: 50.0}}"]]],
            ["set_atomically", [["count", INTEGER, 4], ["gain", DOUBLE, 99.0]]],
            ["get", ["gain", "count", "gains"]])
        first, after = answers["get"]
        assert [value_of(v) for v in first["values"]] == [1.5, 3, ["hip", "knee"], "idle", "{hip: {p: 100.0}}"]
        assert answers["list"][0]["result"]["names"] == ["use_sim_time", "gain", "count", "joints", "mode", "gains"]
        gain, mode = answers["describe"][0]["descriptors"]
        assert (gain["type"], gain["description"], gain["read_only"]) == (DOUBLE, "controller gain", False)
        assert [(r["from_value"], r["to_value"]) for r in gain["floating_point_range"]] == [(0.0, 10.0)]
        assert mode["read_only"] and mode["type"] == STRING
        assert answers["types"][0]["types"] == [DOUBLE, INTEGER, 9, STRING]
        results = answers["set"][0]["results"]
        assert [r["successful"] for r in results] == [True, False, False, False, True], results
        assert "above the maximum 10.0" in results[1]["reason"]
        assert results[2]["reason"] == "parameter 'count': seven is unlucky"   # the node's own callback said no
        assert "read-only" in results[3]["reason"]
        atomic = answers["set_atomically"][0]["result"]
        assert not atomic["successful"] and "above the maximum" in atomic["reason"]
        assert [value_of(v) for v in after["values"]] == [2.5, 3, "{hip: {p: 50.0}}"]   # count stayed 3
        assert node.get_parameter("gain") == 2.5 and node.get_parameter("gains") == {"hip": {"p": 50.0}}
        assert ("gain", 2.5) in seen and ("count", 7) in seen                   # the callback saw the sets
        # zenroid's own YAML service still answers on the key of the same name (zenroid param, the probe)
        zenroid_get = msgs.get_type("zenroid_msgs/srv/GetParameters")
        client = node.create_client(zenroid_get, "/lab/tuned/get_parameters")
        assert client.call(zenroid_get.Request(names=["gain"]), timeout=10.0).values_yaml == ["2.5"]
        # zenroid param describe / delete speak the ROS 2 services, printing as ros2 param does
        described = zenroid(router, "param", "describe", "/lab/tuned", "gain", "mode")
        assert described.returncode == 0, described.stdout + described.stderr
        assert ("Parameter name: gain\n  Type: double\n  Description: controller gain\n  Constraints:\n"
                "    Min value: 0.0\n    Max value: 10.0\n") in described.stdout, described.stdout
        assert "Parameter name: mode\n  Type: string\n  Constraints:\n    Read only: true" in described.stdout
        deleted = zenroid(router, "param", "delete", "/lab/tuned", "gain")
        assert deleted.returncode == 1 and "Deleting parameter failed: parameter 'gain': static parameter " \
            "cannot be undeclared" in deleted.stdout, deleted.stdout + deleted.stderr
    finally:
        node.destroy()


def test_rclpys_parameter_client_reaches_a_ros2_node_played_by_zenoh_ros2_sdk(processes, zenoh_port,
                                                                               ros_env) -> None:
    parameters = {"gain": [DOUBLE, 1.0], "gain_doubled": [DOUBLE, 2.0], "mode": [STRING, "idle"]}
    server = subprocess.Popen([sys.executable, str(PEER), "param_server", str(zenoh_port), str(RCL_INTERFACES),
                               "/gain_node", json.dumps(parameters), "90", json.dumps(HASHES)],
                              env=_peer_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              cwd=PEER.parent)
    try:
        tuner = processes.start(str(PROGRAMS / "parameter_client.py"), "2.5", name="tuner", env=ros_env)
        assert tuner.wait(timeout=60) == 0, processes.output(tuner)
        out = processes.output(tuner)
        assert "set gain: successful=True" in out and "gain values now [2.5, 2.0]" in out, out
        inspector = processes.start(str(PROGRAMS / "parameter_inspector.py"), name="inspector", env=ros_env)
        assert inspector.wait(timeout=60) == 0, processes.output(inspector)
        out = processes.output(inspector)
        assert ("describe: [('gain', 3, 'played by zenoh-ros2-sdk', False), "
                "('mode', 4, 'played by zenoh-ros2-sdk', False)]") in out, out
        assert "types: [3, 4]" in out and "atomically with mode: successful=True" in out, out
        assert "delete: successful=False reason='gain: not a 0 parameter of this node'" in out, out
        assert "list: ['gain', 'gain_doubled', 'mode']" in out and "values now [4.0, 2.0]" in out, out
    finally:
        server.terminate()
        seen, errors = server.communicate(timeout=30)
    applied = [json.loads(line) for line in seen.splitlines() if line.startswith("{")]
    assert {"set": "gain", "value": 2.5} in applied and {"set": "mode", "value": "run"} in applied, seen + errors
