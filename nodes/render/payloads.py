"""Rendered frames as plain message dicts (ROS 2 field names): what ``msgs`` encodes to msgpack or CDR.

Every ``uint8[] data`` is ``bytes`` made by one ``ndarray.tobytes()`` (a buffer copy; a per-element loop over
a 640x480 image would cost ~100 ms). Layouts follow what ROS tools expect from Gazebo:

- ``image``: sensor_msgs/Image in rgb8, bgr8, mono8 or 32FC1 (float32 depth), little-endian, rows packed
  (``step`` = width x bytes per pixel);
- ``camera_info``: gazebo_ros_camera's: plumb_bob with zero distortion, K = [f 0 cx; 0 f cy; 0 0 1],
  R = I, P = [K | 0] (a monocular camera: Tx = Ty = 0), no binning, a zeroed ROI;
- ``camera_points``: the depth camera's organised PointCloud2 (height x width as the image), fields x y z
  (FLOAT32 at 0, 4, 8) and rgb (FLOAT32 at 16 holding the bits of 0x00RRGGBB, as PCL and gazebo_ros pack
  it), ``point_step`` 32 (gazebo_ros's depth camera layout, PCL's aligned PointXYZRGB), NaN points where
  there is no depth, so ``is_dense`` False;
- ``lidar_points``: a 3-D lidar's PointCloud2 of its finite returns (height 1): x y z intensity (FLOAT32 at
  0, 4, 8, 12) and ring (UINT16 at 16), ``point_step`` 20: the ring padded to keep every point's floats
  4-byte aligned (Velodyne's own ``x y z intensity ring`` order and offsets; no ``time`` field, a scan is
  instantaneous here), ``is_dense`` True;
- ``laser_scan``: sensor_msgs/LaserScan from the horizontal axis; of a multi-ring spec the middle ring
  (``rings // 2``, the ring gazebo_ros' LaserScan conversion takes). Ranges may be +-inf (REP 117): a
  msgpack decoder needs ``msgs.Limits(allow_nonfinite=True)`` to accept them.
"""

from __future__ import annotations

import numpy as np

from nodes.render.camera import intrinsics
from nodes.urdf.rendered_sensors import CAMERA_POINT_BYTES, LIDAR_POINT_BYTES, CameraSpec, RaySpec

FLOAT32, UINT16 = 7, 4                                   # sensor_msgs/PointField datatypes
IMAGE_CHANNELS = {"rgb8": (3, np.uint8), "bgr8": (3, np.uint8), "mono8": (1, np.uint8),
                  "32FC1": (1, np.dtype("<f4"))}                      # encoding -> (channels, dtype)
CAMERA_POINT_STEP = CAMERA_POINT_BYTES          # (the spawn's message size check counts with these)
LIDAR_POINT = np.dtype({"names": ["x", "y", "z", "intensity", "ring"],
                        "formats": ["<f4", "<f4", "<f4", "<f4", "<u2"],
                        "offsets": [0, 4, 8, 12, 16], "itemsize": LIDAR_POINT_BYTES})


def header(stamp: dict, frame_id: str) -> dict:
    return {"stamp": stamp, "frame_id": frame_id}


def _field(name: str, offset: int, datatype: int) -> dict:
    return {"name": name, "offset": offset, "datatype": datatype, "count": 1}


def image(stamp: dict, frame_id: str, array: np.ndarray, encoding: str) -> dict:
    """sensor_msgs/Image of ``array``: (H, W, 3) uint8 for rgb8 / bgr8 (channels already in that order),
    (H, W) uint8 for mono8, (H, W) float32 metres for 32FC1."""
    if encoding not in IMAGE_CHANNELS:
        raise ValueError(f"image encoding '{encoding}' is not one of {', '.join(IMAGE_CHANNELS)}")
    channels, dtype = IMAGE_CHANNELS[encoding]
    expected_ndim = 3 if channels == 3 else 2
    if array.ndim != expected_ndim or (channels == 3 and array.shape[2] != 3):
        raise ValueError(f"a {encoding} image must be {'(H, W, 3)' if channels == 3 else '(H, W)'}, "
                         f"got {array.shape}")
    height, width = array.shape[:2]
    data = np.ascontiguousarray(array, dtype=dtype).tobytes()
    return {"header": header(stamp, frame_id), "height": height, "width": width, "encoding": encoding,
            "is_bigendian": 0, "step": width * channels * np.dtype(dtype).itemsize, "data": data}


