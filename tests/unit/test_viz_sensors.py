"""The viewer's sensors without processes: images, camera info, clouds, scans, IMU and wrenches in; arrays and
Rerun rows out (saved to a file and read back); bad messages refused with the field and the reason."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun as rr

import msgs
from nodes.viz.blueprint import RobotLayout, build_blueprint
from nodes.viz.clouds import cloud_points, intensity_colors, scan_points
from nodes.viz.images import SensorDataError, color_image, depth_millimetres, image_array, intrinsics
from nodes.viz.scene import RobotScene, parse_model
from nodes.viz.sensors import (
    CameraFrame,
    RenderedSensors,
    camera_entity,
    camera_frame,
    contact_points,
    fallback_k,
    force_arrow,
    imu_columns,
    range_points,
    ranges_entity,
    sensor_part,
    to_world,
)
from tests.support.rrd import record as record_rrd

Image = msgs.get_type("sensor_msgs/msg/Image")
CameraInfo = msgs.get_type("sensor_msgs/msg/CameraInfo")
PointCloud2 = msgs.get_type("sensor_msgs/msg/PointCloud2")
LaserScan = msgs.get_type("sensor_msgs/msg/LaserScan")
Imu = msgs.get_type("sensor_msgs/msg/Imu")
WrenchStamped = msgs.get_type("geometry_msgs/msg/WrenchStamped")
ContactsState = msgs.get_type("gazebo_msgs/msg/ContactsState")
FLOAT32, UINT16 = 7, 4
LIDAR = np.dtype({"names": ["x", "y", "z", "intensity", "ring"], "formats": ["<f4", "<f4", "<f4", "<f4", "<u2"],
                  "offsets": [0, 4, 8, 12, 16], "itemsize": 20})  # the renderer's (Velodyne's) layout


def image(array: np.ndarray, encoding: str, padding: int = 0, **changes: Any) -> Any:
    """An Image of ``array`` (rows padded by ``padding`` bytes), then ``changes`` to its fields."""
    height, width = array.shape[:2]
    row = array.reshape(height, -1).view(np.uint8).reshape(height, -1)
    padded = np.zeros((height, row.shape[1] + padding), np.uint8)
    padded[:, :row.shape[1]] = row
    fields = {"header": {"frame_id": "camera_optical_frame"}, "height": height, "width": width,
              "encoding": encoding, "step": padded.shape[1], "data": padded.tobytes(), **changes}
    return msgs.from_dict(Image, fields)


def lidar_cloud(xyz: np.ndarray, intensity: np.ndarray, **changes: Any) -> Any:
    points = np.zeros(len(xyz), LIDAR)
    points["x"], points["y"], points["z"], points["intensity"] = xyz.T[0], xyz.T[1], xyz.T[2], intensity
    fields = [{"name": n, "offset": o, "datatype": t, "count": 1}
              for n, o, t in (("x", 0, FLOAT32), ("y", 4, FLOAT32), ("z", 8, FLOAT32), ("intensity", 12, FLOAT32),
                              ("ring", 16, UINT16))]
    data = {"header": {"frame_id": "lidar_link"}, "height": 1, "width": len(xyz), "fields": fields,
            "point_step": 20, "row_step": 20 * len(xyz), "data": points.tobytes(), "is_dense": True, **changes}
    return msgs.from_dict(PointCloud2, data)


def scan(ranges: list[float], **changes: Any) -> Any:
    fields = {"header": {"frame_id": "laser_link"}, "angle_min": -math.pi / 2, "angle_max": math.pi / 2,
              "angle_increment": math.pi / (len(ranges) - 1), "range_min": 0.1, "range_max": 10.0,
              "ranges": ranges, **changes}
    return msgs.from_dict(LaserScan, fields, msgs.Limits(allow_nonfinite=True))  # REP 117's +inf


# -- images ------------------------------------------------------------------------------------------------
def test_images_of_every_common_encoding_become_arrays() -> None:
    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    pixels, model = color_image(image(rgb, "rgb8", padding=3))  # rows padded to 12 bytes
    assert model == "RGB" and np.array_equal(pixels, rgb)
    pixels, _ = color_image(image(rgb[..., ::-1].copy(), "bgr8"))
    assert np.array_equal(pixels, rgb), "bgr8 comes out r g b"
    grey, model = color_image(image(np.full((2, 3), 7, np.uint8), "mono8"))
    assert model == "L" and grey.shape == (2, 3)
    wide = image(np.full((2, 3), 0x1234, ">u2"), "mono16", is_bigendian=1)
    assert image_array(wide)[0, 0] == 0x1234 and color_image(wide)[0][0, 0] == 0x12
    depth = np.array([[1.5, np.inf], [-np.inf, np.nan]], np.float32)
    assert depth_millimetres(image(depth, "32FC1")).tolist() == [[1500, 0], [0, 0]], "REP 117: no depth is 0"
    assert depth_millimetres(image(np.array([[900]], np.uint16), "16UC1")).tolist() == [[900]]


@pytest.mark.parametrize(("changes", "reason"), [
    ({"encoding": "yuv422"}, "encoding 'yuv422' is not one of rgb8"),
    ({"step": 5}, "step is 5 bytes, shorter than a row of 3 rgb8 pixels (9)"),
    ({"data": b"\0" * 17}, "data has 17 bytes, step x height is 18"),
    ({"height": 0, "data": b""}, "height x width is 0 x 3"),
])
def test_malformed_images_are_refused_with_the_field_and_reason(changes: dict, reason: str) -> None:
    msg = msgs.from_dict(Image, {**msgs.to_dict(image(np.zeros((2, 3, 3), np.uint8), "rgb8")), **changes})
    with pytest.raises(SensorDataError) as info:
        color_image(msg)
    assert reason in str(info.value)


def test_a_depth_image_is_not_a_colour_image_and_back() -> None:
    with pytest.raises(SensorDataError, match="is a depth image"):
        color_image(image(np.zeros((1, 1), np.float32), "32FC1"))
    with pytest.raises(SensorDataError, match="is not a depth image"):
        depth_millimetres(image(np.zeros((1, 1, 3), np.uint8), "rgb8"))


def test_camera_info_gives_the_pinhole_or_the_reason() -> None:
    info = msgs.from_dict(CameraInfo, {"width": 320, "height": 240, "k": [277.0, 0, 160.5, 0, 277.0, 120.5, 0, 0, 1]})
    k, width, height = intrinsics(info, 320, 240)
    assert k[0, 0] == 277.0 and k[1, 2] == 120.5 and (width, height) == (320, 240)
    with pytest.raises(SensorDataError, match="width x height is 320 x 240 but the image is 640 x 480"):
        intrinsics(info, 640, 480)
    with pytest.raises(SensorDataError, match="fx 0.0, fy 0.0: focal lengths are positive"):
        intrinsics(msgs.from_dict(CameraInfo, {"width": 2, "height": 2}))
    assert fallback_k(320, 240, 1.047)[0, 0] == pytest.approx(320 / (2 * math.tan(1.047 / 2)))


def test_a_camera_frame_draws_what_it_can_and_names_the_rest() -> None:
    info = msgs.from_dict(CameraInfo, {"width": 640, "height": 480, "k": [500.0, 0, 320, 0, 500.0, 240, 0, 0, 1]})
    good = image(np.zeros((240, 320), np.float32), "32FC1")
    bad = msgs.from_dict(Image, {**msgs.to_dict(image(np.zeros((240, 320, 3), np.uint8), "rgb8")), "step": 10})
    frame, problems = camera_frame(bad, good, info, 1.047)
    assert frame is not None and frame.color is None and frame.depth_mm.shape == (240, 320)
    assert [p[0] for p in problems] == ["image", "camera_info"]
    assert "image skipped: step is 10 bytes" in problems[0][1]
    assert "but the image is 320 x 240: the frustum comes from the URDF's field of view" in problems[1][1]
    assert frame.k[0, 0] == pytest.approx(fallback_k(320, 240, 1.047)[0, 0])
    assert camera_frame(bad, None, None, 1.047)[0] is None


# -- clouds and scans ------------------------------------------------------------------------------------
def test_a_lidar_cloud_gives_its_finite_points_and_intensities() -> None:
    xyz = np.array([[1, 0, 0], [np.nan, 0, 0], [0, 2, 0.5]], np.float32)
    points, intensity, rgb = cloud_points(lidar_cloud(xyz, np.array([0.2, 0.5, 0.9], np.float32)))
    assert points.tolist() == [[1, 0, 0], [0, 2, 0.5]] and intensity.tolist() == pytest.approx([0.2, 0.9])
    assert rgb is None
    many = lidar_cloud(np.ones((1000, 3), np.float32), np.zeros(1000, np.float32))
    assert len(cloud_points(many, max_points=100)[0]) == 100, "every k-th point beyond the cap"
    colors = intensity_colors(np.array([0.0, 0.5, 1.0]))
    assert colors[0].tolist() == [0, 0, 255] and colors[-1].tolist() == [255, 0, 0], "RViz's rainbow"


def test_a_camera_cloud_gives_its_packed_colours() -> None:
    cloud = np.zeros((1, 2, 8), "<f4")  # gazebo_ros' depth camera layout: x y z at 0, 4, 8; rgb at 16
    cloud[0, :, :3] = [[1, 2, 3], [4, 5, 6]]
    cloud.view("<u4")[0, :, 4] = [0x00FF8000, 0x000000FF]
    fields = [{"name": n, "offset": o, "datatype": FLOAT32, "count": 1} for n, o in zip("xyz", (0, 4, 8), strict=True)]
    msg = msgs.from_dict(PointCloud2, {"height": 1, "width": 2, "point_step": 32, "row_step": 64,
                                       "fields": [*fields, {"name": "rgb", "offset": 16, "datatype": FLOAT32,
                                                            "count": 1}], "data": cloud.tobytes()})
    points, intensity, rgb = cloud_points(msg)
    assert points.tolist() == [[1, 2, 3], [4, 5, 6]] and intensity is None
    assert rgb.tolist() == [[255, 128, 0], [0, 0, 255]]


def test_a_big_endian_cloud_reads_the_same() -> None:
    little = lidar_cloud(np.array([[1.5, -2, 3]], np.float32), np.array([7.0], np.float32))
    big = np.zeros(1, LIDAR.newbyteorder(">"))
    big["x"], big["y"], big["z"], big["intensity"] = 1.5, -2, 3, 7.0
    msg = msgs.from_dict(PointCloud2, {**msgs.to_dict(little), "is_bigendian": True, "data": big.tobytes()})
    assert cloud_points(msg)[0].tolist() == [[1.5, -2, 3]] and cloud_points(msg)[1].tolist() == [7.0]


@pytest.mark.parametrize(("changes", "reason"), [
    ({"fields": []}, "fields has no 'x'"),
    ({"point_step": 12}, "fields 'intensity': offset 12 + 4 bytes is past the point_step of 12"),
    ({"point_step": 0}, "point_step is 0"),
    ({"row_step": 10}, "row_step is 10, shorter than width x point_step (40)"),
    ({"data": b"\0" * 39}, "data has 39 bytes, row_step x height is 40"),
    ({"fields": [{"name": a, "offset": 4 * i, "datatype": 9, "count": 1} for i, a in enumerate("xyz")]},
     "fields 'x': datatype 9 is not a PointField type"),
])
def test_malformed_clouds_are_refused_with_the_field_and_reason(changes: dict, reason: str) -> None:
    msg = lidar_cloud(np.zeros((2, 3), np.float32), np.zeros(2, np.float32))
    msg = msgs.from_dict(PointCloud2, {**msgs.to_dict(msg), **changes})
    with pytest.raises(SensorDataError) as info:
        cloud_points(msg)
    assert reason in str(info.value)


def test_range_points_colour_lidars_by_intensity_and_lasers_magenta() -> None:
    xyz, colors = range_points("points", lidar_cloud(np.ones((2, 3), np.float32), np.array([0, 1], np.float32)), 0)
    assert colors.tolist() == [[0, 0, 255], [255, 0, 0]]
    xyz, colors = range_points("scan", scan([1.0, 1.0, 1.0]), 0)
    assert len(xyz) == 3 and colors.tolist() == [[255, 0, 255]] * 3


def test_a_scan_gives_points_of_its_returns_only() -> None:
    points, intensities = scan_points(scan([1.0, math.inf, 2.0, 0.05, 20.0]))
    assert intensities is None
    # -90, -45, 0, 45, 90 degrees: +inf (no return), 0.05 (under range_min) and 20 (over range_max) left out
    assert points.tolist() == [pytest.approx([0, -1, 0], abs=1e-6), pytest.approx([2, 0, 0], abs=1e-6)]


@pytest.mark.parametrize(("changes", "reason"), [
    ({"angle_increment": 0.0}, "angle_increment is 0 for 3 rays"),
    ({"intensities": [1.0]}, "intensities has 1 entries for 3 ranges"),
])
def test_malformed_scans_are_refused_with_the_field_and_reason(changes: dict, reason: str) -> None:
    with pytest.raises(SensorDataError, match=reason):
        scan_points(scan([1.0, 1.0, 1.0], **changes))


# -- body sensors ----------------------------------------------------------------------------------------
def test_imu_columns_and_force_arrows() -> None:
    assert sensor_part("humanoid", "humanoid/imu_sensor_broadcaster/imu") == "imu_sensor_broadcaster_imu"
    imu = msgs.from_dict(Imu, {"angular_velocity": {"x": 0.1}, "linear_acceleration": {"z": 9.81}})
    columns = imu_columns("imu", imu)
    assert columns["angular_velocity"]["imu"].tolist() == [0.1, 0, 0]
    assert columns["linear_acceleration"]["imu"].tolist() == [0, 0, 9.81]
    foot = np.eye(4)
    foot[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # turned 90 degrees about z
    foot[:3, 3] = [0.1, 0.2, 0.05]
    wrench = msgs.from_dict(WrenchStamped, {"wrench": {"force": {"x": 100.0, "z": 300.0}}})
    origin, vector = force_arrow(foot, wrench, 0.001)
    assert vector == pytest.approx([0.0, 0.1, 0.3])
    assert origin + vector == pytest.approx([0.1, 0.2, 0.05]), "it pushes on the foot: its tip at the frame"
    bad = msgs.from_dict(Imu, {})
    bad.linear_acceleration.z = math.nan  # the codec refuses NaN on the wire: as if it had come through
    with pytest.raises(SensorDataError, match="linear_acceleration is not finite"):
        imu_columns("imu", bad)


def test_contact_points_of_a_bumper_in_the_world() -> None:
    contacts = msgs.from_dict(ContactsState, {"header": {"frame_id": "world"}, "states": [
        {"contact_positions": [{"x": 0.1, "y": 0.2, "z": 0.0}, {"x": 0.3, "y": 0.2, "z": 0.0}]},
        {"contact_positions": [{"x": -0.1, "y": 0.0, "z": 0.0}]}]})
    assert contact_points(np.eye(4), contacts).tolist() == [[0.1, 0.2, 0.0], [0.3, 0.2, 0.0], [-0.1, 0.0, 0.0]]
    lifted = np.eye(4)
    lifted[2, 3] = 1.0   # positions given in a link one metre up
    assert contact_points(lifted, contacts)[:, 2].tolist() == [1.0, 1.0, 1.0]
    assert contact_points(np.eye(4), msgs.from_dict(ContactsState, {})).shape == (0, 3)
    bad = msgs.from_dict(ContactsState, {"states": [{"contact_positions": [{"x": 1.0}]}]})
    bad.states[0].contact_positions[0].x = math.inf   # as if it had come through
    with pytest.raises(SensorDataError, match="contact_positions is not finite"):
        contact_points(np.eye(4), bad)


LEG = """<robot name="leg">
  <link name="hip"><visual><geometry><box size="0.2 0.2 0.1"/></geometry></visual></link>
  <link name="foot"><visual><geometry><sphere radius="0.05"/></geometry></visual></link>
  <joint name="ankle" type="fixed"><parent link="hip"/><child link="foot"/><origin xyz="0 0 -0.4"/></joint>
