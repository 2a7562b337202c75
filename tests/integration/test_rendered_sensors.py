"""The humanoid's camera, depth camera, laser and lidar, rendered on the CPU by the renderer process from the
simulator's frames (real simulator, real renderer, real Zenoh), in empty.world with a wall spawned ahead:

- the wall 2 m ahead: the depth at the image centre is the camera's distance to it (± 1 cm), the centre pixel
  has the wall's colour, the scan's range at angle 0 is right within its resolution, the lidar's points lie
  on the wall's plane;
- the wall moved 1 m further: every reading grows by 1.00 ± 0.02 m;
- nothing in view: +inf depth, +inf (out of range) scan values, no lidar returns ahead;
- CameraInfo agrees with the field of view and the size; every message carries the frame's sim time and its
  sensor's optical or link frame;
- bad sensor declarations are refused at spawn, naming the sensor and the field, and the simulator runs on.

The shipped humanoid's range noise (1 cm) is taken out of the robot used here, so the geometry is exact."""

from __future__ import annotations

import math
import re
import threading
import time
from pathlib import Path

import msgpack
import numpy as np
import pytest

import msgs
from nodes.core import Node
from nodes.core.delivery import Inline, Raw
from nodes.sim.interfaces import DeleteEntity, GetEntityState, SetEntityState, SpawnEntity, StepSimulation
from tests.conftest import wait_until
from tests.integration.test_sim_helpers import call, start_sim, wait_ready

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
KEYS = ("humanoid/camera/rgb", "humanoid/camera/depth", "humanoid/camera/camera_info", "humanoid/scan",
        "humanoid/lidar/points")
WALL_COLOUR = (0.2, 0.7, 0.3)


def wall_sdf() -> str:
    r, g, b = WALL_COLOUR
    return (f"<?xml version='1.0'?><sdf version='1.7'><model name='wall'><static>true</static><link name='link'>"
            f"<collision name='c'><geometry><box><size>0.1 6 3</size></box></geometry></collision>"
            f"<visual name='v'><geometry><box><size>0.1 6 3</size></box></geometry>"
            f"<material><diffuse>{r} {g} {b} 1</diffuse></material></visual></link></model></sdf>")


class Latest:
    """The newest message of each key (decoded with msgpack alone), by sim time."""

    def __init__(self, node: Node) -> None:
        self.lock = threading.Lock()
        self.messages: dict[str, dict] = {}
        for key in KEYS:
            node.create_subscription(None, f"/{key}", self._on, delivery=Inline(), message=Raw(with_key=True))

    def _on(self, payload: bytes, key: str) -> None:
        msg = msgpack.unpackb(payload)
        with self.lock:
            self.messages[key] = msg

    def after(self, t: float) -> dict[str, dict]:
        """Every key's newest message once all of them show a state later than sim time ``t``."""
        def ready():
            with self.lock:
                ok = all(k in self.messages and stamp(self.messages[k]) > t for k in KEYS)
                return dict(self.messages) if ok else None
        return wait_until(ready, timeout=60, message=f"every sensor past sim time {t:.2f}")


def stamp(msg: dict) -> float:
    return msg["header"]["stamp"]["sec"] + msg["header"]["stamp"]["nanosec"] * 1e-9