def camera_info(stamp: dict, frame_id: str, spec: CameraSpec) -> dict:
    """sensor_msgs/CameraInfo of ``spec``, with the intrinsics its images were cast with."""
    f, cx, cy = intrinsics(spec)
    return {
        "header": header(stamp, frame_id), "height": spec.height, "width": spec.width,
        "distortion_model": "plumb_bob", "d": [0.0] * 5,
        "k": [f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0],
        "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        "p": [f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        "binning_x": 0, "binning_y": 0,
        "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False},
    }


def camera_points(stamp: dict, frame_id: str, points: np.ndarray, color: np.ndarray) -> dict:
    """The depth camera's organised sensor_msgs/PointCloud2: ``points`` (H, W, 3) in the optical frame (NaN
    where no depth), ``color`` (H, W, 3) uint8 in r g b order."""
    height, width = points.shape[:2]
    if color.shape != (height, width, 3):
        raise ValueError(f"color must be ({height}, {width}, 3) r g b, got {color.shape}")
    cloud = np.zeros((height, width, CAMERA_POINT_STEP // 4), dtype="<f4")
    cloud[..., :3] = points
    c = color.astype(np.uint32)
    cloud.view("<u4")[..., 4] = (c[..., 0] << 16) | (c[..., 1] << 8) | c[..., 2]
    return {
        "header": header(stamp, frame_id), "height": height, "width": width,
        "fields": [_field("x", 0, FLOAT32), _field("y", 4, FLOAT32), _field("z", 8, FLOAT32),
                   _field("rgb", 16, FLOAT32)],
        "is_bigendian": False, "point_step": CAMERA_POINT_STEP, "row_step": CAMERA_POINT_STEP * width,
        "data": cloud.tobytes(), "is_dense": False,
    }


def lidar_points(stamp: dict, frame_id: str, xyz: np.ndarray, intensity: np.ndarray, ring: np.ndarray) -> dict:
    """A lidar's unorganised sensor_msgs/PointCloud2 (height 1) of its K finite returns."""
    count = len(xyz)
    cloud = np.zeros(count, dtype=LIDAR_POINT)
    cloud["x"], cloud["y"], cloud["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    cloud["intensity"] = intensity
    cloud["ring"] = ring
    return {
        "header": header(stamp, frame_id), "height": 1, "width": count,
        "fields": [_field("x", 0, FLOAT32), _field("y", 4, FLOAT32), _field("z", 8, FLOAT32),
                   _field("intensity", 12, FLOAT32), _field("ring", 16, UINT16)],
        "is_bigendian": False, "point_step": LIDAR_POINT.itemsize, "row_step": LIDAR_POINT.itemsize * count,
        "data": cloud.tobytes(), "is_dense": True,
    }


def laser_scan(stamp: dict, frame_id: str, spec: RaySpec, ranges: np.ndarray, intensities: np.ndarray,
               scan_time: float) -> dict:
    """sensor_msgs/LaserScan of one ring: ``ranges`` and ``intensities`` (columns,), or (rings, columns) of
    which the middle ring (rings // 2) is taken."""
    ranges, intensities = np.asarray(ranges), np.asarray(intensities)
    if ranges.ndim == 2:
        middle = ranges.shape[0] // 2
        ranges, intensities = ranges[middle], intensities[middle]
    axis = spec.horizontal
    count = axis.count
    if ranges.shape != (count,) or intensities.shape != (count,):
        raise ValueError(f"a scan of this spec has {count} columns; got ranges {ranges.shape}, "
                         f"intensities {intensities.shape}")
    increment = (axis.max_angle - axis.min_angle) / (count - 1) if count > 1 else 0.0
    return {
        "header": header(stamp, frame_id),
        "angle_min": float(axis.min_angle),
        "angle_max": float(axis.max_angle) if count > 1 else float(axis.min_angle),
        "angle_increment": float(increment), "time_increment": 0.0, "scan_time": float(scan_time),
        "range_min": float(spec.range_min), "range_max": float(spec.range_max),
        # float32 -> Python floats in one C loop (bench/render.py measures it against the alternatives)
        "ranges": ranges.astype(np.float32, copy=False).tolist(),
        "intensities": intensities.astype(np.float32, copy=False).tolist(),
    }