</robot>"""


def record(tmp_path: Path, body) -> dict:
    return record_rrd(tmp_path / "sensors.rrd", body, "test_viz_sensors")


def test_force_arrows_and_the_centre_of_pressure_are_in_the_robots_row(tmp_path: Path) -> None:
    """No entity of their own: the feet's forces and the CoP cost the page no chunk."""
    def body(recording: rr.RecordingStream) -> None:
        scene = RobotScene(recording, "leg", parse_model(LEG))
        scene.log_joint_states(1.0, ["x"], [0.0], [], [])  # every row has the arrows, empty at first
        scene.update_arrow("leg/left_ft/wrench", (0.0, 0.1, 0.05), (0.0, 0.0, 0.3))
        scene.update_balance((0, 0, 0.8), (0.01, 0), True, [(0.1, 0.1, 0), (0.1, -0.1, 0), (-0.1, 0, 0)],
                             cop=(0.02, -0.01))
        scene.log_joint_states(1.1, ["x"], [0.0], [], [], extra={"angular_velocity": {"imu": np.array([1, 2, 3.])}})
        scene.update_arrow("leg/left_ft/wrench", None)
        scene.log_joint_states(1.2, ["x"], [0.0], [], [])

    rows = record(tmp_path, body)["world/leg/robot"].rows
    assert [len(r["Arrows3D:vectors"]) for r in rows] == [0, 1, 0]
    assert rows[1]["Arrows3D:origins"] == [pytest.approx([0, 0.1, 0.05])]
    assert rows[1]["Arrows3D:vectors"] == [pytest.approx([0, 0, 0.3])]
    assert rows[1]["Points3D:positions"][3] == pytest.approx([0.02, -0.01, 0.004]), "the CoP on the ground"
    assert rows[1]["Points3D:colors"][3] == 0x28DCF0FF
    assert rows[1]["angular_velocity:imu"] == [1.0, 2.0, 3.0]


