"""Meshes from the outside (real simulator, real renderer, real launcher, real Zenoh):

- hostile meshes (non-finite vertices in STL, OBJ and DAE, garbage, empty, flat, a header claiming 1.25 M
  triangles), as collision and as visual, spawned as SDF models or named by a robot's URDF, are refused with
  the file named; the simulator keeps stepping, its memory does not jump, and the humanoid's camera keeps
  rendering;
- a world file with such a mesh ends the launch with status 1 at once, naming the file;
- a mesh with its own colour (OBJ + MTL) is seen by the camera in that colour, at the right depth;
- a renderer given a scene with a shape it cannot draw leaves that shape out, says so once on rosout with the
  model and the file, and draws the rest.
"""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import msgpack
import numpy as np
import pytest

import msgs
from nodes.core import Node
from nodes.core.delivery import Inline, Raw
from nodes.sim.interfaces import GetEntityState, SpawnEntity, StepSimulation
from tests.conftest import free_port, wait_until
from tests.integration.test_sim_helpers import call, wait_ready
from tests.support import meshes as M

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
PAINT = (0.1, 0.3, 0.9)


def mesh_model(name: str, uri: str, *, collision: bool = True, visual: bool = True) -> str:
    geometry = f"<geometry><mesh><uri>{uri}</uri></mesh></geometry>"
    return (f"<?xml version='1.0'?><sdf version='1.7'><model name='{name}'><static>true</static><link name='link'>"
            + (f"<collision name='c'>{geometry}</collision>" if collision else "")
            + (f"<visual name='v'>{geometry}</visual>" if visual else "") + "</link></model></sdf>")


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


class Images:
    """The newest camera image and depth image, by sim time (decoded with msgpack alone)."""

    def __init__(self, node: Node, prefix: str = "humanoid/camera") -> None:
        self.lock = threading.Lock()
        self.latest: dict[str, dict] = {}
        for key in (f"{prefix}/rgb", f"{prefix}/depth"):
            node.create_subscription(None, f"/{key}", self._on, delivery=Inline(), message=Raw(with_key=True))

    def _on(self, payload: bytes, key: str) -> None:
        with self.lock:
            self.latest[key.rsplit("/", 1)[-1]] = msgpack.unpackb(payload)

    def after(self, t: float) -> dict[str, dict]:
        def ready():
            with self.lock:
                ok = all(k in self.latest and stamp(self.latest[k]) > t for k in ("rgb", "depth"))
                return dict(self.latest) if ok else None
        return wait_until(ready, timeout=60, message=f"camera images past sim time {t:.2f}")


def stamp(msg: dict) -> float:
    return msg["header"]["stamp"]["sec"] + msg["header"]["stamp"]["nanosec"] * 1e-9


