"""A robot's sensors in Rerun: the body sensors' values (IMU, force/torque) and the rendered sensors' entities.

Body sensors add nothing to the page's chunk count: the IMU's angular velocity and linear acceleration are
columns of the robot's row (``imu_columns``: ``angular_velocity:<imu>``, ``linear_acceleration:<imu>``,
plotted in the "imu" tab) and the feet's forces are arrows among the robot's markers (``force_arrow``, as
RViz's WrenchStamped display draws them, ``wrench_scale`` m per N, but ending at the sensor frame).

Rendered sensors are entities of their own under the robot's subtree (a deleted robot clears them too):

- ``world/<ns>/cameras/<camera>``        ``Transform3D`` (the optical frame in the world) + ``Pinhole``
                                         (CameraInfo's K: the frustum; Rerun's default camera axes are RDF,
                                         ROS's optical frame) + the colour image, JPEG-compressed
                                         (``EncodedImage``, ~13 kB instead of 230 kB for 320 x 240) + the
                                         depth image (``DepthImage``, uint16 mm, ``meter`` 1000; no depth: 0),
                                         all in one row: one chunk per flush for the page, not two. The
                                         layout's views pick what each draws (``blueprint.py``)
- ``world/<ns>/ranges``                  every lidar's and laser's newest points in the world (``Points3D``:
                                         lidars coloured by intensity, lasers magenta), one row for all of them

Each is logged at its own rate (``image_rate``, ``cloud_rate``: 1 Hz), never the sensors' 10-30 Hz: a page
takes in one chunk per entity and flush, and raw images would be tens of MB/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import rerun as rr

from nodes.kinematics import matrix_to_quaternion

from .clouds import cloud_points, intensity_colors, scan_points
from .images import SensorDataError, color_image, depth_millimetres, intrinsics
from .scene import SceneTime, group_part

IMU_KINDS = ("angular_velocity", "linear_acceleration")
IMU_SERIES = ["x", "y", "z"]
SCAN_COLOR = (255, 0, 255)  # magenta: apart from the lidars' rainbow
# One size for every range point (a radius per point would be 4 bytes more each, 58 kB a lidar row), in UI
# points: the same size on screen at any zoom, like RViz's "Points" style. The laser stands out by colour.
POINT_RADIUS = -2.0
FRUSTUM_DEPTH = 0.25  # m from the camera to the image plane drawn in the 3-D view


def sensor_part(namespace: str, topic: str) -> str:
    """A sensor's name in column and entity names: its topic under the robot namespace, ``/`` as ``_``
    (``humanoid/imu_sensor_broadcaster/imu`` -> ``imu_sensor_broadcaster_imu``)."""
    return group_part(topic.strip("/").removeprefix(f"{namespace}/").replace("/", "_"))


def finite(values: Sequence[float], what: str) -> np.ndarray:
    array = np.asarray(values, float)
    if not np.isfinite(array).all():
        raise SensorDataError(f"{what} is not finite: {array.tolist()}")
    return array


def imu_columns(part: str, msg: Any) -> dict[str, dict[str, np.ndarray]]:
    """The robot-row columns of a sensor_msgs/Imu: angular velocity (rad/s) and linear acceleration (m/s^2)."""
    w, a = msg.angular_velocity, msg.linear_acceleration
    return {"angular_velocity": {part: finite((w.x, w.y, w.z), "angular_velocity")},
            "linear_acceleration": {part: finite((a.x, a.y, a.z), "linear_acceleration")}}


def force_arrow(frame: np.ndarray, msg: Any, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """(origin, vector) in the world of a geometry_msgs/WrenchStamped's force measured in ``frame`` (4x4),
    drawn pushing on the frame: the arrow ends at the frame's origin. (RViz starts it there; a foot's
    ground reaction would then run up inside the shin, hidden, where this one rises from under the sole.)"""
    f = msg.wrench.force
    vector = frame[:3, :3] @ finite((f.x, f.y, f.z), "wrench.force") * scale
    return frame[:3, 3] - vector, vector


@dataclass
class CameraFrame:
    """What one camera row draws: K and resolution, the pixels, the optical frame in the world."""

    k: np.ndarray  # 3x3
    width: int
    height: int
    color: tuple[np.ndarray, str] | None = None  # (pixels, "RGB" | "L")
    depth_mm: np.ndarray | None = None  # (H, W) uint16
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))


def contact_points(frame: np.ndarray, msg: Any) -> np.ndarray:
    """The world positions of a gazebo_msgs/ContactsState's contacts (given in the frame at ``frame``);
    SensorDataError naming the field for a non-finite one."""
    rows = [(p.x, p.y, p.z) for state in msg.states for p in state.contact_positions]
    if not rows:
        return np.zeros((0, 3))
    points = finite([v for row in rows for v in row], "states[].contact_positions").reshape(-1, 3)
    return points @ frame[:3, :3].T + frame[:3, 3]


def camera_frame(color_msg: Any, depth_msg: Any, info_msg: Any, horizontal_fov: float
                 ) -> tuple[CameraFrame | None, list[tuple[str, str]]]:
    """The pixels of a camera's newest colour and depth images (either may be None) and its pinhole:
    CameraInfo's K, else the URDF's field of view; with the problems met, as (``"image"``, ``"depth"`` or
    ``"camera_info"``, reason). None when neither image can be drawn."""
    problems: list[tuple[str, str]] = []
    color = depth = None
    try:
        color = color_image(color_msg) if color_msg is not None else None
    except SensorDataError as exc:
        problems.append(("image", f"image skipped: {exc}"))
    try:
        depth = depth_millimetres(depth_msg) if depth_msg is not None else None
    except SensorDataError as exc:
        problems.append(("depth", f"depth image skipped: {exc}"))
    if color is None and depth is None:
        return None, problems
    height, width = (color[0] if color is not None else depth).shape[:2]
    k = None
    if info_msg is not None:
        try:
            k = intrinsics(info_msg, width, height)[0]
        except SensorDataError as exc:
            problems.append(("camera_info", f"{exc}: the frustum comes from the URDF's field of view"))
    if k is None:
        k = fallback_k(width, height, horizontal_fov)
    return CameraFrame(k, width, height, color, depth), problems


def range_points(kind: str, msg: Any, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """(xyz (N, 3) in the sensor frame, colours (N, 3) uint8) of a lidar's PointCloud2 (``kind`` "points":
    by intensity, else its packed colours, else grey) or a LaserScan ("scan": magenta)."""
    if kind == "points":
        xyz, intensity, rgb = cloud_points(msg, max_points)
        if intensity is not None:
            return xyz, intensity_colors(intensity)
        return xyz, rgb if rgb is not None else np.full((len(xyz), 3), 200, np.uint8)
    xyz, _ = scan_points(msg)
    return xyz, np.tile(np.array(SCAN_COLOR, np.uint8), (len(xyz), 1))


def camera_entity(namespace: str, camera: str) -> str:
    return f"world/{namespace}/cameras/{rr.escape_entity_path_part(camera)}"


def ranges_entity(namespace: str) -> str:
    return f"world/{namespace}/ranges"


def fallback_k(width: int, height: int, horizontal_fov: float = 1.047) -> np.ndarray:
    """K of a camera without CameraInfo: gazebo_ros_camera's (square pixels, centred), from the fov."""
    f = width / (2.0 * math.tan(horizontal_fov / 2.0))
    return np.array([[f, 0.0, width / 2.0], [0.0, f, height / 2.0], [0.0, 0.0, 1.0]])