def readings(messages: dict[str, dict]) -> dict[str, object]:
    depth_msg, rgb_msg = messages["humanoid/camera/depth"], messages["humanoid/camera/rgb"]
    h, w = depth_msg["height"], depth_msg["width"]
    depth = np.frombuffer(depth_msg["data"], np.float32).reshape(h, w)
    rgb = np.frombuffer(rgb_msg["data"], np.uint8).reshape(h, w, 3)
    scan = messages["humanoid/scan"]
    angles = scan["angle_min"] + scan["angle_increment"] * np.arange(len(scan["ranges"]))
    ahead = int(np.argmin(np.abs(angles)))
    cloud = messages["humanoid/lidar/points"]
    points = np.frombuffer(cloud["data"], dtype=np.dtype({"names": ["x", "y", "z", "intensity", "ring"],
                                                          "formats": ["<f4", "<f4", "<f4", "<f4", "<u2"],
                                                          "offsets": [0, 4, 8, 12, 16],
                                                          "itemsize": cloud["point_step"]}))
    front = points[(np.abs(points["y"]) < 0.5) & (np.abs(points["z"]) < 0.3) & (points["x"] > 0)]   # not the floor
    return {"depth": float(depth[h // 2, w // 2]), "pixel": rgb[h // 2, w // 2].astype(float),
            "scan": scan["ranges"][ahead], "scan_angle": float(angles[ahead]), "lidar_x": front["x"],
            "rgb": rgb_msg, "depth_msg": depth_msg}


def link_x(node: Node, link: str) -> float:
    response = call(node, GetEntityState, "/sim/get_entity_state", GetEntityState.Request(name=f"humanoid::{link}"))
    assert response.success, link
    return response.state.pose.position.x


def step(node: Node, steps: int) -> None:
    response = call(node, StepSimulation, "/sim/step", StepSimulation.Request(steps=steps), timeout=120)
    assert response.success, response.status_message


def test_a_wall_in_view_moved_and_gone_and_bad_declarations(processes, router, tmp_path):
    xml = (ROOT / "robots" / "humanoid.urdf").read_text()
    xml = re.sub(r"<noise><type>gaussian</type><mean>0</mean><stddev>0\.01</stddev></noise>", "", xml)
    (tmp_path / "robot.urdf").write_text(xml)
    sim = start_sim(processes, "world:=empty.world", "mode:=lockstep", "paused:=true",
                    f"entities:=[{{name: humanoid, file: {tmp_path / 'robot.urdf'}, z: 0.93}}]")
    renderer = processes.start("-m", "nodes.render", name="renderer")
    node = Node("rendered_sensors_test", connect=[router])
    try:
        wait_ready(node, processes, sim)
        latest = Latest(node)
        wait_until(lambda: "sensors humanoid::camera" in processes.output(renderer), timeout=60,
                   message="the renderer's scene with the sensors")
        step(node, 1000)   # standing still (holding position), at 1 s of sim time
        camera_x, laser_x, lidar_x = (link_x(node, link) for link in ("camera_link", "laser_link", "lidar_link"))

        # nothing in view: the empty world's horizon
        empty = readings(latest.after(0.85))
        assert empty["depth"] == math.inf
        assert empty["scan"] == math.inf and empty["lidar_x"].size == 0
        info = latest.messages["humanoid/camera/camera_info"]
        f = 320 / (2 * math.tan(1.047 / 2))
        assert (info["width"], info["height"], info["distortion_model"]) == (320, 240, "plumb_bob")
        assert info["k"] == pytest.approx([f, 0, 160.5, 0, f, 120.5, 0, 0, 1])
        assert info["p"][:3] == pytest.approx([f, 0, 160.5])
        frames = {key: latest.messages[key]["header"]["frame_id"] for key in KEYS}
        assert frames == {"humanoid/camera/rgb": "camera_optical_frame", "humanoid/camera/depth": "camera_optical_frame",
                          "humanoid/camera/camera_info": "camera_optical_frame", "humanoid/scan": "laser_link",
                          "humanoid/lidar/points": "lidar_link"}
        rgb, depth = latest.messages["humanoid/camera/rgb"], latest.messages["humanoid/camera/depth"]
        assert (rgb["encoding"], rgb["step"], len(rgb["data"])) == ("rgb8", 960, 320 * 240 * 3)
        assert (depth["encoding"], depth["step"], len(depth["data"])) == ("32FC1", 1280, 320 * 240 * 4)

        # a wall whose front face is 2 m ahead of the camera
        front = camera_x + 2.0
        spawned = call(node, SpawnEntity, "/sim/spawn_entity", msgs.from_dict(SpawnEntity.Request, {
            "name": "wall", "xml": wall_sdf(), "initial_pose": {"position": {"x": front + 0.05, "y": 0.0, "z": 1.5}}}))
        assert spawned.success, spawned.status_message
        # a phase is 0.3 s: frames are due at the start of a control period, so the last one of a phase
        # of n steps is one sensor period before its end (the 10 Hz lidar's: 0.2 s after the phase starts)
        step(node, 300)
        seen = readings(latest.after(1.1))
        assert seen["depth"] == pytest.approx(2.0, abs=0.01)
        pixel = seen["pixel"]
        assert pixel / pixel.sum() == pytest.approx(np.array(WALL_COLOUR) / sum(WALL_COLOUR), abs=0.03), pixel
        assert seen["scan"] == pytest.approx((front - laser_x) / math.cos(seen["scan_angle"]), abs=0.01)
        assert seen["lidar_x"].size > 100
        assert np.all(np.abs(seen["lidar_x"] - (front - lidar_x)) < 0.02)   # rings tilt: x is the plane's

        # moved 1 m further
        moved = call(node, SetEntityState, "/sim/set_entity_state", msgs.from_dict(SetEntityState.Request, {
            "state": {"name": "wall", "pose": {"position": {"x": front + 1.05, "y": 0.0, "z": 1.5},
                                               "orientation": {"w": 1.0}}}}))
        assert moved.success
        step(node, 300)
        further = readings(latest.after(1.4))
        assert further["depth"] - seen["depth"] == pytest.approx(1.0, abs=0.02)
        assert further["scan"] - seen["scan"] == pytest.approx(1.0, abs=0.02)
        assert np.median(further["lidar_x"]) - np.median(seen["lidar_x"]) == pytest.approx(1.0, abs=0.02)
        # and back to nothing
        assert call(node, DeleteEntity, "/sim/delete_entity", DeleteEntity.Request(name="wall")).success
        step(node, 300)
        gone = readings(latest.after(1.7))
        assert gone["depth"] == math.inf and gone["scan"] == math.inf and gone["lidar_x"].size == 0

        # bad declarations: refused at spawn with the sensor and the field named; the simulator runs on
        bad = {
            "pixel cap": ("<width>320</width><height>240</height>", "<width>4000</width><height>3000</height>",
                          r"sensor 'camera'.*12000000 pixels, over the cap"),
            "fov": ("<horizontal_fov>1.047</horizontal_fov>", "<horizontal_fov>3.5</horizontal_fov>",
                    r"sensor 'camera'.*<horizontal_fov> 3.5: must be in \(0, pi\)"),
            "clip": ("<near>0.05</near><far>10</far>", "<near>5</near><far>1</far>",
                     r"sensor 'camera'.*<clip> near 5 far 1"),
            "format": ("<format>R8G8B8</format>", "<format>YUV422</format>",
                       r"sensor 'camera'.*<format> 'YUV422' is not one of"),
            "rate": ("<update_rate>30</update_rate>", "<update_rate>5000</update_rate>",
                     r"sensor 'camera'.*<update_rate> 5000: over the physics rate"),
        }
        for case, (good, wrong, reason) in bad.items():
            assert good in xml, case
            reply = call(node, SpawnEntity, "/sim/spawn_entity", SpawnEntity.Request(
                name=f"bad_{case.replace(' ', '_')}", xml=xml.replace(good, wrong, 1), robot_namespace=f"bad{len(case)}"))
            assert not reply.success and re.search(reason, reply.status_message), (case, reply.status_message)
        step(node, 50)
        assert sim.poll() is None and renderer.poll() is None
    except BaseException:
        print("--- simulator:\n" + processes.output(sim)[-3000:] + "\n--- renderer:\n" + processes.output(renderer)[-3000:])
        raise
    finally:
        node.destroy()


def test_images_and_scans_recorded_by_zenroid_bag_are_read_by_rosbags_and_played_back(processes, router, tmp_path):
    """``zenroid bag record humanoid/camera/rgb humanoid/scan humanoid/joint_states``: rosbags (an independent
    reader) decodes the Image and the LaserScan (its +inf ranges kept), and ``zenroid bag play`` publishes
    them again."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    sim = start_sim(processes, "world:=simple_lab.world", "mode:=lockstep", "paused:=true",
                    "entities:=[{name: humanoid, file: humanoid, z: 0.93}]")
    renderer = processes.start("-m", "nodes.render", name="renderer")
    node = Node("rendered_bag_test", connect=[router])
    bag = tmp_path / "camera_bag"
    try:
        wait_ready(node, processes, sim)
        wait_until(lambda: "sensors humanoid::camera" in processes.output(renderer), timeout=60,
                   message="the renderer's scene with the sensors")
        recorder = processes.start("-m", "nodes.tools", "bag", "record", "humanoid/camera/rgb", "humanoid/scan",
                                   "-o", str(bag), "--quiet", name="recorder")
        wait_until(lambda: "Recording" in processes.output(recorder), timeout=30, message="the recorder ready")
        step(node, 1000)
        time.sleep(0.5)           # the last frames on their way to the recorder
        recorder.send_signal(2)   # Ctrl-C, as a person stops it
        assert recorder.wait(30) == 0, processes.output(recorder)
        store = get_typestore(Stores.ROS2_JAZZY)
        images, scans = [], []
        with AnyReader([bag], default_typestore=store) as reader:
            for connection, _, raw in reader.messages():
                message = reader.deserialize(raw, connection.msgtype)
                (images if connection.msgtype == "sensor_msgs/msg/Image" else scans).append(message)
        assert len(images) >= 25 and len(scans) >= 15, (len(images), len(scans))
        image = images[-1]
        assert (image.width, image.height, image.encoding, len(image.data)) == (320, 240, "rgb8", 320 * 240 * 3)
        assert np.asarray(image.data).std() > 5   # the lab, not a blank frame
        assert len(scans[-1].ranges) == 720 and scans[-1].header.frame_id == "laser_link"

        played: list[dict] = []
        node.create_subscription(None, "/humanoid/camera/rgb", lambda p: played.append(msgpack.unpackb(p)),
                                 delivery=Inline(), message=Raw())
        player = processes.start("-m", "nodes.tools", "bag", "play", str(bag), "-r", "4", "--quiet", name="player")
        assert player.wait(120) == 0, processes.output(player)
        assert len(played) >= 0.9 * len(images)
        assert played[-1]["data"] == bytes(image.data)
    finally:
        node.destroy()


def test_frames_go_out_only_for_the_sensors_somebody_subscribes_to(processes, router):
    """Nobody subscribes to a picture: the simulator sends the renderer no frame (a frame's link poses cost the
    physics thread ~0.3 ms). A subscriber to the scan: frames for the laser alone, and scans at its rate; gone
    again: no frames."""
    sim = start_sim(processes, "world:=empty.world", "mode:=lockstep", "paused:=true",
                    "entities:=[{name: humanoid, file: humanoid, z: 0.93}]")
    renderer = processes.start("-m", "nodes.render", name="renderer")
    node = Node("rendered_on_demand_test", connect=[router])
    frames: list[list[str]] = []
    scans: list[float] = []
    node.create_subscription(None, "/sim/render/frame", lambda p: frames.append(msgpack.unpackb(p)["sensors"]),
                             delivery=Inline(), message=Raw())
    try:
        wait_ready(node, processes, sim)
        wait_until(lambda: "sensors humanoid::camera" in processes.output(renderer), timeout=60,
                   message="the renderer's scene with the sensors")
        step(node, 200)   # the renderer's first answer tells the simulator that nobody watches
        time.sleep(0.3)
        frames.clear()
        step(node, 500)
        time.sleep(0.3)
        assert frames == []
        scan_sub = node.create_subscription(None, "/humanoid/scan", lambda p: scans.append(stamp(msgpack.unpackb(p))),
                                            delivery=Inline(), message=Raw())
        time.sleep(0.5)   # the renderer notices the subscriber and says so (within ~10 ms of Zenoh's matching)
        step(node, 500)   # 0.5 s of sim time: the laser's 20 Hz gives 10 scans
        wait_until(lambda: len(scans) >= 10, timeout=30, message="ten scans")
        assert frames and all(sensors == ["humanoid::laser"] for sensors in frames), frames[:5]
        assert len(frames) == 10 and len(scans) == 10, (len(frames), len(scans))
        node.destroy_entity(scan_sub)
        time.sleep(0.5)
        frames.clear()
        step(node, 500)
        time.sleep(0.3)
        assert frames == []
    except BaseException:
        print("--- simulator:\n" + processes.output(sim)[-3000:] + "\n--- renderer:\n" + processes.output(renderer)[-3000:])
        raise
    finally:
        node.destroy()