def centre(images: dict[str, dict]) -> tuple[float, np.ndarray]:
    depth, rgb = images["depth"], images["rgb"]
    h, w = depth["height"], depth["width"]
    d = np.frombuffer(depth["data"], np.float32).reshape(h, w)
    c = np.frombuffer(rgb["data"], np.uint8).reshape(h, w, 3)
    return float(d[h // 2, w // 2]), c[h // 2, w // 2].astype(float)


def step(node: Node, steps: int) -> None:
    response = call(node, StepSimulation, "/sim/step", StepSimulation.Request(steps=steps), timeout=120)
    assert response.success, response.status_message


def test_hostile_meshes_are_refused_and_a_coloured_mesh_is_seen(processes, router, tmp_path):
    models = tmp_path / "models"
    bad = M.hostile(models / "bad" / "meshes")
    M.obj(models / "paint" / "meshes" / "slab.obj", size=(0.1, 6, 3), rgb=PAINT)
    for name in ("bad", "paint"):     # a model folder of the model path: its meshes are model://NAME/...
        (models / name / "model.sdf").write_text(f"<sdf version='1.7'><model name='{name}'><static>true</static>"
                                                 "<link name='link'/></model></sdf>")
    robot_dir = tmp_path / "robot"
    M.binary_stl(robot_dir / "meshes" / "inf.stl", M.with_bad_vertex())
    urdf = (robot_dir / "bot.urdf")
    urdf.write_text("<robot name='bot'><link name='base'><inertial><mass value='1'/><inertia ixx='0.1' iyy='0.1' "
                    "izz='0.1' ixy='0' ixz='0' iyz='0'/></inertial><collision><geometry>"
                    "<mesh filename='meshes/inf.stl'/></geometry></collision></link></robot>")
    sim = processes.start("-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml"),
                          "--param", "world:=empty.world", "--param", "mode:=lockstep", "--param", "paused:=true",
                          "--param", "entities:=[{name: humanoid, file: humanoid, z: 0.93}, "
                          f"{{name: bot, file: {urdf}, z: 2}}]", name="sim", env={"GAZEBO_MODEL_PATH": str(models)})
    renderer = processes.start("-m", "nodes.render", name="renderer")
    node = Node("meshes_test", connect=[router])
    try:
        wait_ready(node, processes, sim)
        # a robot whose URDF names a mesh with an inf vertex: refused at start, the file named, no crash
        wait_until(lambda: "cannot spawn 'bot'" in processes.output(sim), timeout=30, message="bot refused")
        log = processes.output(sim)
        assert re.search(r"cannot spawn 'bot': .*collision mesh '.*inf.stl': .*inf.stl: vertex \d+ is not finite",
                         log), log[-2000:]
        images = Images(node)
        wait_until(lambda: "sensors humanoid::camera" in processes.output(renderer), timeout=60,
                   message="the renderer's scene with the camera")
        step(node, 300)
        images.after(0.2)

        # every hostile mesh, as collision and as visual: refused naming the file and the reason
        t = 0.3
        for case, (path, reason) in bad.items():
            for part in ("collision",) if case == "flat_stl" else ("collision", "visual"):   # a flat decal is drawn
                uri = f"model://bad/meshes/{path.name}"
                before = rss_mb(sim.pid)
                reply = call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(
                    name=f"{case}_{part}", xml=mesh_model(case, uri, collision=part == "collision",
                                                          visual=part == "visual")), timeout=30)
                assert not reply.success, (case, part)
                assert path.name in reply.status_message and reason in reply.status_message, reply.status_message
                if case == "big_stl":   # refused from its header: nothing of 62.5 MB was read
                    assert rss_mb(sim.pid) - before < 30, (before, rss_mb(sim.pid))
            step(node, 100)                      # the physics and the camera go on after each
            t += 0.1
            images.after(t - 0.05)
        assert sim.poll() is None and renderer.poll() is None

        # a mesh with its own colour, 2 m ahead of the camera: seen in that colour, at that depth
        camera = call(node, GetEntityState, "/sim/get_entity_state",
                      GetEntityState.Request(name="humanoid::camera_link")).state.pose.position.x
        reply = call(node, SpawnEntity, "/sim/spawn_entity", msgs.from_dict(SpawnEntity.Request, {
            "name": "slab", "xml": mesh_model("slab", "model://paint/meshes/slab.obj"),
            "initial_pose": {"position": {"x": camera + 2.05, "y": 0.0, "z": 1.5}}}), timeout=30)
        assert reply.success, reply.status_message
        step(node, 300)
        depth, pixel = centre(images.after(t + 0.25))
        assert depth == pytest.approx(2.0, abs=0.01)
        assert pixel / pixel.sum() == pytest.approx(np.array(PAINT) / sum(PAINT), abs=0.03), pixel
        assert sim.poll() is None and renderer.poll() is None
    except BaseException:
        print("--- simulator:\n" + processes.output(sim)[-4000:] + "\n--- renderer:\n" + processes.output(renderer)[-3000:])
        raise
    finally:
        node.destroy()


@pytest.mark.parametrize(("case", "part"), [("inf_stl", "collision"), ("nan_obj", "visual"),
                                            ("garbage_obj", "visual"), ("flat_stl", "collision")])
