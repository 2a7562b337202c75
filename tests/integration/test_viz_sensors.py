"""The world and the sensors in the viewer's recording (real processes, real Zenoh), fed by this test: a
sim/scene (latched) and sim/link_states as the simulator sends them, the IMU and foot force/torque
broadcasters' messages, and the renderer's camera, depth, lidar and laser messages (synthetic, so the test
needs no simulator or renderer and knows every value). The robot state publisher and the viz feeder give the
humanoid's description, tf and joint_states. Bad images, clouds, scans, scenes and NaN poses are refused on
rosout with the field and the reason, and the viewer keeps running."""

from __future__ import annotations

import itertools
import math
import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import msgs
from msgs.compiled import packb
from nodes.core import Node
from tests.conftest import wait_until
from tests.support.rrd import load

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = ROOT / "robots" / "humanoid.urdf"
ROBOT, CAMERA, RANGES = "world/humanoid/robot", "world/humanoid/cameras/camera", "world/humanoid/ranges"
T = {name: msgs.get_type(name) for name in (
    "zenroid_msgs/msg/Scene", "gazebo_msgs/msg/LinkStates", "sensor_msgs/msg/Imu", "geometry_msgs/msg/WrenchStamped",
    "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo", "sensor_msgs/msg/PointCloud2", "sensor_msgs/msg/LaserScan")}
LIDAR = np.dtype({"names": ["x", "y", "z", "intensity", "ring"], "formats": ["<f4", "<f4", "<f4", "<f4", "<u2"],
                  "offsets": [0, 4, 8, 12, 16], "itemsize": 20})
