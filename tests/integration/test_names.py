"""Names are ROS names before anything else: a spawn request or a robot file carrying a name rcl would refuse
(too long, a wildcard, an empty token, a token starting with a digit) is refused at the door, the field and
the reason named, and nothing of it reaches Zenoh or the renderer: the simulator keeps serving and the
humanoid's camera keeps publishing."""

from __future__ import annotations

import re
import threading
from pathlib import Path

import msgpack
import pytest

import msgs
from nodes.core import Node
from nodes.core.delivery import Inline, Raw
from nodes.sim.interfaces import DeleteEntity, GetModelList, SpawnEntity, StepSimulation
from tests.conftest import wait_until
from tests.integration.test_sim_helpers import ModelStatesProbe, call, start_sim, wait_ready

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
BOX = ("<?xml version='1.0'?><robot name='box'><link name='base'><inertial><mass value='1'/>"
       "<inertia ixx='0.01' iyy='0.01' izz='0.01' ixy='0' ixz='0' iyz='0'/></inertial>"
       "<collision><geometry><box size='0.2 0.2 0.2'/></geometry></collision></link></robot>")


def camera_robot(*, sensor: str = "cam", namespace: str = "", remap: str = "", frame: str = "base") -> str:
    ros = (f"<namespace>{namespace}</namespace>" if namespace else "") + (
        f"<remapping>{remap}</remapping>" if remap else "")
    return ("<?xml version='1.0'?><robot name='cam'><link name='base'><inertial><mass value='1'/>"
            "<inertia ixx='0.01' iyy='0.01' izz='0.01' ixy='0' ixz='0' iyz='0'/></inertial>"
            "<collision><geometry><box size='0.2 0.2 0.2'/></geometry></collision></link>"
            f"<gazebo reference='base'><sensor name='{sensor}' type='camera'><update_rate>10</update_rate>"
            "<camera><horizontal_fov>1.0</horizontal_fov><image><width>32</width><height>24</height></image>"
            "<clip><near>0.05</near><far>10</far></clip></camera>"
            f"<plugin name='cam_controller' filename='libgazebo_ros_camera.so'><ros>{ros}</ros>"
            f"<frame_name>{frame}</frame_name></plugin></sensor></gazebo></robot>")


def test_a_huge_robot_namespace_is_refused_and_the_simulator_keeps_serving(processes, router):
    sim = start_sim(processes, "ground_enabled:=true", "mode:=realtime")
    node = Node("names_test", connect=[router])
    try:
        wait_ready(node, processes, sim)
        probe = ModelStatesProbe(node)
        for namespace, reason in (("n" * 100_000, r"robot_namespace .*100000 characters, over the limit of \d+"),
                                  ("a//b", r"robot_namespace .*empty token"),
                                  ("robot/**", r"robot_namespace .*'\*'"),
                                  ("7up", r"robot_namespace .*starts with a digit")):
            reply = call(node, SpawnEntity, "/sim/spawn_entity",
                         SpawnEntity.Request(name="box", xml=BOX, robot_namespace=namespace), timeout=20)
            assert not reply.success and re.search(reason, reply.status_message), reply.status_message[:300]
            assert len(reply.status_message) < 1000
        reply = call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(name="b" * 100_000, xml=BOX),
                     timeout=20)
        assert not reply.success and re.search(r"name .*over the limit", reply.status_message)
        # a file:// include outside the model path: one answer whether the host has the folder or not
        answers = set()
        for folder in ("/etc", "/no_such_folder_here", "/tmp/../etc/ssl"):
            xml = (f"<?xml version='1.0'?><sdf version='1.7'><model name='m'><link name='l'/><include>"
                   f"<uri>file://{folder}</uri></include></model></sdf>")
            reply = call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(name="probe", xml=xml))
            assert not reply.success
            answers.add(reply.status_message.replace(folder, "FOLDER"))
        assert len(answers) == 1 and "not in the model path" in answers.pop()
        # still serving: a service answers, the model states keep coming, a good spawn goes through
        assert call(node, GetModelList, "/sim/get_model_list").success
        count = probe.count
        wait_until(lambda: probe.count > count + 10, 20, message="model_states still published")
        reply = call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(name="box", xml=BOX,
                                                                                 robot_namespace="tools/box"))
        assert reply.success, reply.status_message
        wait_until(lambda: "box" in probe.get(), 20, message="the good box")
        output = processes.output(sim)
        assert "panicked" not in output and "100000 characters" in output   # said on the log (and rosout)
        assert sim.poll() is None
    finally:
        node.destroy()