def test_a_world_with_a_bad_mesh_ends_the_launch_at_once_naming_the_file(tmp_path, case, part):
    path, reason = M.hostile(tmp_path / "meshes")[case]
    geometry = f"<geometry><mesh><uri>meshes/{path.name}</uri></mesh></geometry>"
    world = tmp_path / "bad_mesh.world"
    world.write_text(f"<sdf version='1.6'><world name='w'><include><uri>model://ground_plane</uri></include>"
                     f"<model name='statue'><static>true</static><pose>3 0 0.5 0 0 0</pose><link name='link'>"
                     f"<{part} name='x'>{geometry}</{part}></link></model></world></sdf>")
    try:
        result = subprocess.run([sys.executable, "-m", "launch", "humanoid.yaml", "gui:=false", "mode:=lockstep",
                                 "ros2:=false", f"world:={world}", f"zenoh_port:={free_port()}",
                                 "--log-dir", str(tmp_path / "logs")],
                                cwd=ROOT, capture_output=True, text=True, timeout=90)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"the launch with {path.name} did not end: {str(exc.stdout)[-2000:]}")
    output = result.stdout + result.stderr
    assert result.returncode == 1, output[-3000:]
    line = next((x for x in output.splitlines() if f"model 'statue' link 'link': {part} mesh: " in x), "")
    assert path.name in line and reason in line, output[-3000:]
    assert "respawning 'simulator'" not in output and "signal 11" not in output.lower()


ROBOT = """<robot name="bot"><link name="camera_link"/>
<gazebo reference="camera_link"><sensor name="camera" type="depth"><always_on>true</always_on>
<update_rate>10</update_rate><camera><horizontal_fov>1.0</horizontal_fov>
<image><width>32</width><height>24</height><format>R8G8B8</format></image><clip><near>0.05</near><far>10</far></clip>
</camera><plugin name="c" filename="libgazebo_ros_camera.so"><ros><remapping>camera/image_raw:=camera/rgb</remapping>
<remapping>camera/depth/image_raw:=camera/depth</remapping></ros><camera_name>camera</camera_name></plugin>
</sensor></gazebo></robot>"""


def _shape(link: int, kind: int, size=(), colour=(1.0, 0.0, 0.0), vertices=b"", triangles=b"", uri="") -> dict:
    return {"link": link, "kind": kind, "size": list(size),
            "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"w": 1.0}},
            "color": {"r": colour[0], "g": colour[1], "b": colour[2], "a": 1.0}, "visual": True, "collision": True,
            "mesh_uri": uri, "vertices": vertices, "triangles": triangles}


def test_the_renderer_leaves_out_a_shape_it_cannot_draw_and_draws_the_rest(processes, router):
    """A scene that carries one mesh with a NaN vertex (as a simulator of another version might send):
    that shape is left out and named once on rosout, and the wall beside it is still seen."""
    node = Node("renderer_feeder", connect=[router])
    renderer = processes.start("-m", "nodes.render", name="renderer")
    try:
        wait_until(lambda: "renderer ready" in processes.output(renderer), timeout=60, message="renderer ready")
        rosout: list[str] = []
        node.create_subscription(None, "/rosout", lambda p: rosout.append(msgpack.unpackb(p).get("msg", "")),
                                 delivery=Inline(), message=Raw())
        nan_vertices = np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], "<f4").tobytes()
        scene = msgs.from_dict(msgs.get_type("zenroid_msgs/msg/Scene"), {
            "version": 1, "models": ["bot", "wall"], "namespaces": ["bot", ""], "static_models": [False, True],
            "descriptions": [ROBOT, ""], "links": ["bot::camera_link", "wall::link"], "link_models": [0, 1],
            "shapes": [_shape(1, 1, (0.1, 6, 3), (0.0, 1.0, 0.0)),
                       _shape(1, 4, vertices=nan_vertices, triangles=np.array([[0, 1, 2]], "<u4").tobytes(),
                              uri="/models/statue/meshes/broken.obj")],
            "has_camera_pose": False, "camera_pose": {"orientation": {"w": 1.0}}})
        node.create_publisher(msgs.get_type("zenroid_msgs/msg/Scene"), "/sim/scene", latched=True).publish(scene)
        images = Images(node, "bot/camera")
        frames = node.create_publisher(msgs.get_type("zenroid_msgs/msg/RenderFrame"), "/sim/render/frame")
        wall = [1, 0, 0, 2.05, 0, 1, 0, 0, 0, 0, 1, 0]          # 3x4 row-major: 2.05 m ahead
        camera = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]
        step_no = 0

        def drawn():
            nonlocal step_no
            step_no += 1
            frames.publish(msgs.from_dict(msgs.get_type("zenroid_msgs/msg/RenderFrame"), {
                "stamp": {"sec": step_no}, "step": step_no, "scene_version": 1, "poses": camera + wall,
                "sensors": ["bot::camera"], "lockstep": True}))
            time.sleep(0.1)
            with images.lock:
                return images.latest if {"rgb", "depth"} <= set(images.latest) else None
        wait_until(drawn, timeout=60, message="a camera image of the scene with the bad mesh")
        depth, pixel = centre(images.after(0))
        assert depth == pytest.approx(2.0, abs=0.01) and pixel[1] > 100 and pixel[0] + pixel[2] < 30, (depth, pixel)
        for _ in range(3):
            drawn()
        warnings = [m for m in rosout if "broken.obj" in m]
        assert len(warnings) == 1 and "model 'wall' link 'link'" in warnings[0] and "not finite" in warnings[0], \
            warnings
        assert renderer.poll() is None
    except BaseException:
        print("--- renderer:\n" + processes.output(renderer)[-3000:])
        raise
    finally:
        node.destroy()


