"""Worlds in the simulator process: a world file's physics, gravity, ground and models (a model:// include
through the model path among them), gazebo_ros' entity services and the ``zenroid sim`` / ``zenroid spawn``
verbs on them, SDF models spawned at run time, bad requests refused while the simulator keeps running, and
a launch with a bad world file ending with status 1 at once."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import msgpack
import pytest

from nodes.core import Node
from nodes.core.delivery import Inline, Raw
from nodes.sim.interfaces import (
    ApplyJointEffort,
    ApplyLinkWrench,
    Empty,
    GetEntityState,
    GetModelList,
    GetPhysicsProperties,
    JointRequest,
    SetEntityState,
    SpawnEntity,
    StepSimulation,
)
from tests.conftest import free_port, wait_until
from tests.integration.test_sim_helpers import call, run_cli, start_sim, wait_ready

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
RADIUS = 0.1

TEST_WORLD = f"""<?xml version="1.0"?>
<sdf version="1.6">
  <world name="test">
    <gravity>0 0 -5.0</gravity>
    <physics type="ode"><max_step_size>0.002</max_step_size><real_time_factor>2</real_time_factor>
      <real_time_update_rate>1000</real_time_update_rate></physics>
    <include><uri>model://ground_plane</uri></include>
    <include><uri>model://sun</uri></include>
    <include><uri>model://crate</uri><name>crate_1</name><pose>0 3 0.15 0 0 0</pose></include>
    <light name="lamp" type="point"/>
    <plugin name="p" filename="libgazebo_ros_state.so"/>
    <model name="sphere"><pose>0 0 0.6 0 0 0</pose>
      <link name="link">
        <inertial><mass>1</mass><inertia><ixx>0.004</ixx><iyy>0.004</iyy><izz>0.004</izz></inertia></inertial>
        <collision name="c"><geometry><sphere><radius>{RADIUS}</radius></sphere></geometry></collision>
        <visual name="v"><geometry><sphere><radius>{RADIUS}</radius></sphere></geometry></visual>
      </link>
    </model>
    <model name="box"><pose>2 0 0.1 0 0 0</pose>
      <link name="link">
        <inertial><mass>1</mass><inertia><ixx>0.0067</ixx><iyy>0.0067</iyy><izz>0.0067</izz></inertia></inertial>
        <collision name="c"><geometry><box><size>0.2 0.2 0.2</size></box></geometry></collision>
      </link>
    </model>
    <model name="wall"><static>true</static><pose>-2 0 0.5 0 0 0</pose>
      <link name="link"><collision name="c"><geometry><box><size>0.1 4 1</size></box></geometry></collision></link>
    </model>
    <model name="door"><pose>0 -3 0 0 0 0</pose>
      <link name="frame"><collision name="c"><geometry><box><size>0.1 0.1 2</size></box></geometry></collision></link>
      <link name="leaf"><pose>0.5 0 1 0 0 0</pose>
        <inertial><mass>5</mass><inertia><ixx>1</ixx><iyy>1</iyy><izz>1</izz></inertia></inertial>
        <collision name="c"><geometry><box><size>0.8 0.05 1.8</size></box></geometry></collision>
      </link>
      <joint name="fixed_frame" type="fixed"><parent>world</parent><child>frame</child></joint>
      <joint name="hinge" type="revolute"><parent>frame</parent><child>leaf</child><pose>-0.5 0 0 0 0 0</pose>
        <axis><xyz>0 0 1</xyz></axis></joint>
    </model>
  </world>