def test_camera_and_range_rows(tmp_path: Path) -> None:
    rgb = np.zeros((240, 320, 3), np.uint8)
    rgb[:, 160:] = [200, 30, 30]
    depth = np.full((240, 320), 2500, np.uint16)
    k = fallback_k(320, 240)
    pose = np.eye(4)
    pose[:3, 3] = [0.1, 0.0, 1.4]

    def body(recording: rr.RecordingStream) -> None:
        sensors = RenderedSensors(recording, "humanoid", jpeg_quality=75)
        sensors.log_camera(2.0, "camera", CameraFrame(k, 320, 240, (rgb, "RGB"), depth, pose))
        lidar = to_world(pose, np.array([[1, 0, 0]], np.float32))
        sensors.log_ranges(2.1, [(lidar, np.array([[0, 0, 255]], np.uint8)),
                                 (np.zeros((2, 3), np.float32), np.full((2, 3), 255, np.uint8))])

    data = record(tmp_path, body)
    camera = data[camera_entity("humanoid", "camera")].rows[0]
    assert camera["Transform3D:translation"] == [pytest.approx([0.1, 0.0, 1.4])]
    assert camera["Pinhole:resolution"] == [[320.0, 240.0]]
    assert camera["EncodedImage:media_type"] == ["image/jpeg"]
    jpeg = bytes(camera["EncodedImage:blob"][0])
    assert jpeg[:2] == b"\xff\xd8" and len(jpeg) < 320 * 240 * 3 / 20, f"{len(jpeg)} bytes: not compressed"
    assert camera["DepthImage:meter"] == [1000.0] and camera["sim_time"] == 2.0, "the depth image in the same row"
    assert set(data) - {"__properties"} == {camera_entity("humanoid", "camera"), ranges_entity("humanoid")}
    ranges = data[ranges_entity("humanoid")].rows[0]
    assert ranges["Points3D:positions"][0] == pytest.approx([1.1, 0.0, 1.4])
    assert len(ranges["Points3D:positions"]) == 3 and ranges["Points3D:radii"] == [-2.0], "one radius for all"
    assert ranges["Points3D:colors"] == [0x0000FFFF, 0xFFFFFFFF, 0xFFFFFFFF]