LIDAR_FIELDS = [{"name": n, "offset": o, "datatype": d, "count": 1}
                for n, o, d in (("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 12, 7), ("ring", 16, 4))]


def pose(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> dict:
    return {"position": {"x": x, "y": y, "z": z}, "orientation": {"w": 1.0}}


def box(link: int, size: list[float], rgba: tuple, kind: int = 1) -> dict:
    return {"link": link, "kind": kind, "size": size, "pose": pose(), "visual": True, "collision": True,
            "color": dict(zip("rgba", rgba, strict=True))}


SCENE = {"version": 3, "models": ["ground_plane", "crate", "ball", "humanoid"],
         "namespaces": ["", "", "", "humanoid"], "static_models": [True, True, False, False],
         "descriptions": ["", "", "", ""],
         "links": ["ground_plane::link", "crate::link", "ball::link", "humanoid::pelvis"], "link_models": [0, 1, 2, 3],
         "shapes": [box(0, [50, 50, 1], (0.8, 0.8, 0.8, 1)), box(1, [0.4, 0.4, 0.4], (0.6, 0.2, 0.6, 1)),
                    box(2, [0.1], (0.95, 0.85, 0.1, 1), kind=3), box(3, [0.3, 0.3, 0.3], (0, 0, 1, 1))],
         "has_camera_pose": True, "camera_pose": pose(-4.5, -4.5, 3.2)}


def stamp(t: float) -> dict:
    return {"sec": int(t), "nanosec": int((t % 1) * 1e9)}


def sensor_messages(t: float) -> dict[str, Any]:
    """One round of every stream at sim time ``t`` (the feeder's clock runs alike; stamps only order rows)."""
    header = {"stamp": stamp(t)}
    rgb = np.zeros((240, 320, 3), np.uint8)
    rgb[:, :160] = [30, 90, 200]
    depth = np.full((240, 320), 2.0, np.float32)
    depth[:20] = np.inf  # REP 117: beyond the far clip
    ring = np.linspace(-math.pi, math.pi, 900, endpoint=False)
    cloud = np.zeros(900, LIDAR)
    cloud["x"], cloud["y"], cloud["z"], cloud["intensity"] = 3 * np.cos(ring), 3 * np.sin(ring), 0.0, np.linspace(0, 1, 900)
    ranges = [1.5] * 700 + [math.inf] * 20
    camera = {**header, "frame_id": "camera_optical_frame"}
    return {
        "sim/link_states": {"name": ["crate::link", "ball::link", "humanoid::pelvis"],
                            "pose": [pose(0, -3, 0.2), pose(1.5 + 0.1 * t, 2.5, 0.1), pose(0, 0, 0.9)],
                            "twist": [{}, {}, {}]},
        "humanoid/imu_sensor_broadcaster/imu": {"header": {**header, "frame_id": "pelvis"},
                                                "angular_velocity": {"y": 0.2}, "linear_acceleration": {"z": 9.81}},
        "humanoid/left_foot_ft_broadcaster/wrench": {"header": {**header, "frame_id": "left_foot"},
                                                     "wrench": {"force": {"z": 170.0}}},
        "humanoid/right_foot_ft_broadcaster/wrench": {"header": {**header, "frame_id": "right_foot"},
                                                      "wrench": {"force": {"z": 150.0}}},
        "humanoid/camera/rgb": {"header": camera, "height": 240, "width": 320, "encoding": "rgb8", "step": 960,
                                "data": rgb.tobytes()},
        "humanoid/camera/camera_info": {"header": camera, "height": 240, "width": 320,
                                        "k": [277.2, 0, 160.5, 0, 277.2, 120.5, 0, 0, 1]},
        "humanoid/camera/depth": {"header": camera, "height": 240, "width": 320, "encoding": "32FC1",
                                  "step": 1280, "data": depth.tobytes()},
        "humanoid/lidar/points": {"header": {**header, "frame_id": "lidar_link"}, "height": 1, "width": 900,
                                  "fields": LIDAR_FIELDS, "point_step": 20, "row_step": 18000,
                                  "data": cloud.tobytes(), "is_dense": True},
        "humanoid/scan": {"header": {**header, "frame_id": "laser_link"}, "angle_min": -1.5708,
                          "angle_max": 1.5708, "angle_increment": 3.1416 / 719, "range_min": 0.1,
                          "range_max": 10.0, "ranges": ranges},
    }


TYPES = {"sim/link_states": "gazebo_msgs/msg/LinkStates", "humanoid/imu_sensor_broadcaster/imu": "sensor_msgs/msg/Imu",
         "humanoid/left_foot_ft_broadcaster/wrench": "geometry_msgs/msg/WrenchStamped",
         "humanoid/right_foot_ft_broadcaster/wrench": "geometry_msgs/msg/WrenchStamped",
         "humanoid/camera/rgb": "sensor_msgs/msg/Image", "humanoid/camera/camera_info": "sensor_msgs/msg/CameraInfo",
         "humanoid/camera/depth": "sensor_msgs/msg/Image", "humanoid/lidar/points": "sensor_msgs/msg/PointCloud2",
         "humanoid/scan": "sensor_msgs/msg/LaserScan"}
NONFINITE = msgs.Limits(allow_nonfinite=True)


class SensorFeed:
    """Publishes sim/scene (latched) and, in a thread at 10 Hz, every stream of ``sensor_messages``, each
    message passed through ``edit(key, fields)`` (a test's bad input)."""

    def __init__(self, router: str, edit: Callable[[str, dict], dict] | None = None) -> None:
        self.node = Node("sensor_feed", connect=[router])
        self.scene = self.node.create_publisher(T["zenroid_msgs/msg/Scene"], "/sim/scene", latched=True)
        self.pubs = {key: self.node.create_publisher(msgs.get_type(t), f"/{key}") for key, t in TYPES.items()}
        self.edit = edit or (lambda key, fields: fields)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def run(self) -> None:
        t = 0.0
        while not self.stop.wait(0.1):
            t += 0.1
            for key, fields in sensor_messages(t).items():
                message = msgs.from_dict(msgs.get_type(TYPES[key]), self.edit(key, fields), NONFINITE)
                # as bytes: our publisher refuses a bad message (msgs.EncodeError), a foreign one may send it
                self.pubs[key].publish_raw(packb(msgs.to_dict(message)))

    def __enter__(self) -> SensorFeed:
        self.scene.publish(msgs.from_dict(T["zenroid_msgs/msg/Scene"], SCENE))
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop.set()
        self.thread.join(5)
        self.node.destroy()


def start_viewer(processes, rrd: Path, *params: str):
    processes.start("-m", "nodes.state_publisher", "--ns", "humanoid", "--param", f"robot_description_file:={HUMANOID}",
                    name="state_publisher")
    viz = processes.start("-m", "nodes.viz", "--save", str(rrd), "--robots", "humanoid", *params, name="viz")
    wait_until(lambda: "saving the recording" in processes.output(viz), 30, message="the viewer to start")
    processes.start("-m", "tests.support.viz_feeder", "--param", "robots:=[humanoid]", name="feeder")
    return viz


def stop(processes, proc) -> str:
    proc.send_signal(signal.SIGINT)
    proc.wait(20)
    return processes.output(proc)


@pytest.mark.slow
def test_world_body_and_rendered_sensors_are_recorded(processes, router: str, tmp_path: Path) -> None:
    rrd = tmp_path / "sensors.rrd"
    viz = start_viewer(processes, rrd)
    with SensorFeed(router):
        wait_until(lambda: "world: scene version 3, 2 models drawn" in processes.output(viz), 30,
                   message="the world in the viewer")
        wait_until(lambda: "23 visuals" in processes.output(viz), 40, message="the robot model in the viewer")
        time.sleep(7.0)
    log = stop(processes, viz)
    assert viz.returncode == 0, log
    assert "humanoid/camera/points" in log and "sensors camera, lidar, laser" in log
    data = load(rrd)

    # The world: the crate (static) and the ball (moving), no ground box, no robot box.
    world = data["world/models"].rows
    last = world[-1]
    assert last["Boxes3D:centers"] == [pytest.approx([0, -3, 0.2])]
    assert last["Boxes3D:colors"] == [0x993399FF]
    balls = [r["Ellipsoids3D:centers"][0][0] for r in world if r["Ellipsoids3D:centers"]]
    assert balls[-1] > balls[0] + 0.2, f"the ball rolled along x: {balls}"
    assert len(world) < 60, f"{len(world)} world rows: at most world_rate (5 Hz) while it moves"

    # Body sensors: the IMU's columns, the feet's arrows (0.17 m and 0.15 m, ending at the feet).
    robot = data[ROBOT]
    accel = robot.column("linear_acceleration:imu_sensor_broadcaster_imu")
    assert accel and accel[-1][1] == pytest.approx([0, 0, 9.81])
    assert robot.column("angular_velocity:imu_sensor_broadcaster_imu")[-1][1] == pytest.approx([0, 0.2, 0])
    arrows = robot.rows[-1]["Arrows3D:vectors"]
    assert sorted(round(v[2], 3) for v in arrows) == [0.15, 0.17]
    for origin, vector in zip(robot.rows[-1]["Arrows3D:origins"], arrows, strict=True):
        assert origin[2] + vector[2] == pytest.approx(0.05, abs=0.05), "the tip at a foot, near the ground"

    # Rendered sensors: a frame at a time (about image_rate, 1 Hz), compressed, in the head's frame.
    camera = data[CAMERA].rows
    assert 3 <= len(camera) <= 12, len(camera)
    assert camera[-1]["EncodedImage:media_type"] == ["image/jpeg"]
    assert camera[-1]["Pinhole:image_from_camera"][0][0] == pytest.approx(277.2)
    assert camera[-1]["Transform3D:translation"][0][2] > 1.2, "the head camera, above the pelvis"
    assert camera[-1]["DepthImage:meter"] == [1000.0], "the depth image in the camera's row"
    ranges = data[RANGES].rows
    assert 3 <= len(ranges) <= 12, len(ranges)
    assert len(ranges[-1]["Points3D:positions"]) == 900 + 700, "the lidar ring and the laser's returns (no inf)"


SPOILED = itertools.count()


def spoil(key: str, fields: dict) -> dict:
    """Every rendered stream malformed: a short image row, a cloud without z, a scan with a wrong number of
    intensities; and every third link_states with a NaN pose (refused by the codec, naming the field)."""
    if key == "humanoid/camera/rgb":
        return {**fields, "step": 100}
    if key == "humanoid/lidar/points":
        return {**fields, "fields": [f for f in fields["fields"] if f["name"] != "z"]}
    if key == "humanoid/scan":
        return {**fields, "intensities": [1.0]}
    if key == "sim/link_states" and next(SPOILED) % 3 == 0:
        return {**fields, "pose": [pose(math.nan), *fields["pose"][1:]]}
    return fields


@pytest.mark.slow
def test_bad_sensor_input_is_reported_and_the_viewer_keeps_running(processes, router: str, tmp_path: Path) -> None:
    rrd = tmp_path / "bad.rrd"
    viz = start_viewer(processes, rrd)
    with SensorFeed(router, spoil) as feed:
        bad_scene = {**SCENE, "version": 4, "shapes": [*SCENE["shapes"], box(9, [1, 1, 1], (1, 0, 0, 1))]}
        wait_until(lambda: "world: scene version 3" in processes.output(viz), 30, message="the first scene")
        feed.scene.publish(msgs.from_dict(T["zenroid_msgs/msg/Scene"], bad_scene))
        reasons = ["]: humanoid/camera/rgb: image skipped: step is 100 bytes, shorter than a row of 320 rgb8 pixels",
                   "]: humanoid/lidar/points: skipped: fields has no 'z'",
                   "]: humanoid/scan: skipped: intensities has 1 entries for 720 ranges",
                   "sim/scene: shapes[4]: link 9 is not one of the 4 links: skipped",
                   "dropped a message on 'sim/link_states': gazebo_msgs/msg/LinkStates: pose[0].position.x"]
        for reason in reasons:
            wait_until(lambda r=reason: r in processes.output(viz), 30, message=reason)
        assert viz.poll() is None, "the viewer died on bad input"
        time.sleep(1.0)
    log = stop(processes, viz)
    assert viz.returncode == 0, log
    data = load(rrd)
    assert data["world/models"].rows[-1]["Boxes3D:centers"], "the good shapes of the bad scene are drawn"
    camera = data[CAMERA].rows
    assert camera and all("DepthImage:buffer" in r and "EncodedImage:blob" not in r for r in camera), \
        "the camera's good depth image is drawn without its bad colour image"
    assert RANGES not in data or not any(r["Points3D:positions"] for r in data[RANGES].rows)