BOT = """<robot name="mesh_bot">
  <link name="base">
    <inertial><mass value="50"/><inertia ixx="10" iyy="10" izz="10" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://mesh_bot_description/meshes/body.obj"/></geometry></visual>
    <collision><geometry><mesh filename="package://mesh_bot_description/meshes/body.stl"/></geometry></collision>
  </link>
  <link name="head">
    <inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://mesh_bot_description/meshes/head.dae" scale="0.5 0.5 0.5"/>
    </geometry></visual>
  </link>
  <joint name="neck" type="fixed"><parent link="base"/><child link="head"/><origin xyz="0 0 2.5"/></joint>
</robot>"""


def test_a_package_robot_with_stl_dae_and_obj_meshes_is_seen_in_colour_and_cached(processes, router, tmp_path):
    """A description package found through ROS_PACKAGE_PATH, its URDF sent over the wire with package://
    meshes in three formats: spawned, seen by the camera in the OBJ's MTL colour; a second simulator takes
    its converted meshes from the cache."""
    package = tmp_path / "pkgs" / "mesh_bot_description"
    (package / "package.xml").parent.mkdir(parents=True)
    (package / "package.xml").write_text("<package format='3'><name>mesh_bot_description</name><version>1.0.0"
                                         "</version><description>x</description><maintainer email='a@b.c'>a"
                                         "</maintainer><license>MIT</license></package>")
    M.obj(package / "meshes" / "body.obj", M.CUBE_VERTICES * [1, 2, 4], rgb=PAINT)
    M.binary_stl(package / "meshes" / "body.stl", size=(1, 2, 4))
    M.dae(package / "meshes" / "head.dae", M.CUBE_VERTICES * 1000, unit=0.001, up="Y_UP")
    cache = tmp_path / "cache"
    env = {"ROS_PACKAGE_PATH": str(tmp_path / "pkgs"), "ZENROID_MESH_CACHE": str(cache)}
    node = Node("mesh_bot_test", connect=[router])
    try:
        for run in range(2):
            sim = processes.start("-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml"),
                                  "--param", "world:=empty.world", "--param", "mode:=lockstep",
                                  "--param", "paused:=true", "--param",
                                  "entities:=[{name: humanoid, file: humanoid, z: 0.93}]", name=f"sim{run}", env=env)
            wait_ready(node, processes, sim)
            camera = call(node, GetEntityState, "/sim/get_entity_state",
                          GetEntityState.Request(name="humanoid::camera_link")).state.pose.position.x
            reply = call(node, SpawnEntity, "/sim/spawn_entity", msgs.from_dict(SpawnEntity.Request, {
                "name": "mesh_bot", "xml": BOT, "robot_namespace": "mesh_bot",
                "initial_pose": {"position": {"x": camera + 2.5, "y": 0.0, "z": 2.01}}}), timeout=60)
            assert reply.success, reply.status_message + processes.output(sim)[-2000:]
            expected = "3 mesh(es) checked and converted, " + ("0" if run == 0 else "3") + " from the mesh cache"
            wait_until(lambda s=sim, e=expected: e in processes.output(s), timeout=10, message=expected)
            if run == 0:
                renderer = processes.start("-m", "nodes.render", name="renderer", env=env)
                images = Images(node)
                wait_until(lambda r=renderer: "sensors humanoid::camera" in processes.output(r), timeout=60,
                           message="the renderer's scene with the camera")
                step(node, 300)
                depth, pixel = centre(images.after(0.2))
                assert depth == pytest.approx(2.0, abs=0.05)
                assert pixel / pixel.sum() == pytest.approx(np.array(PAINT) / sum(PAINT), abs=0.03), pixel
                renderer.terminate()
                renderer.wait(timeout=30)
            sim.terminate()
            sim.wait(timeout=30)
    finally:
        node.destroy()


