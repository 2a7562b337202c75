"""``zenroid`` verbs against real processes: nothing hangs or pretends, ROS names get hints, closed pipes end
streaming verbs, latched topics echo, parameters apply live or are refused, the newer verbs work."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

import pytest
import yaml

import msgs
from nodes.core import Node
from nodes.core.delivery import Inline
from tests.conftest import ROOT, free_port, wait_until

JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")


def _env(endpoint: str) -> dict[str, str]:
    env = dict(os.environ, ZENOH_CONNECT=endpoint, PYTHONPATH=str(ROOT))
    env.pop("ZENOH_CONFIG", None)
    return env


def zenroid(endpoint: str, *argv: str, timeout: float = 60) -> subprocess.CompletedProcess:
    """One verb; the timeout is only a guard against a hang (the verbs must end on their own)."""
    return subprocess.run([sys.executable, "-m", "nodes.tools", *argv], capture_output=True, text=True,
                          env=_env(endpoint), timeout=timeout, cwd=ROOT)


def start(endpoint: str, *argv: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "nodes.tools", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=_env(endpoint), cwd=ROOT)


def test_without_a_router_every_network_verb_fails_with_the_reason(tmp_path) -> None:
    nobody = f"tcp/127.0.0.1:{free_port()}"
    verbs = [
        ["node", "list"], ["node", "info", "/humanoid/simulator"], ["topic", "list"],
        ["topic", "echo", "humanoid/joint_states", "--once"], ["topic", "hz", "humanoid/joint_states"],
        ["topic", "info", "humanoid/joint_states"],
        ["topic", "pub", "--once", "x", "std_msgs/msg/String", "{data: hi}"],
        ["service", "list"], ["service", "call", "sim/pause_physics", "std_srvs/srv/Empty"],
        ["action", "info", "humanoid/joint_trajectory_controller/follow_joint_trajectory"],
        ["param", "get", "/humanoid/joint_commander", "period"], ["lifecycle", "get", "/x"],
        ["log", "level", "/humanoid/joint_commander"], ["control", "list_controllers"], ["sim", "info"],
        ["bag", "record", "-a", "-o", str(tmp_path / "never_written")], ["graph"],
    ]
    procs = [start(nobody, *argv) for argv in verbs]  # all at once: the test takes as long as the slowest
    for argv, proc in zip(verbs, procs):
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 1, (argv, proc.returncode, out, err)
        assert b"no Zenoh router answers at " + nobody.encode() in err, (argv, err)
        assert b"Traceback" not in err
    assert not (tmp_path / "never_written").exists()


@pytest.fixture
def commander(processes):
    """The tutorial's joint commander in namespace humanoid (it needs no controller to publish)."""
    proc = processes.start("-m", "nodes.commanders.joint_commander", "--ns", "humanoid", "--param", "period:=0.5",
                           name="joint_commander")
    wait_until(lambda: "Joint Commander initialized" in processes.output(proc), timeout=30, message="commander up")
    return proc


@pytest.fixture
def sweep(processes):
    """A fast joint_states publisher in namespace humanoid (joint_sweep at 200 Hz)."""
    proc = processes.start("-m", "nodes.commanders.joint_sweep", "--ns", "humanoid", "--param", "robot:=humanoid",
                           "--param", "rate:=200.0", name="sweep")
    wait_until(lambda: "sweeping" in processes.output(proc), timeout=30, message="sweep up")
    return proc


def test_router_without_nodes_lists_fail_and_echo_gives_up(router) -> None:
    listed = zenroid(router, "node", "list")
    assert listed.returncode == 1 and "no nodes are running" in listed.stderr
    echo = zenroid(router, "topic", "echo", "humanoid/joint_states", "--once", "--wait", "2")
    assert echo.returncode == 1
    assert "waiting for a publisher on 'humanoid/joint_states'" in echo.stderr
    assert "no publisher on 'humanoid/joint_states' within 2 s" in echo.stderr