class RenderedSensors:
    """The Rerun entities of one robot's cameras and range sensors (see the module's docstring)."""

    def __init__(self, recording: rr.RecordingStream, namespace: str, jpeg_quality: int = 75) -> None:
        self.recording = recording
        self.namespace = namespace
        self.jpeg_quality = jpeg_quality
        self.set_time = SceneTime(recording)

    def log_camera(self, sim_time: float, camera: str, frame: CameraFrame) -> None:
        """One row of the camera: pose, pinhole, compressed image, depth image."""
        self.set_time(sim_time)
        entity = camera_entity(self.namespace, camera)
        parts: list = [rr.Transform3D(translation=frame.pose[:3, 3], quaternion=matrix_to_quaternion(frame.pose[:3, :3])),
                       rr.Pinhole(image_from_camera=frame.k, resolution=[frame.width, frame.height],
                                  image_plane_distance=FRUSTUM_DEPTH)]
        if frame.color is not None:
            pixels, model = frame.color
            parts.append(rr.Image(pixels, color_model=model).compress(jpeg_quality=self.jpeg_quality))
        if frame.depth_mm is not None:
            parts.append(rr.DepthImage(frame.depth_mm, meter=1000.0))
        self.recording.log(entity, *parts)

    def log_ranges(self, sim_time: float, clouds: Sequence[tuple[np.ndarray, np.ndarray]]) -> None:
        """One row with every range sensor's points: (world xyz (N, 3), colours (N, 3) uint8) each."""
        self.set_time(sim_time)
        self.recording.log(ranges_entity(self.namespace), rr.Points3D(
            np.concatenate([xyz for xyz, _ in clouds]) if clouds else np.zeros((0, 3), np.float32),
            colors=np.concatenate([c for _, c in clouds]) if clouds else np.zeros((0, 3), np.uint8),
            radii=[POINT_RADIUS]))


def to_world(pose: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    return (xyz @ pose[:3, :3].T.astype(np.float32) + pose[:3, 3].astype(np.float32)).astype(np.float32)
