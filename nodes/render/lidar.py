"""Laser range finders (2-D lasers and multi-ring 3-D lidars) drawn by casting one ray per beam.

Conventions (``RaySpec``, as Gazebo has them): horizontal angles about the sensor frame's z, 0 along +x,
counter-clockwise; vertical angles up from the x-y plane; one ring per vertical angle, ring 0 the lowest
(Velodyne numbers its rings from the bottom). A scan is (rings, columns): ``ranges[ring, column]``.

Ranges are metres along the beam; REP 117: +inf for no return or beyond ``range_max``, -inf nearer than
``range_min``. Noise, as Gazebo Classic's ray sensor applies it: N(mean, stddev) added to each in-range
return (from the caller's ``rng``; ``None``: none), clamped to [range_min, range_max], then rounded to
``range_resolution`` when that is positive. Gazebo's bias (drawn once per sensor) is not applied here.

Intensity (Gazebo Classic reports the surface's ``<laser_retro>``, 0 by default, which tells a user
nothing): the hit surface's colour luminance (0.299 r + 0.587 g + 0.114 b of its rgba) times |cos| of the
angle between the beam and the surface normal, in [0, 1]; 0 where there is no finite return. Bright
surfaces facing the sensor return strongly, grazing or dark ones weakly, as real lidars roughly do.

``spec.visual`` (gpu_ray, gpu_lidar) casts against visual shapes, otherwise (ray, lidar) collision shapes.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from nodes.render.geometry import dot, rotate
from nodes.render.raycast import RayScene, View
from nodes.urdf.rendered_sensors import RayAxis, RaySpec

LUMINANCE = np.array([0.299, 0.587, 0.114], dtype=np.float32)


@functools.lru_cache(maxsize=16)
def directions(horizontal: RayAxis, vertical: RayAxis) -> np.ndarray:
    """Unit beam directions (rings, columns, 3) float64 in the sensor frame (read-only, shared)."""
    yaw = horizontal.angles()[None, :]
    pitch = vertical.angles()[:, None]
    out = np.stack([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw),
                    np.broadcast_to(np.sin(pitch), (len(vertical.angles()), len(horizontal.angles())))], axis=-1)
    out.flags.writeable = False
    return out


@dataclass
class RangeScan:
    """One scan: ``ranges`` and ``intensities`` (rings, columns) float32; ``directions`` the beams' unit
    directions (rings, columns, 3) in the sensor frame."""

    ranges: np.ndarray
    intensities: np.ndarray
    directions: np.ndarray

    def points(self, ranges: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The finite returns of ``ranges`` (default: this scan's) as ``(xyz (K, 3) float32 in the sensor
        frame, intensity (K,) float32, ring (K,) uint16)``, ring-major (ring 0's columns first)."""
        ranges = self.ranges if ranges is None else np.asarray(ranges, dtype=np.float32)
        finite = np.isfinite(ranges)
        ring, column = np.nonzero(finite)           # C order: ring-major
        r = ranges[ring, column]
        xyz = (self.directions[ring, column] * r[:, None]).astype(np.float32)
        return xyz, self.intensities[ring, column].astype(np.float32), ring.astype(np.uint16)


def render_ray(scene: RayScene, spec: RaySpec, sensor_pose: np.ndarray,
               rng: np.random.Generator | None = None) -> RangeScan:
    """The scan ``spec`` describes from ``sensor_pose`` (4x4 world pose of the sensor frame)."""
    beams = directions(spec.horizontal, spec.vertical)
    shape = beams.shape[:2]
    pose = np.asarray(sensor_pose, dtype=np.float64)
    world = rotate(beams.reshape(-1, 3), pose[:3, :3])
    vertical = spec.vertical.angles()
    view = View(origin=pose[:3, 3], rotation=pose[:3, :3], far=float(spec.range_max),
                elevation=(float(vertical.min()), float(vertical.max())))   # a band: the rings' elevations
    hits = scene.cast(pose[:3, 3], world, layer="visual" if spec.visual else "collision",
                      max_distance=np.float32(spec.range_max), view=view)
    ranges = hits.distance.copy()
    ranges[ranges > spec.range_max] = np.inf
    too_near = ranges < spec.range_min
    ranges[too_near] = -np.inf
    valid = np.isfinite(ranges)

    noise = spec.noise
    if rng is not None and noise.type != "none" and (noise.stddev or noise.mean):
        count = int(valid.sum())
        noisy = ranges[valid] + rng.normal(noise.mean, noise.stddev, count).astype(np.float32)
        ranges[valid] = np.clip(noisy, spec.range_min, spec.range_max)
    if spec.range_resolution > 0:
        ranges[valid] = np.round(ranges[valid] / spec.range_resolution) * spec.range_resolution

    intensities = np.zeros(len(ranges), dtype=np.float32)
    if valid.any():
        surface = dot(scene.rgba[hits.shape[valid], :3], LUMINANCE)
        incidence = np.abs(np.einsum("ij,ij->i", hits.normal[valid], world[valid].astype(np.float32)))
        intensities[valid] = np.clip(surface * incidence, 0.0, 1.0)
    return RangeScan(ranges.reshape(shape), intensities.reshape(shape), beams)