BAD_CAMERAS = {
    "namespace **": (dict(namespace="**"), r"<ros><namespace> '\*\*'"),
    "namespace $*": (dict(namespace="$*"), r"<ros><namespace> '\$\*'"),
    "namespace a//b": (dict(namespace="a//b"), r"<ros><namespace> 'a//b'.*empty token"),
    "sensor a/*/b": (dict(sensor="a/*/b"), r"sensor 'a/\*/b'"),
    "remap ~/out:=**": (dict(remap="~/out:=**"), r"<remapping> '~/out:=\*\*'"),
    "frame with a wildcard": (dict(frame="base*"), r"<frame_name> 'base\*'"),
}


def test_bad_sensor_names_are_refused_and_the_humanoid_camera_keeps_publishing(processes, router):
    sim = start_sim(processes, "world:=empty.world", "mode:=lockstep", "paused:=true",
                    "entities:=[{name: humanoid, file: humanoid, z: 0.93}]")
    renderer = processes.start("-m", "nodes.render", name="renderer")
    node = Node("names_camera_test", connect=[router])
    stamps: list[float] = []
    lock = threading.Lock()

    def on_image(payload: bytes) -> None:
        stamp = msgpack.unpackb(payload)["header"]["stamp"]
        with lock:
            stamps.append(stamp["sec"] + stamp["nanosec"] * 1e-9)

    try:
        wait_ready(node, processes, sim)
        node.create_subscription(None, "/humanoid/camera/rgb", on_image, delivery=Inline(), message=Raw())
        wait_until(lambda: "sensors humanoid::camera" in processes.output(renderer), timeout=60,
                   message="the renderer's scene with the sensors")
        for case, (options, reason) in BAD_CAMERAS.items():
            reply = call(node, SpawnEntity, "/sim/spawn_entity",
                         SpawnEntity.Request(name="cam", xml=camera_robot(**options)), timeout=20)
            assert not reply.success, (case, reply.status_message)
            assert re.search(reason, reply.status_message), (case, reply.status_message)
        # a lidar remapped onto the humanoid's scan with another frame: accepted, and said once on rosout
        lidar = camera_robot().replace("type='camera'", "type='ray'").replace(
            "libgazebo_ros_camera.so", "libgazebo_ros_ray_sensor.so").replace(
            "<ros></ros>", "<ros><remapping>~/out:=/humanoid/scan</remapping></ros>"
            "<output_type>sensor_msgs/LaserScan</output_type>")
        lidar = re.sub(r"<camera>.*</camera>", "<ray><scan><horizontal><samples>10</samples><min_angle>-0.5"
                       "</min_angle><max_angle>0.5</max_angle></horizontal></scan><range><min>0.1</min><max>5</max>"
                       "</range></ray>", lidar)
        warnings: list[str] = []
        node.create_subscription(None, "/rosout", lambda p: warnings.append(msgpack.unpackb(p)["msg"]),
                                 delivery=Inline(), message=Raw())
        reply = call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(name="lidar", xml=lidar))
        assert reply.success, reply.status_message
        wait_until(lambda: any("publishes on '/humanoid/scan' with frame id 'base'" in w for w in warnings), 10,
                   message="the shared key on rosout")
        assert sum("'/humanoid/scan' with frame id" in w for w in warnings) == 1
        assert call(node, DeleteEntity, "/sim/delete_entity", DeleteEntity.Request(name="lidar")).success
        for _ in range(3):
            reply = call(node, StepSimulation, "/sim/step", StepSimulation.Request(steps=300), timeout=120)
            assert reply.success, reply.status_message
        wait_until(lambda: len(stamps) >= 5 and max(stamps) > 0.5, timeout=30, message="camera frames")
        assert "invalid name" not in processes.output(renderer)
        assert sim.poll() is None and renderer.poll() is None
    except BaseException:
        print("--- simulator:\n" + processes.output(sim)[-3000:] + "\n--- renderer:\n" + processes.output(renderer)[-3000:])
        raise
    finally:
        node.destroy()


def test_a_zenoh_panic_inside_a_node_ends_its_process(processes, router):
    """After a panic the session is poisoned: the node would keep its pid and serve nothing. It ends instead
    (status 70), saying why, so that the launcher respawns it."""
    from nodes.core.panic import PANIC_EXIT

    empty = msgs.get_type("std_srvs/srv/Empty")
    proc = processes.start("-m", "tests.support.panicking_node", name="panicker")
    node = Node("panic_test", connect=[router])
    try:
        wait_until(lambda: "ready" in processes.output(proc), 30, message="the node up")
        try:
            node.create_client(empty, "/panicker/panic").call(empty.Request(), timeout=5)
        except Exception:  # noqa: BLE001 - no answer: the node is going away
            pass
        wait_until(lambda: proc.poll() is not None, 20, message="the panicked node to exit")
        assert proc.returncode == PANIC_EXIT
        assert "Zenoh panicked in" in processes.output(proc)
    finally:
        node.destroy()