</sdf>
"""

CRATE = """<?xml version="1.0"?><sdf version="1.7"><model name="crate"><link name="link">
  <inertial><mass>2</mass><inertia><ixx>0.03</ixx><iyy>0.03</iyy><izz>0.03</izz></inertia></inertial>
  <collision name="c"><geometry><box><size>0.3 0.3 0.3</size></box></geometry></collision></link></model></sdf>"""


@pytest.fixture
def node(router):
    n = Node("sim_worlds_test", connect=[router])
    yield n
    n.destroy()


def step(node: Node, steps: int) -> None:
    response = call(node, StepSimulation, "/sim/step", StepSimulation.Request(steps=steps), timeout=60)
    assert response.success, response.status_message


def state(node: Node, name: str, frame: str = ""):
    return call(node, GetEntityState, "/sim/get_entity_state", GetEntityState.Request(name=name, reference_frame=frame))


def test_world_file_physics_models_entity_services_and_bad_requests(processes, node, tmp_path, zenoh_port):
    models = tmp_path / "models"
    (models / "crate").mkdir(parents=True)
    (models / "crate" / "model.config").write_text("<model><name>crate</name><sdf version='1.7'>crate.sdf</sdf></model>")
    (models / "crate" / "crate.sdf").write_text(CRATE)
    world = tmp_path / "test.world"
    world.write_text(TEST_WORLD)
    proc = processes.start("-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml"),
                           "--param", f"world:={world}", "--param", "paused:=true", name="sim",
                           env={"GAZEBO_MODEL_PATH": str(models)})
    physics = wait_ready(node, processes, proc)

    # <physics> and <gravity> from the file are what get_physics_properties reports
    assert physics.time_step == 0.002 and physics.real_time_factor == 2.0
    assert (physics.gravity.x, physics.gravity.y, physics.gravity.z) == (0.0, 0.0, -5.0) and physics.has_ground
    log = processes.output(proc)
    assert "world 'test' from" in log and "accepted but not simulated: light, light (model://sun), plugin" in log

    listed = call(node, GetModelList, "/sim/get_model_list")
    assert listed.success and listed.model_names == ["ground_plane", "crate_1", "sphere", "box", "wall", "door"]

    # a dynamic sphere falls and rests on the ground at z = radius
    step(node, 1000)                                                 # 2 s of sim time
    sphere = state(node, "sphere")
    assert sphere.success and sphere.state.pose.position.z == pytest.approx(RADIUS, abs=0.005)
    assert abs(sphere.state.twist.linear.z) < 0.01
    crate = state(node, "crate_1::link")
    assert crate.state.pose.position.z == pytest.approx(0.15, abs=0.005)   # included through the model path
    assert state(node, "wall").state.pose.position.x == -2.0                 # static: stays

    # apply_link_wrench moves the free box in the force's direction (8 N against 5 N of friction, 0.5 s)
    request = ApplyLinkWrench.Request(link_name="box::link")
    request.wrench.force.x, request.wrench.force.y = 5.657, 5.657
    request.duration.nanosec = 500_000_000
    response = call(node, ApplyLinkWrench, "/sim/apply_link_wrench", request)
    assert response.success, response.status_message
    step(node, 500)
    box = state(node, "box").state.pose.position
    assert box.x - 2.0 > 0.05 and box.y > 0.05 and box.x - 2.0 == pytest.approx(box.y, rel=0.05)
    moved = (box.x, box.y)
    step(node, 500)                                 # the wrench expired after 0.5 s: friction has stopped it
    box = state(node, "box").state.pose.position
    assert (box.x, box.y) == pytest.approx(moved, abs=0.01)

    # set_entity_state then get_entity_state round-trips a pose (and a frame relative to another model)
    request = SetEntityState.Request()
    request.state.name = "box"
    p, q = request.state.pose.position, request.state.pose.orientation
    p.x, p.y, p.z = 1.0, 2.0, 0.5
    q.z, q.w = 0.29552020666133955, 0.955336489125606   # yaw 0.6
    assert call(node, SetEntityState, "/sim/set_entity_state", request).success
    got = state(node, "box")
    assert (got.state.pose.position.x, got.state.pose.position.y, got.state.pose.position.z) == \
        pytest.approx((1.0, 2.0, 0.5), abs=1e-9)
    assert (got.state.pose.orientation.z, got.state.pose.orientation.w) == pytest.approx((q.z, q.w), abs=1e-9)
    relative = state(node, "box", "wall")
    assert (relative.state.pose.position.x, relative.state.pose.position.y) == pytest.approx((3.0, 2.0), abs=1e-9)
    assert relative.header.frame_id == "wall"

    # apply_joint_effort turns the door's hinge; clear_joint_efforts stops pushing it
    effort = ApplyJointEffort.Request(joint_name="door::hinge", effort=20.0)
    effort.duration.sec = -1
    assert call(node, ApplyJointEffort, "/sim/apply_joint_effort", effort).success
    step(node, 200)
    leaf = state(node, "door::leaf").state.pose
    assert leaf.orientation.z > 0.05                                   # turned about +z
    call(node, JointRequest, "/sim/clear_joint_efforts", JointRequest.Request(joint_name="hinge"))
    assert "clear_joint_efforts 'door::hinge': 1 cleared" in processes.output(proc)

    # an SDF model spawns (service, then the CLI from a file), into the same world
    spawn = SpawnEntity.Request(name="crate_2", xml=CRATE)
    spawn.initial_pose.position.x, spawn.initial_pose.position.z = 1.0, 1.0
    response = call(node, SpawnEntity, "/sim/spawn_entity", spawn)
    assert response.success and "spawned SDF model 'crate_2'" in response.status_message
    (tmp_path / "crate.sdf").write_text(CRATE)
    port = ["--zenoh-port", str(zenoh_port)]
    result = run_cli(processes, "spawn", "-entity", "crate_3", "-file", str(tmp_path / "crate.sdf"), "-x", "-1",
                     "-z", "0.5", *port)
    assert result.returncode == 0, result.stdout + result.stderr
    step(node, 500)
    assert state(node, "crate_2").state.pose.position.z == pytest.approx(0.15, abs=0.01)
    assert state(node, "crate_3").state.pose.position.x == pytest.approx(-1.0, abs=0.01)

    # the CLI verbs
    result = run_cli(processes, "sim", "models", *port)
    assert result.returncode == 0 and "crate_3" in result.stdout.split(), result.stdout + result.stderr
    result = run_cli(processes, "sim", "set", "ball_that_is_not_there", "0", "0", "1", *port)
    assert result.returncode == 1 and "refused" in result.stdout
    result = run_cli(processes, "sim", "set", "sphere", "0.5", "0", "1.0", *port)
    assert result.returncode == 0, result.stdout + result.stderr
    result = run_cli(processes, "sim", "get", "sphere", *port)
    assert result.returncode == 0 and "z: 1.0" in result.stdout, result.stdout
    result = run_cli(processes, "sim", "push", "crate_3", "0", "30", "0", "--duration", "0.4", *port)
    assert result.returncode == 0 and "on 'crate_3::link' for 0.4 s" in result.stdout, result.stdout
    step(node, 500)
    assert state(node, "crate_3").state.pose.position.y > 0.05

    # link_states covers every link of every model
    links: list[list[str]] = []
    node.create_subscription(None, "/sim/link_states", lambda raw: links.append(msgpack.unpackb(raw)["name"]),
                             delivery=Inline(), message=Raw())
    time.sleep(0.5)
    wait_until(lambda: call(node, Empty, "/sim/unpause_physics") is not None and links, 20,
               message="link_states")
    call(node, Empty, "/sim/pause_physics")
    assert {"door::frame", "door::leaf", "crate_1::link", "sphere::link", "ground_plane::link"} <= set(links[-1])

    # bad requests: refused with the reason in the log, the simulator keeps running
    assert not state(node, "nothing::here").success
    assert not state(node, "sphere::no_link").success
    bad = SetEntityState.Request()
    bad.state.name = "sphere"
    bad.state.pose.position.x = float("nan")
    # refused by the calling side now (msgs.EncodeError, a ValueError), as the server's decoder would
    with pytest.raises(ValueError, match=r"state.pose.position.x: not a finite number"):
        call(node, SetEntityState, "/sim/set_entity_state", bad)
    bad.state.pose.position.x = 1e9
    assert not call(node, SetEntityState, "/sim/set_entity_state", bad).success
    push = ApplyLinkWrench.Request(link_name="wall")
    push.wrench.force.x, push.duration.sec = 10.0, 1
    response = call(node, ApplyLinkWrench, "/sim/apply_link_wrench", push)
    assert not response.success and "static model" in response.status_message
    push = ApplyLinkWrench.Request(link_name="box")
    push.wrench.force.x, push.duration.sec = 1e12, 1
    response = call(node, ApplyLinkWrench, "/sim/apply_link_wrench", push)
    assert not response.success and "wrench.force: [1000000000000.0, 0.0, 0.0] is beyond" in response.status_message
    response = call(node, ApplyJointEffort, "/sim/apply_joint_effort", ApplyJointEffort.Request(joint_name="nope"))
    assert not response.success and "no joint 'nope'" in response.status_message
    for xml, reason in [
        (CRATE, "an entity named 'crate_2' already exists"),
        ("<?xml version='1.0'?><!DOCTYPE sdf [<!ENTITY a 'x'>]><sdf version='1.6'><model name='&a;'/></sdf>",
         "XML declares entities"),
        (CRATE.replace("<mass>2</mass>", "<mass>nan</mass>"), "<mass>: must be finite"),
        (CRATE.replace('<size>0.3 0.3 0.3</size>', '<size>0.3 0.3 1e9</size>'), "each side must be in"),
        ("<sdf version='1.6'><model name='m'><include><uri>model://missing</uri></include></model></sdf>",
         "no model 'missing' in the model path"),
    ]:
        name = "crate_2" if xml == CRATE else "crate_9"
        response = call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(name=name, xml=xml))
        assert not response.success and reason in response.status_message, response.status_message
    log = processes.output(proc)
    for reason in ("get_entity_state 'nothing::here': name: no model named 'nothing'",
                   "model 'sphere' has no link 'no_link'", "state.pose.position: [1000000000.0, 0.0, 0.0] is beyond"):
        assert reason in log, reason
    assert proc.poll() is None
    step(node, 10)

    # reset_world puts the world's models back where the file placed them
    call(node, Empty, "/sim/reset_world")
    assert state(node, "box").state.pose.position.x == pytest.approx(2.0, abs=1e-9)
    assert state(node, "sphere").state.pose.position.z == pytest.approx(0.6, abs=1e-9)


@pytest.mark.parametrize("world", ["empty.world", "simple_lab.world"])
def test_each_shipped_world_loads_in_the_simulator(processes, node, world):
    proc = start_sim(processes, f"world:={world}", "paused:=true")
    physics = wait_ready(node, processes, proc)
    assert physics.has_ground and physics.time_step == 0.001
    names = call(node, GetModelList, "/sim/get_model_list").model_names
    expected = {"empty.world": ["ground_plane"],
                "simple_lab.world": ["ground_plane", "walls", "table", "block", "book", "box_small", "box_medium",
                                     "box_large", "ball", "ramp"]}[world]
    assert names == expected
    call(node, GetPhysicsProperties, "/sim/get_physics_properties")
    assert "loaded in" in processes.output(proc)


@pytest.mark.parametrize(("world", "reason"), [
    ("no_such_world", "world 'no_such_world' not found"),
    ("BAD", "no model 'no_such_model' in the model path"),
])
def test_a_launch_with_a_bad_world_file_exits_1_at_once(tmp_path, world, reason):
    if world == "BAD":
        world = str(tmp_path / "bad.world")
        Path(world).write_text("<sdf version='1.6'><world name='w'><include><uri>model://no_such_model</uri>"
                               "</include></world></sdf>")
    started = time.monotonic()
    result = subprocess.run([sys.executable, "-m", "launch", "humanoid.yaml", "gui:=false", "mode:=lockstep",
                             "ros2:=false", f"world:={world}", f"zenoh_port:={free_port()}",
                             "--log-dir", str(tmp_path / "logs")],
                            cwd=ROOT, capture_output=True, text=True, timeout=120)
    elapsed = time.monotonic() - started
    assert result.returncode == 1, result.stdout[-3000:] + result.stderr[-3000:]
    assert reason in result.stdout + result.stderr
    assert "refused its configuration (status 2): not respawned" in result.stdout + result.stderr
    assert "respawning 'simulator'" not in result.stdout
    print(f"bad world launch ended in {elapsed:.1f} s")
