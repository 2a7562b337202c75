"""sensor_msgs/PointCloud2 and LaserScan as points the viewer can draw, checked as RViz checks them.

``cloud_points`` reads x y z (and ``intensity`` or ``rgb`` when present) of a PointCloud2 through a numpy
structured dtype built from its ``fields`` (any datatype, either byte order, rows of ``row_step`` bytes), and
drops points that are not finite (an organised cloud's holes). ``scan_points`` turns a LaserScan into points
in its frame, leaving out REP 117's +-inf and ranges outside [range_min, range_max]. ``intensity_colors``
colours by intensity as RViz's Intensity channel does (a rainbow over the cloud's own min..max).

A cloud whose fields, offsets or sizes do not add up raises ``SensorDataError`` naming the field and the
reason; the caller logs it on rosout and skips the message.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .images import SensorDataError

FIELD_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}  # PointField datatypes
MAX_POINTS = 4_000_000
MAX_RAYS = 1_000_000
# RViz's rainbow, low to high: blue, cyan, green, yellow, red
RAINBOW = np.array([[0, 0, 255], [0, 255, 255], [0, 255, 0], [255, 255, 0], [255, 0, 0]], float)


def point_dtype(msg: Any) -> np.dtype:
    """The structured dtype of one point: x y z, and intensity / rgb / rgba when the cloud has them."""
    step = int(msg.point_step)
    if step <= 0:
        raise SensorDataError(f"point_step is {step}")
    order = ">" if msg.is_bigendian else "<"
    fields = {f.name: f for f in msg.fields}
    missing = [axis for axis in "xyz" if axis not in fields]
    if missing:
        raise SensorDataError(f"fields has no '{missing[0]}' (names: {[f.name for f in msg.fields]})")
    names, formats, offsets = [], [], []
    for name in ("x", "y", "z", "intensity", "rgb", "rgba"):
        f = fields.get(name)
        if f is None:
            continue
        if f.datatype not in FIELD_TYPES:
            raise SensorDataError(f"fields '{name}': datatype {f.datatype} is not a PointField type (1..8)")
        kind = np.dtype(FIELD_TYPES[f.datatype]).newbyteorder(order)
        if f.count < 1:
            raise SensorDataError(f"fields '{name}': count is {f.count}")
        if f.offset + kind.itemsize > step:
            raise SensorDataError(f"fields '{name}': offset {f.offset} + {kind.itemsize} bytes is past the "
                                  f"point_step of {step}")
        if name in ("rgb", "rgba") and kind.itemsize != 4:
            raise SensorDataError(f"fields '{name}': a packed colour is 4 bytes, datatype {f.datatype} is not")
        names.append(name)
        formats.append(kind)
        offsets.append(int(f.offset))
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": step})


def cloud_records(msg: Any) -> np.ndarray:
    """The points of a PointCloud2 as structured records (height x width of them, row padding dropped)."""
    dtype = point_dtype(msg)
    height, width, row_step = int(msg.height), int(msg.width), int(msg.row_step)
    if height * width > MAX_POINTS:
        raise SensorDataError(f"height x width is {height} x {width}, over the viewer's {MAX_POINTS} points")
    if row_step < width * dtype.itemsize:
        raise SensorDataError(f"row_step is {row_step}, shorter than width x point_step ({width * dtype.itemsize})")
    data = msg.data
    if len(data) != row_step * height:
        raise SensorDataError(f"data has {len(data)} bytes, row_step x height is {row_step * height}")
    if height * width == 0:
        return np.zeros(0, dtype)
    rows = np.frombuffer(data, dtype=np.uint8).reshape(height, row_step)[:, :width * dtype.itemsize]
    return np.ascontiguousarray(rows).view(dtype).reshape(-1)


def cloud_points(msg: Any, max_points: int = 0) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """(xyz (N, 3) float32, intensity (N,) or None, rgb (N, 3) uint8 or None) of the finite points, every
    k-th one when there are more than ``max_points`` (0: all)."""
    records = cloud_records(msg)
    xyz = np.stack([records[a].astype(np.float32) for a in "xyz"], axis=-1)
    keep = np.isfinite(xyz).all(axis=1)
    names = records.dtype.names or ()
    intensity = records["intensity"].astype(np.float32) if "intensity" in names else None
    rgb = None
    packed = "rgb" if "rgb" in names else "rgba" if "rgba" in names else ""
    if packed:
        bits = np.ascontiguousarray(records[packed]).view(np.uint32 if records.dtype[packed].byteorder != ">"
                                                          else np.dtype(">u4"))
        rgb = np.stack([(bits >> 16) & 255, (bits >> 8) & 255, bits & 255], axis=-1).astype(np.uint8)
    index = np.flatnonzero(keep)
    if max_points and len(index) > max_points:
        index = index[:: math.ceil(len(index) / max_points)]
    return (xyz[index], None if intensity is None else intensity[index], None if rgb is None else rgb[index])


def scan_points(msg: Any) -> tuple[np.ndarray, np.ndarray | None]:
    """(xyz (N, 3) float32 in the scan's frame, intensities (N,) or None) of a LaserScan's returns."""
    ranges = np.asarray(msg.ranges, dtype=np.float32)
    if len(ranges) > MAX_RAYS:
        raise SensorDataError(f"ranges has {len(ranges)} entries, over the viewer's {MAX_RAYS}")
    start, increment = float(msg.angle_min), float(msg.angle_increment)
    if not (math.isfinite(start) and math.isfinite(increment)):
        raise SensorDataError(f"angle_min {start} / angle_increment {increment} are not finite")
    if len(ranges) > 1 and increment == 0.0:
        raise SensorDataError(f"angle_increment is 0 for {len(ranges)} rays")
    intensities = np.asarray(msg.intensities, dtype=np.float32) if len(msg.intensities) else None
    if intensities is not None and len(intensities) != len(ranges):
        raise SensorDataError(f"intensities has {len(intensities)} entries for {len(ranges)} ranges "
                              "(one per range, or none)")
    low = float(msg.range_min) if math.isfinite(msg.range_min) else 0.0
    high = float(msg.range_max) if math.isfinite(msg.range_max) else np.inf
    with np.errstate(invalid="ignore"):
        keep = np.flatnonzero(np.isfinite(ranges) & (ranges >= low) & (ranges <= high))
    angles = start + increment * keep.astype(np.float64)
    r = ranges[keep].astype(np.float64)
    xyz = np.stack([r * np.cos(angles), r * np.sin(angles), np.zeros_like(r)], axis=-1).astype(np.float32)
    return xyz, None if intensities is None else intensities[keep]


def intensity_colors(values: np.ndarray) -> np.ndarray:
    """RGB uint8 per value: RViz's rainbow from the lowest to the highest value of these points."""
    if len(values) == 0:
        return np.zeros((0, 3), np.uint8)
    finite = np.where(np.isfinite(values), values, 0.0)
    low, high = float(finite.min()), float(finite.max())
    t = (finite - low) / (high - low) if high > low else np.full(len(finite), 0.5)
    stops = np.linspace(0.0, 1.0, len(RAINBOW))
    return np.stack([np.interp(t, stops, RAINBOW[:, c]) for c in range(3)], axis=-1).astype(np.uint8)