def test_ros_names_get_a_namespace_hint(router, commander, sweep) -> None:
    echo = zenroid(router, "topic", "echo", "/joint_states", "--once", "--wait", "1")
    assert echo.returncode == 1
    assert "no publisher on 'joint_states'" in echo.stderr
    assert "did you mean humanoid/joint_states?" in echo.stderr
    info = zenroid(router, "topic", "info", "/joint_trajectory_controller/joint_trajectory")
    assert info.returncode == 1 and "Type: unknown" not in info.stdout
    assert "did you mean humanoid/joint_trajectory_controller/joint_trajectory?" in info.stderr
    good = zenroid(router, "topic", "info", "/humanoid/joint_trajectory_controller/joint_trajectory")
    assert good.returncode == 0 and "Type: trajectory_msgs/msg/JointTrajectory" in good.stdout
    assert "/humanoid/joint_commander" in good.stdout
    param = zenroid(router, "param", "get", "/joint_commander", "period")
    assert param.returncode == 1 and "did you mean /humanoid/joint_commander?" in param.stderr
    nobody = zenroid(router, "topic", "pub", "--once", "/joint_states", "sensor_msgs/msg/JointState", "{}",
                     "--wait", "0.5")
    assert nobody.returncode == 1 and "nobody subscribes to 'joint_states'" in nobody.stderr
    field = zenroid(router, "topic", "echo", "humanoid/joint_states", "--once", "--field", "position.0")
    assert field.returncode == 0 and "..." not in field.stdout
    float(field.stdout.split("\n")[0])  # the value alone, then the --- separator
    listed = zenroid(router, "topic", "list")
    assert "/humanoid/joint_states" in listed.stdout.split() and "[" not in listed.stdout  # types only with -t
    assert "/humanoid/joint_states [sensor_msgs/msg/JointState]" in zenroid(router, "topic", "list", "-t").stdout


@pytest.mark.parametrize("argv", [
    ["topic", "echo", "humanoid/joint_states"],
    ["topic", "echo", "humanoid/joint_states", "--json"],
    ["topic", "hz", "humanoid/joint_states", "--window", "0.2"],
    ["topic", "bw", "humanoid/joint_states", "--window", "0.2"],
    ["bag", "record", "humanoid/joint_states", "-o", "{tmp}/bag"],
])
def test_a_closed_pipe_ends_streaming_verbs_at_once_and_quietly(router, sweep, tmp_path, argv) -> None:
    proc = start(router, *[a.replace("{tmp}", str(tmp_path)) for a in argv])
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.readline()
    proc.stdout.close()  # like `| head -1`: the next write fails
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"{argv} kept running after its reader left")
    err = proc.stderr.read()
    assert proc.returncode == 0, err
    assert b"Traceback" not in err and b"BrokenPipe" not in err


def test_latched_topic_echoes_its_last_message(processes, router) -> None:
    processes.start("-m", "nodes.state_publisher", "--ns", "humanoid", "--param",
                    "robot_description_file:=robots/humanoid.urdf", name="rsp")
    wait_until(lambda: "robot 'humanoid'" in " ".join(processes.output(p) for p in processes.procs), timeout=30,
               message="state publisher up")
    time.sleep(1.0)  # published long ago: only the latched answer can deliver it now
    echo = zenroid(router, "topic", "echo", "humanoid/robot_description", "--once", "--field", "data")
    assert echo.returncode == 0, echo.stderr
    assert echo.stdout.lstrip().startswith("<?xml") and '<robot name="humanoid"' in echo.stdout


def _commands_per_second(router: str, seconds: float) -> float:
    count = 0
    lock = threading.Lock()

    def on_msg(_msg: object) -> None:
        nonlocal count
        with lock:
            count += 1

    node = Node("rate_probe", connect=[router])
    try:
        node.create_subscription(JointTrajectory, "/humanoid/joint_trajectory_controller/joint_trajectory", on_msg,
                                 delivery=Inline())
        time.sleep(0.5)
        with lock:
            count = 0
        time.sleep(seconds)
        with lock:
            return count / seconds
    finally:
        node.destroy()


