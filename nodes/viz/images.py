"""sensor_msgs/Image and CameraInfo as arrays the viewer can draw, checked as ROS tools check them.

``image_array`` turns an Image into a numpy array (colour: (H, W, 3) uint8 in r g b order, or (H, W) uint8;
depth: (H, W) float32 metres or uint16 millimetres), ``depth_millimetres`` makes a depth image the
viewer's uint16 millimetres (REP 117's +-inf, NaN and 0 all "no depth": 0), and ``intrinsics`` reads the
pinhole of a CameraInfo. Anything that does not add up (an unknown encoding, a step shorter than a row,
data that is not step x height bytes, a non-positive focal length) raises ``SensorDataError`` naming the
field and the reason: the caller logs it on rosout and skips the message.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

# encoding -> (channels, numpy dtype of a channel); sensor_msgs/image_encodings.hpp's common ones
ENCODINGS: dict[str, tuple[int, str]] = {
    "rgb8": (3, "u1"), "bgr8": (3, "u1"), "rgba8": (4, "u1"), "bgra8": (4, "u1"), "mono8": (1, "u1"),
    "8UC1": (1, "u1"), "8UC3": (3, "u1"), "mono16": (1, "u2"), "16UC1": (1, "u2"), "32FC1": (1, "f4"),
}
DEPTH_ENCODINGS = ("32FC1", "16UC1")  # depth images: metres (float) or millimetres (uint16), as in ROS
MAX_PIXELS = 4096 * 4096


class SensorDataError(ValueError):
    """A sensor message the viewer cannot draw: the message names the field and the reason."""


def is_depth(msg: Any) -> bool:
    return msg.encoding in DEPTH_ENCODINGS


def image_array(msg: Any) -> np.ndarray:
    """The pixels of a sensor_msgs/Image: (H, W) for one channel, (H, W, C) for several (a view on the
    message's bytes where possible; rows of ``step`` bytes, padding dropped)."""
    if msg.encoding not in ENCODINGS:
        raise SensorDataError(f"encoding '{msg.encoding}' is not one of {', '.join(ENCODINGS)}")
    channels, base = ENCODINGS[msg.encoding]
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    if height <= 0 or width <= 0:
        raise SensorDataError(f"height x width is {height} x {width}: an image has pixels")
    if height * width > MAX_PIXELS:
        raise SensorDataError(f"height x width is {height} x {width}, over the viewer's {MAX_PIXELS} pixels")
    dtype = np.dtype(base).newbyteorder(">" if msg.is_bigendian else "<")
    row = width * channels * dtype.itemsize
    if step < row:
        raise SensorDataError(f"step is {step} bytes, shorter than a row of {width} {msg.encoding} pixels ({row})")
    data = bytes(msg.data) if not isinstance(msg.data, (bytes, bytearray, memoryview)) else msg.data
    if len(data) != step * height:
        raise SensorDataError(f"data has {len(data)} bytes, step x height is {step * height}")
    rows = np.frombuffer(data, dtype=np.uint8).reshape(height, step)[:, :row]
    pixels = np.ascontiguousarray(rows).view(dtype).reshape(height, width, channels)
    return pixels[..., 0] if channels == 1 else pixels


def color_image(msg: Any) -> tuple[np.ndarray, str]:
    """(pixels, Rerun colour model) of a colour or grey image: (H, W, 3) r g b, or (H, W) "L"; 16-bit grey
    is scaled to 8 bits, the way image viewers show it."""
    pixels = image_array(msg)
    encoding = msg.encoding
    if encoding in DEPTH_ENCODINGS:
        raise SensorDataError(f"encoding '{encoding}' is a depth image, not a colour one")
    if pixels.ndim == 2:
        return (pixels if pixels.dtype.itemsize == 1 else (pixels >> 8)).astype(np.uint8), "L"
    if encoding.startswith("bgr"):
        pixels = pixels[..., 2::-1]
    return np.ascontiguousarray(pixels[..., :3]), "RGB"


def depth_millimetres(msg: Any) -> np.ndarray:
    """A depth image as uint16 millimetres (half the bytes of float32 metres, 1 mm steps up to 65.5 m; 0:
    no depth): REP 117's +-inf (out of range), NaN and non-positive depths become 0."""
    pixels = image_array(msg)
    if msg.encoding == "16UC1":
        return pixels.astype(np.uint16, copy=False)
    if msg.encoding != "32FC1":
        raise SensorDataError(f"encoding '{msg.encoding}' is not a depth image (32FC1 metres or 16UC1 mm)")
    depth = pixels.astype(np.float32, copy=False)
    valid = np.isfinite(depth) & (depth > 0)
    return np.where(valid, np.minimum(np.rint(depth * 1000.0), 65535.0), 0.0).astype(np.uint16)


def intrinsics(info: Any, width: int | None = None, height: int | None = None) -> tuple[np.ndarray, int, int]:
    """(3x3 K, width, height) of a sensor_msgs/CameraInfo, checked; a K for another resolution than the
    image's (``width``, ``height``) is refused."""
    k = [float(v) for v in info.k]
    if len(k) != 9 or not all(math.isfinite(v) for v in k):
        raise SensorDataError(f"k is {k}: 9 finite numbers [fx 0 cx 0 fy cy 0 0 1]")
    fx, fy = k[0], k[4]
    if fx <= 0 or fy <= 0:
        raise SensorDataError(f"k has fx {fx}, fy {fy}: focal lengths are positive (an uncalibrated camera?)")
    w, h = int(info.width), int(info.height)
    if w <= 0 or h <= 0:
        raise SensorDataError(f"width x height is {w} x {h}")
    if width is not None and height is not None and (w, h) != (width, height):
        raise SensorDataError(f"width x height is {w} x {h} but the image is {width} x {height}")
    return np.array(k).reshape(3, 3), w, h
