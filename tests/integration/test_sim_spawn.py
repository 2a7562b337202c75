"""Spawning into the simulator process (CLI from a file and from robot_description, service with a pose,
bad URDF, two robots), limits over the hardware interface, world-control CLI, and malformed input."""

from __future__ import annotations

import math
import time
from pathlib import Path

import msgpack
import pytest

from nodes.core import Node
from nodes.core.endpoints import ServiceError
from nodes.sim.interfaces import (
    DeleteEntity,
    GetHardwareInfo,
    GetPhysicsProperties,
    SpawnEntity,
)
from tests.conftest import wait_until
from tests.integration.test_sim_helpers import (
    ModelStatesProbe,
    call,
    connect_controller,
    run_cli,
    start_sim,
    wait_ready,
)

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
ARM = (ROOT / "tests" / "data" / "sim_arm.urdf").read_text()


@pytest.fixture
def node(router):
    n = Node("sim_spawn_test", connect=[router])
    yield n
    n.destroy()


def test_spawn_from_file_topic_and_service_with_poses_and_bad_input(processes, node, session, zenoh_port):
    proc = start_sim(processes, "ground_enabled:=true")
    wait_ready(node, processes, proc)
    port = ["--zenoh-port", str(zenoh_port)]
    probe = ModelStatesProbe(node)

    # 1. from a file, spawn_entity.py style, with a pose
    result = run_cli(processes, "spawn", "-entity", "humanoid", "-file", "humanoid",
                     "-x", "1.0", "-y", "2.0", "-z", "0.915", "-Y", "1.5707963", *port)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "spawned 'humanoid'" in result.stdout

    # 2. from a latched robot_description (answered by a queryable, as the state publisher does)
    queryable = session.declare_queryable(
        "arm/robot_description",
        lambda query: query.reply("arm/robot_description", msgpack.packb({"data": ARM})))
    result = run_cli(processes, "spawn", "-entity", "arm", "-topic", "/arm/robot_description", "-fixed",
                     "-x", "3.0", "-J", "elbow", "0.5", *port)
    assert result.returncode == 0, result.stdout + result.stderr

    wait_until(lambda: {"ground_plane", "humanoid", "arm"} <= set(probe.get()), 20, message="three models")
    models = probe.get()
    assert list(models)[0] == "ground_plane" and models["ground_plane"][:3] == (0.0, 0.0, 0.0)
    x, y, z, qx, qy, qz, qw = models["humanoid"]
    assert (x, y) == pytest.approx((1.0, 2.0), abs=0.02) and 0.85 < z < 0.95
    assert 2 * math.atan2(qz, qw) == pytest.approx(math.pi / 2, abs=0.02)     # yaw
    assert models["arm"][:3] == pytest.approx((3.0, 0.0, 0.0), abs=1e-9)     # fixed base does not move

    # two robots, each with its own hardware interface
    arm_info = call(node, GetHardwareInfo, "/arm/hardware/info")
    assert [j.name for j in arm_info.joints] == ["shoulder", "elbow"]
    assert arm_info.joints[0].command_interfaces == ["position", "velocity", "effort"]
    assert arm_info.joints[0].max_position == 0.8          # ros2_control max param
    assert len(call(node, GetHardwareInfo, "/humanoid/hardware/info").joints) == 22

    # limits over the hardware interface: commanding past the limit stops at the limit
    arm = connect_controller(node, "arm", policy=lambda state: {"shoulder": 5.0, "elbow": -9.0})
    wait_until(lambda: arm.last_state is not None and abs(arm.last_state["position"][0] - 0.8) < 0.01
               and abs(arm.last_state["position"][1] + 1.5) < 0.01, 30, message="arm at its limits")
    time.sleep(0.3)
    assert arm.last_state["position"][0] <= 0.8 + 0.01 and arm.last_state["position"][1] >= -1.5 - 0.01
    assert "outside [-0.8, 0.8]; clamped" in processes.output(proc)

    # bad requests: clear answers, world unchanged
    def spawn(**fields):
        return call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(**fields))

    broken = ARM.replace('<joint name="elbow" type="revolute">', '<joint name="elbow" type="revolute">\n<bad')
    response = spawn(name="broken", xml=broken)
    assert not response.success and "line" in response.status_message, response.status_message
    response = spawn(name="arm", xml=ARM)
    assert not response.success and "already exists" in response.status_message
    response = spawn(name="arm2", xml=ARM, robot_namespace="arm")
    assert not response.success and "namespace 'arm'" in response.status_message
    response = spawn(name="empty", xml="")
    assert not response.success and "xml is empty" in response.status_message
    hostile = (ROOT / "tests" / "data" / "urdf_broken" / "billion_laughs.urdf").read_text()
    response = spawn(name="lol", xml=hostile)
    assert not response.success and "XML declares entities" in response.status_message, response.status_message
    nan_pose = msgpack.packb({"name": "nan", "xml": ARM, "initial_pose": {"position": {"x": float("nan")}}})
    with pytest.raises(ServiceError, match="initial_pose.position.x"):
        from nodes.core.endpoints import call_raw
        call_raw(node.session, "sim/spawn_entity", nan_pose, 5.0)
    result = run_cli(processes, "spawn", "-entity", "bad", "-file", str(ROOT / "tests" / "data" / "nope.urdf"),
                     *port)
    assert result.returncode == 2 and "not found" in result.stderr

    # malformed payloads on the hardware and service keys never stop the simulator
    session.put("humanoid/hardware/command", b"\xc1\xc1 not msgpack")
    session.put("humanoid/hardware/command", msgpack.packb({"step": 1, "name": ["left_knee"],
                                                            "interface": ["position"], "value": ["x"]}))
    for key in ("sim/pause_physics", "sim/step", "sim/set_physics_properties", "humanoid/hardware/info"):
        replies = list(session.get(key, payload=b"\xc1garbage", timeout=5.0))
        assert replies and replies[0].err is not None, key
    wait_until(lambda: "dropped a malformed message" in processes.output(proc), 10, message="malformed log")
    assert set(probe.get()) == {"ground_plane", "humanoid", "arm"}

    # delete
    assert call(node, DeleteEntity, "/sim/delete_entity", DeleteEntity.Request(name="arm")).success
    assert not call(node, DeleteEntity, "/sim/delete_entity", DeleteEntity.Request(name="arm")).success
    wait_until(lambda: "arm" not in probe.get(), 10, message="arm removed from model_states")
    assert proc.poll() is None
    queryable.undeclare()