def test_an_unknown_collision_mesh_mode_is_a_configuration_error(processes, router):
    sim = processes.start("-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml"),
                          "--param", "collision_mesh:=hull,left_hand=convex", name="sim")
    wait_until(lambda: sim.poll() is not None, timeout=60, message="the simulator to refuse its configuration")
    assert sim.returncode == 2
    assert "collision_mesh: 'convex' is not one of hull, decompose, exact" in processes.output(sim)


def test_the_viewer_records_a_package_robots_meshes_in_their_colours(processes, router, tmp_path):
    """A robot_description whose visuals are package:// OBJ (MTL colour) and DAE (millimetres, y up) meshes:
    the viewer's recording has each as a Mesh3D, in its file's colour, in metres."""
    import signal

    from tests.support.rrd import load

    package = tmp_path / "pkgs" / "mesh_bot_description"
    package.mkdir(parents=True)
    (package / "package.xml").write_text("<package format='3'><name>mesh_bot_description</name></package>")
    M.obj(package / "meshes" / "body.obj", M.CUBE_VERTICES * [1, 2, 4], rgb=PAINT)
    M.binary_stl(package / "meshes" / "body.stl", size=(1, 2, 4))
    M.dae(package / "meshes" / "head.dae", M.CUBE_VERTICES * [1000, 2000, 3000], unit=0.001, up="Y_UP",
          rgb=(0.9, 0.1, 0.1))
    rrd = tmp_path / "meshes.rrd"
    viz = processes.start("-m", "nodes.viz", "--save", str(rrd), "--robots", "mesh_bot", "--param", "ground:=false",
                          name="viz", env={"ROS_PACKAGE_PATH": str(tmp_path / "pkgs")})
    wait_until(lambda: "showing robot 'mesh_bot'" in processes.output(viz), 30, message="the visualiser")
    String = msgs.get_type("std_msgs/msg/String")
    node = Node("mesh_viz_test", connect=[router])
    try:
        description = node.create_publisher(String, "/mesh_bot/robot_description")
        time.sleep(1.0)   # the visualiser's subscription meets ours through the router
        description.publish(String(data=BOT))
        wait_until(lambda: "model 'mesh_bot' with 2 links, 2 visuals" in processes.output(viz), 30,
                   message="the mesh robot in the visualiser")
    finally:
        node.destroy()
    viz.send_signal(signal.SIGINT)
    viz.wait(20)
    assert "not drawn" not in processes.output(viz)
    data = load(rrd)
    body = {**data["world/mesh_bot/links/base/visual_0"].static,
            **{k: v for row in data["world/mesh_bot/links/base/visual_0"].rows for k, v in row.items()}}
    head = {**data["world/mesh_bot/links/head/visual_0"].static,
            **{k: v for row in data["world/mesh_bot/links/head/visual_0"].rows for k, v in row.items()}}
    paint = int("".join(f"{round(c * 255):02x}" for c in PAINT) + "ff", 16)
    assert set(body["Mesh3D:vertex_colors"]) == {paint}
    assert np.ptp(np.asarray(body["Mesh3D:vertex_positions"]), axis=0) == pytest.approx([1, 2, 4], abs=1e-5)
    # the DAE: millimetres to metres, y up to z up (y and z swap), then the URDF's scale of 0.5
    assert np.ptp(np.asarray(head["Mesh3D:vertex_positions"]), axis=0) == pytest.approx([0.5, 1.5, 1.0], abs=1e-5)
    assert set(head["Mesh3D:vertex_colors"]) == {0xE61A1AFF}


