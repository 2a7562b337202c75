"""Rendered frames as message dicts (nodes/render/payloads.py) go through both of our codecs (msgpack, CDR) and
come back with the layout ROS tools expect: steps, point steps, field offsets, data lengths."""

from __future__ import annotations

import math

import numpy as np
import pytest

import msgs
from msgs import cdr
from nodes.render import payloads
from nodes.render.camera import intrinsics, render_camera
from nodes.render.geometry import Shape
from nodes.render.lidar import render_ray
from nodes.render.raycast import RayScene
from nodes.urdf.rendered_sensors import CameraSpec, RayAxis, RaySpec

STAMP = {"sec": 12, "nanosec": 345}
NONFINITE = msgs.Limits(allow_nonfinite=True)   # REP 117 ranges are +-inf


def both_ways(type_name: str, payload: dict, limits: msgs.Limits = msgs.DEFAULT_LIMITS) -> tuple[dict, dict]:
    """The payload after a msgpack round trip (as the nodes publish it: the type's packer) and a CDR one."""
    cls = msgs.get_type(type_name)
    packed = msgs.packer(type_name)(**payload)
    via_msgpack = msgs.to_dict(msgs.decode(cls, packed, limits))
    assert msgs.to_dict(msgs.from_dict(cls, payload, limits)) == via_msgpack
    return via_msgpack, cdr.decode(type_name, cdr.encode(type_name, payload))


@pytest.fixture(scope="module")
def scene() -> RayScene:
    wall = Shape("box", (0.1, 4.0, 4.0), np.eye(4), (0.9, 0.6, 0.3, 1.0), name="wall")
    ball = Shape("sphere", (0.3,), np.eye(4), (0.1, 0.2, 0.9, 1.0), name="ball")
    scene = RayScene(["wall", "ball"], [(0, wall), (1, ball)])
    poses = np.stack([np.eye(4), np.eye(4)])
    poses[0, :3, 3] = (3.0, 0.0, 0.0)
    poses[1, :3, 3] = (1.5, 0.4, 0.0)
    scene.update(poses)
    return scene


@pytest.mark.parametrize("encoding", ["rgb8", "bgr8", "mono8"])
def test_colour_images_round_trip(scene: RayScene, encoding: str) -> None:
    spec = CameraSpec(width=40, height=30, encoding=encoding)
    picture = render_camera(scene, spec, np.eye(4))
    payload = payloads.image(STAMP, "camera_optical", picture.color, encoding)
    channels = 1 if encoding == "mono8" else 3
    assert payload["step"] == 40 * channels and len(payload["data"]) == 40 * 30 * channels
    for decoded in both_ways("sensor_msgs/msg/Image", payload):
        assert (decoded["height"], decoded["width"], decoded["encoding"], decoded["step"]) == (30, 40, encoding,
                                                                                           40 * channels)
        assert decoded["header"] == {"stamp": STAMP, "frame_id": "camera_optical"}
        assert decoded["is_bigendian"] == 0
        assert np.array_equal(np.frombuffer(decoded["data"], np.uint8).reshape(picture.color.shape), picture.color)