def test_sim_cli_pause_step_gravity_reset(processes, node, zenoh_port):
    proc = start_sim(processes, "entities:=[{name: arm, file: tests/data/sim_arm.urdf, fixed: true}]")
    wait_ready(node, processes, proc)
    port = ["--zenoh-port", str(zenoh_port)]

    def props():
        return call(node, GetPhysicsProperties, "/sim/get_physics_properties")

    arm = connect_controller(node, "arm", policy=lambda state: {"shoulder": 0.5}, record=True)
    wait_until(lambda: arm.states > 20, 30, message="lockstep with the arm")
    assert run_cli(processes, "sim", "pause", *port).returncode == 0
    paused_at = props()
    assert paused_at.pause
    time.sleep(0.3)
    assert props().step == paused_at.step                      # nothing moves while paused
    arm.reset_recording()
    result = run_cli(processes, "sim", "step", "25", *port)
    assert result.returncode == 0, result.stdout
    assert props().step == paused_at.step + 25
    assert props().sim_time == pytest.approx(paused_at.sim_time + 0.025, abs=1e-9)
    # stepping runs whole control periods: the controller saw (and answered) every one of them
    assert [row[0] for row in arm.trajectory] == list(range(paused_at.step, paused_at.step + 25))

    result = run_cli(processes, "sim", "gravity", "0", "0", "-1.62", *port)
    assert result.returncode == 0 and props().gravity.z == -1.62
    assert run_cli(processes, "sim", "gravity", "0", "nan", "0", *port).returncode == 2
    assert run_cli(processes, "sim", "step", "-3", *port).returncode == 2
    assert run_cli(processes, "sim", "ground", "off", *port).returncode == 0 and not props().has_ground

    result = run_cli(processes, "spawn", "-entity", "arm2", "-file", "tests/data/sim_arm.urdf", "-fixed",
                     "-x", "1", "-unpause", *port)
    assert result.returncode == 0 and "physics unpaused" in result.stdout, result.stdout + result.stderr
    assert not props().pause
    assert run_cli(processes, "sim", "pause", *port).returncode == 0 and props().pause
    assert run_cli(processes, "sim", "unpause", *port).returncode == 0
    wait_until(lambda: props().step > paused_at.step + 100, 20, message="physics running again")
    result = run_cli(processes, "sim", "step", "5", *port)
    assert result.returncode == 1 and "pause it first" in result.stdout
    before = props().sim_time
    assert before > 0.1
    reset_at = time.monotonic()
    assert run_cli(processes, "sim", "reset", "--time", *port).returncode == 0
    # Sim time starts again from 0 at real time: no more of it than the wall time since the reset began
    # (without the reset, `before` more). A fixed bound fails when the CLI and the query take long on a
    # loaded machine.
    after, elapsed = props().sim_time, time.monotonic() - reset_at
    assert after <= elapsed + 0.05, (before, after, elapsed)
    assert proc.poll() is None


def test_realtime_mode_holds_latest_command_then_position(processes, node, session):
    # the startup entity comes from a latched robot_description, as a launch file would spawn it
    queryable = session.declare_queryable(
        "arm/robot_description",
        lambda query: query.reply("arm/robot_description", msgpack.packb({"data": ARM})))
    proc = start_sim(processes, "mode:=realtime", "command_timeout:=0.3",
                     "entities:=[{name: arm, topic: /arm/robot_description, fixed: true, z: 0.5}]")
    props = wait_ready(node, processes, proc)
    assert props.mode == "realtime"
    wait_until(lambda: "spawned 'arm'" in processes.output(proc), 30, message="arm spawned from the topic")

    arm = connect_controller(node, "arm", policy=lambda state: {"shoulder": 0.5, "elbow": -0.7})
    wait_until(lambda: arm.last_state is not None and abs(arm.last_state["position"][0] - 0.5) < 0.01
               and abs(arm.last_state["position"][1] + 0.7) < 0.01, 30, message="arm at the commanded pose")
    arm.enabled = False                    # commands stop: the last one is held, then position is held
    wait_until(lambda: "no hardware/command for 0.3 s; holding position" in processes.output(proc), 15,
               message="realtime command_timeout fallback")
    time.sleep(0.5)
    position = arm.last_state["position"]
    assert position[0] == pytest.approx(0.5, abs=0.02) and position[1] == pytest.approx(-0.7, abs=0.02)
    assert proc.poll() is None
    queryable.undeclare()


@pytest.mark.parametrize("param, message", [
    ("mode:=fast", "parameter 'mode'"),
    ('gains:={"*": {"q": 1}}', "gains.*: unknown keys"),
    ("entities:=[{name: x}]", "entities[0]: give exactly one of file and topic"),
])
def test_bad_parameters_exit_2_naming_the_parameter(processes, param, message):
    proc = start_sim(processes, param)
    assert proc.wait(60) == 2          # and it exits: the Zenoh session is closed on the way out
    assert message in processes.output(proc)