def test_the_blueprint_has_an_imu_tab_and_a_camera_tab() -> None:
    import rerun.blueprint as rrb

    layout = RobotLayout(imus=[("imu_sensor_broadcaster_imu", "imu_sensor_broadcaster/imu")],
                         cameras=[("world/humanoid/cameras/camera", True)])
    side = build_blueprint({"humanoid": layout}).root_container.contents[1]
    tabs = {tab.name: tab for tab in side.contents}
    assert list(tabs) == ["positions", "velocities", "efforts", "imu", "camera"]
    imu_views = tabs["imu"].contents
    assert [str(v.name) for v in imu_views] == ["imu_sensor_broadcaster/imu: angular velocity (rad/s)",
                                                "imu_sensor_broadcaster/imu: linear acceleration (m/s²)"]
    [(entity, [visualizer])] = imu_views[0].visualizer_overrides.items()
    assert str(entity) == "world/humanoid/robot"
    assert visualizer.mappings[0].source_component == "angular_velocity:imu_sensor_broadcaster_imu"
    image_view, depth_view = tabs["camera"].contents
    assert isinstance(image_view, rrb.Spatial2DView) and str(image_view.origin) == "world/humanoid/cameras/camera"
    assert str(depth_view.origin) == "world/humanoid/cameras/camera"

    def active(view: Any) -> list[str]:  # the visualizers a view runs on the camera's entity
        [(entity, visualizers)] = view.visualizer_overrides.items()
        assert str(entity) == "world/humanoid/cameras/camera"
        return [v.visualizer_type for v in visualizers]

    assert active(image_view) == ["EncodedImage"] and active(depth_view) == ["DepthImage"]
    scene = build_blueprint({"humanoid": layout}).root_container.contents[0]
    assert active(scene) == ["Cameras", "EncodedImage"], "the frustum and image, no depth points"
    lifted = build_blueprint({"humanoid": layout}, depth_cloud=True).root_container.contents[0]
    assert not lifted.visualizer_overrides, "depth_cloud: Rerun's own choice, the depth lifted into points"
    plots = build_blueprint({"humanoid": layout}, plots=["positions"]).root_container.contents[1]
    assert [tab.name for tab in plots.contents] == ["positions"], "plots:=[...] leaves the sensor tabs out"