def test_parameters_apply_live_or_are_refused_with_the_reason(router, commander, tmp_path) -> None:
    node = "/humanoid/joint_commander"
    assert 1.0 <= _commands_per_second(router, 2.0) <= 3.5  # period 0.5 s
    changed = zenroid(router, "param", "set", node, "period", "0.1")
    assert changed.returncode == 0 and "Set parameter successful" in changed.stdout
    assert _commands_per_second(router, 1.5) >= 6.0  # now every 0.1 s
    refused = zenroid(router, "param", "set", node, "controller", "other_controller")
    assert refused.returncode == 1
    assert "read-only (set at start-up: restart the node with --param controller:=VALUE)" in refused.stdout
    assert zenroid(router, "param", "set", node, "use_sim_time", "true").returncode == 1
    stopped = zenroid(router, "param", "set", node, "enabled", "false")
    assert stopped.returncode == 0
    assert _commands_per_second(router, 1.0) == 0.0
    # no stray YAML document-end lines anywhere
    listed = zenroid(router, "param", "list", node)
    got = zenroid(router, "param", "get", node, "period")
    assert "..." not in listed.stdout + got.stdout and got.stdout.strip() == "0.1"
    assert "  enabled: false" in listed.stdout
    # dump -> edit -> load, like ros2 param dump/load
    dumped = zenroid(router, "param", "dump", node)
    data = yaml.safe_load(dumped.stdout)
    assert data[node]["ros__parameters"]["period"] == 0.1
    data[node]["ros__parameters"]["knee"] = 0.5
    data[node]["ros__parameters"]["enabled"] = True
    path = tmp_path / "commander.yaml"
    path.write_text(yaml.safe_dump(data))
    loaded = zenroid(router, "param", "load", node, str(path))
    assert loaded.returncode == 0, loaded.stdout + loaded.stderr
    assert "Set parameter knee successful" in loaded.stdout and "Set parameter enabled successful" in loaded.stdout
    assert zenroid(router, "param", "get", node, "knee").stdout.strip() == "0.5"
    assert _commands_per_second(router, 1.0) > 0  # enabled again


def test_log_level_changes_at_run_time(router, commander, processes) -> None:
    node = "/humanoid/joint_commander"
    assert zenroid(router, "log", "level", node).stdout.strip() == "info"
    changed = zenroid(router, "log", "level", node, "warn")
    assert changed.returncode == 0 and "log level warn" in changed.stdout
    assert zenroid(router, "log", "level", node).stdout.strip() == "warn"
    proc = processes.procs[0]
    time.sleep(1.0)
    before = processes.output(proc).count("Sent command")
    time.sleep(2.0)  # two commands per second, none logged at warn
    assert processes.output(proc).count("Sent command") == before
    bad = zenroid(router, "log", "level", node, "loud")
    assert bad.returncode == 2 and "unknown log level 'loud'" in bad.stderr


def test_service_type_action_info_and_lifecycle_list(processes, router) -> None:
    proc = processes.start("-m", "tests.support.echo_node", name="echo")
    wait_until(lambda: "ready" in processes.output(proc), timeout=30, message="echo node ready")
    assert zenroid(router, "service", "type", "/echo/trigger").stdout.strip() == "std_srvs/srv/Trigger"
    missing = zenroid(router, "service", "type", "/trigger")
    assert missing.returncode == 1 and "did you mean echo/trigger?" in missing.stderr
    info = zenroid(router, "action", "info", "/echo/navigate", "-t")
    assert info.returncode == 0
    assert "Action servers: 1\n    /echo [humanoid_msgs/action/NavigateToGoal]" in info.stdout
    assert "Action clients: 0" in info.stdout
    assert "/echo" in zenroid(router, "lifecycle", "nodes").stdout.split()
    available = zenroid(router, "lifecycle", "list", "/echo")
    assert available.returncode == 0
    assert "- configure [1]\n\tStart: unconfigured\n\tGoal: inactive" in available.stdout
    assert "activate" not in available.stdout.replace("deactivate", "")
    refused = zenroid(router, "lifecycle", "set", "/echo", "activate")
    assert refused.returncode == 1 and "zenroid lifecycle list /echo" in refused.stderr


def test_joint_sweep_rate_applies_live(router, sweep) -> None:
    def rate() -> float:
        done = zenroid(router, "topic", "hz", "humanoid/joint_states", "--window", "3", "--duration", "3")
        assert done.returncode == 0, done.stderr
        return float(done.stdout.split("average rate:")[1].split()[0])

    assert rate() > 100  # 200 Hz (a loaded machine may lose some ticks)
    assert zenroid(router, "param", "set", "/humanoid/joint_state_publisher", "rate", "20.0").returncode == 0
    assert rate() < 30
    refused = zenroid(router, "param", "set", "/humanoid/joint_state_publisher", "robot", "atlas")
    assert refused.returncode == 1 and "read-only" in refused.stdout