def test_the_camera_sees_example_robot_datas_g1_in_its_colours(processes, router, tmp_path):
    """Unitree's G1 (51 STL meshes through package://example-robot-data) spawned over the wire 2 m ahead of
    the humanoid's camera: the image's centre is the G1's grey, at the G1's depth. Its meshes, not in the
    mesh cache yet, are converted beside the physics: the simulator answers other requests meanwhile."""
    from nodes.urdf.paths import PathError, package_root

    try:
        root, _ = package_root("example-robot-data")
    except PathError:
        pytest.skip("example-robot-data is not installed (pip install example-robot-data)")
    urdf = (root / "robots" / "g1_description" / "urdf" / "g1_29dof_rev_1_0.urdf").read_text()
    sim = processes.start("-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml"),
                          "--param", "world:=empty.world", "--param", "mode:=lockstep", "--param", "paused:=true",
                          "--param", "entities:=[{name: humanoid, file: humanoid, z: 0.93}]", name="sim",
                          env={"ZENROID_MESH_CACHE": str(tmp_path / "cold_cache")})
    # the renderer reads big meshes by reference, from the simulator's cache
    renderer = processes.start("-m", "nodes.render", name="renderer", env={"ZENROID_MESH_CACHE": str(tmp_path / "cold_cache")})
    node = Node("g1_camera_test", connect=[router])
    try:
        wait_ready(node, processes, sim)
        images = Images(node)
        camera = call(node, GetEntityState, "/sim/get_entity_state",
                      GetEntityState.Request(name="humanoid::camera_link")).state.pose.position
        replies = []
        spawning = threading.Thread(target=lambda: replies.append(call(
            node, SpawnEntity, "/sim/spawn_entity", msgs.from_dict(SpawnEntity.Request, {
                "name": "g1", "xml": urdf, "robot_namespace": "g1",
                "initial_pose": {"position": {"x": camera.x + 2.0, "y": 0.0, "z": camera.z - 0.3},
                                 "orientation": {"z": 1.0, "w": 0.0}}}), timeout=120)))   # facing the camera
        spawning.start()
        wait_until(lambda: "'g1': reading its meshes beside the physics" in processes.output(sim), timeout=60,
                   message="the G1's meshes being read")
        # seconds of conversion ahead (a cold cache): the stepping thread serves another request meanwhile
        assert call(node, GetEntityState, "/sim/get_entity_state",
                    GetEntityState.Request(name="humanoid::camera_link"), timeout=10).success
        assert not replies, "the spawn was answered first: its meshes were converted on the stepping thread"
        spawning.join(120)
        (reply,) = replies
        assert reply.success, reply.status_message
        assert "0 from the mesh cache" in processes.output(sim)
        wait_until(lambda: re.search(r"scene \d+: 3 models", processes.output(renderer)), timeout=60,
                   message="the renderer's scene with the G1 (over the payload limit: its big meshes by reference)")
        step(node, 100)
        depth, pixel = centre(images.after(0.05))
        assert 1.6 < depth < 2.4, depth                  # the G1's torso, not the horizon
        assert abs(pixel[0] - pixel[1]) < 15 and abs(pixel[1] - pixel[2]) < 15 and pixel.max() > 20, pixel
        assert "not drawn" not in processes.output(renderer)
    except BaseException:
        print("--- simulator:\n" + processes.output(sim)[-3000:] + "\n--- renderer:\n" + processes.output(renderer)[-3000:])
        raise
    finally:
        node.destroy()