# -- pulls -----------------------------------------------------------------------------------------------
class FakeSubscription:
    def __init__(self, log: list[str], name: str) -> None:
        self.log, self.name = log, name
        log.append(f"+{name}")

    def destroy(self) -> None:
        self.log.append(f"-{self.name}")


def test_a_pull_subscribes_for_one_frame_per_period() -> None:
    """The renderer draws only while someone subscribes: the viewer takes one frame, then lets go."""
    from nodes.viz.pulls import FramePull

    now, log, frames = [0.0], [], []
    pull = FramePull(["image", "depth"], lambda: [FakeSubscription(log, "image"), FakeSubscription(log, "depth")],
                     lambda: frames.append(now[0]), period=0.5, ordered=True, clock=lambda: now[0])
    pull.arrived("image")  # nothing open yet: ignored
    pull.tick()
    assert log == ["+image", "+depth"]
    now[0] = 0.03
    pull.arrived("depth")  # the depth of a frame whose image came before we subscribed
    pull.arrived("image")
    assert frames == [] and pull.subscriptions
    pull.arrived("depth")
    assert frames == [0.03], "a complete frame: colour and depth"
    assert log[-2:] == ["-image", "-depth"] and not pull.subscriptions, "closed at once"
    pull.arrived("image")
    assert frames == [0.03], "one frame per pull"
    now[0] = 0.05
    pull.tick()
    assert not pull.subscriptions
    now[0] = 0.3
    pull.tick()
    assert not pull.subscriptions, "not due before a period has passed since the last pull opened"
    now[0] = 0.5
    pull.tick()
    assert pull.subscriptions and pull.pulls == 2
    # Only part of the frame comes: after PATIENCE it is drawn anyway, and the pull closes.
    now[0] = 0.55
    pull.arrived("image")
    now[0] = 1.6
    pull.tick()
    assert frames == [0.03, 1.6] and pull.pulls == 3, "drawn with what came, and the next pull (overdue) opened"
    # Nothing at all (no renderer): the subscriptions stay, no churn.
    quiet = FramePull(["scan"], lambda: [FakeSubscription(log, "scan")], lambda: None, period=0.5,
                      clock=lambda: now[0])
    quiet.tick()
    now[0] = 10.0
    quiet.tick()
    assert log.count("+scan") == 1 and "-scan" not in log


def test_a_continuous_pull_stays_subscribed_and_draws_at_its_rate() -> None:
    from nodes.viz.pulls import FramePull

    now, log, frames = [0.0], [], []
    pull = FramePull(["image"], lambda: [FakeSubscription(log, "image")], lambda: frames.append(now[0]),
                     period=0.5, continuous=True, clock=lambda: now[0])
    pull.tick()
    for step in range(30):  # 30 Hz for a second
        now[0] = step / 30
        pull.arrived("image")
        pull.tick()
    assert log == ["+image"] and len(frames) == 2