def test_depth_image_and_camera_info_round_trip(scene: RayScene) -> None:
    spec = CameraSpec(horizontal_fov=1.1, width=40, height=30, depth=True, near=0.2, far=2.0)
    picture = render_camera(scene, spec, np.eye(4))
    assert np.isinf(picture.depth).any() and np.isfinite(picture.depth).any()   # the wall is beyond far
    payload = payloads.image(STAMP, "camera_optical", picture.depth, "32FC1")
    for decoded in both_ways("sensor_msgs/msg/Image", payload):
        assert decoded["step"] == 160 and len(decoded["data"]) == 40 * 30 * 4
        depth = np.frombuffer(decoded["data"], "<f4").reshape(30, 40)
        assert depth.tobytes() == picture.depth.tobytes()
    f, cx, cy = intrinsics(spec)
    for info in both_ways("sensor_msgs/msg/CameraInfo", payloads.camera_info(STAMP, "camera_optical", spec)):
        assert info["k"] == pytest.approx([f, 0, cx, 0, f, cy, 0, 0, 1])
        assert info["p"] == pytest.approx([f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0])
        assert info["r"] == [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        assert info["d"] == [0.0] * 5 and info["distortion_model"] == "plumb_bob"
        assert (info["width"], info["height"], info["binning_x"], info["binning_y"]) == (40, 30, 0, 0)
        assert info["roi"] == {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False}
    assert f == pytest.approx(40 / (2 * math.tan(0.55)))


def test_organised_camera_points_round_trip(scene: RayScene) -> None:
    spec = CameraSpec(width=40, height=30, depth=True, encoding="bgr8", far=2.0)
    picture = render_camera(scene, spec, np.eye(4))
    payload = payloads.camera_points(STAMP, "camera_optical", picture.points, picture.rgb)
    for cloud in both_ways("sensor_msgs/msg/PointCloud2", payload):
        assert (cloud["height"], cloud["width"], cloud["point_step"], cloud["row_step"]) == (30, 40, 32, 32 * 40)
        assert [(f["name"], f["offset"], f["datatype"], f["count"]) for f in cloud["fields"]] == [
            ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("rgb", 16, 7, 1)]
        assert cloud["is_dense"] is False and cloud["is_bigendian"] is False
        assert len(cloud["data"]) == 30 * 40 * 32
        words = np.frombuffer(cloud["data"], "<f4").reshape(30, 40, 8)
        assert words[..., :3].tobytes() == picture.points.tobytes()     # NaN where no depth, bit for bit
        rgb = np.frombuffer(cloud["data"], "<u4").reshape(30, 40, 8)[..., 4]
        r, g, b = (rgb >> 16) & 255, (rgb >> 8) & 255, rgb & 255
        assert np.array_equal(np.stack([r, g, b], axis=-1), picture.color[..., ::-1])
        assert np.all(rgb >> 24 == 0)
    assert np.isnan(picture.points).any() and np.isfinite(picture.points).any()


def test_lidar_points_round_trip(scene: RayScene) -> None:
    spec = RaySpec(horizontal=RayAxis(200, 1.0, -0.8, 0.8), vertical=RayAxis(8, 1.0, -0.2, 0.2),
                   range_max=10.0, range_resolution=0.0)
    scan = render_ray(scene, spec, np.eye(4))
    xyz, intensity, ring = scan.points()
    payload = payloads.lidar_points(STAMP, "lidar", xyz, intensity, ring)
    for cloud in both_ways("sensor_msgs/msg/PointCloud2", payload):
        count = len(xyz)
        assert (cloud["height"], cloud["width"], cloud["point_step"], cloud["row_step"]) == (1, count, 20, 20 * count)
        assert [(f["name"], f["offset"], f["datatype"]) for f in cloud["fields"]] == [
            ("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 12, 7), ("ring", 16, 4)]
        assert cloud["is_dense"] is True and len(cloud["data"]) == 20 * count
        points = np.frombuffer(cloud["data"], payloads.LIDAR_POINT)
        assert np.array_equal(np.stack([points["x"], points["y"], points["z"]], axis=1), xyz)
        assert np.array_equal(points["intensity"], intensity) and np.array_equal(points["ring"], ring)


def test_laser_scan_round_trips_with_infinities(scene: RayScene) -> None:
    spec = RaySpec(horizontal=RayAxis(720, 1.0, -math.pi / 2, math.pi / 2), range_max=2.5, output="scan")
    scan = render_ray(scene, spec, np.eye(4))
    payload = payloads.laser_scan(STAMP, "laser", spec, scan.ranges, scan.intensities, 0.05)
    assert np.isinf(payload["ranges"]).any()
    for decoded in both_ways("sensor_msgs/msg/LaserScan", payload, NONFINITE):
        assert decoded["angle_min"] == pytest.approx(-math.pi / 2) and decoded["angle_max"] == pytest.approx(math.pi / 2)
        assert decoded["angle_increment"] == pytest.approx(math.pi / 719)
        assert (decoded["range_min"], decoded["range_max"], decoded["time_increment"]) == pytest.approx((0.1, 2.5, 0))
        assert decoded["scan_time"] == pytest.approx(0.05)
        assert np.array_equal(np.array(decoded["ranges"], np.float32), scan.ranges[0])
        assert np.array_equal(np.array(decoded["intensities"], np.float32), scan.intensities[0])


def test_laser_scan_of_a_lidar_takes_the_middle_ring(scene: RayScene) -> None:
    spec = RaySpec(horizontal=RayAxis(50, 1.0, -0.5, 0.5), vertical=RayAxis(5, 1.0, -0.3, 0.3))
    scan = render_ray(scene, spec, np.eye(4))
    payload = payloads.laser_scan(STAMP, "lidar", spec, scan.ranges, scan.intensities, 0.1)
    assert payload["ranges"] == scan.ranges[2].tolist()
    with pytest.raises(ValueError, match="50 columns"):
        payloads.laser_scan(STAMP, "lidar", spec, scan.ranges[0, :10], scan.intensities[0, :10], 0.1)


def test_bad_images_are_refused() -> None:
    with pytest.raises(ValueError, match="not one of"):
        payloads.image(STAMP, "c", np.zeros((2, 2, 3), np.uint8), "yuv422")
    with pytest.raises(ValueError, match=r"a rgb8 image must be \(H, W, 3\)"):
        payloads.image(STAMP, "c", np.zeros((2, 2), np.uint8), "rgb8")
