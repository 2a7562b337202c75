"""A pinhole camera (colour, depth, organised points) drawn by casting one ray per pixel.

Conventions, as Gazebo Classic and gazebo_ros_camera have them:

- the sensor frame looks along +x, y left, z up; the optical frame (what ``CameraInfo`` and the images are
  in) is x right, y down, z forward, i.e. rpy(-pi/2, 0, -pi/2) from the sensor frame;
- intrinsics: f = width / (2 tan(hfov / 2)) for fx and fy, cx = (width + 1) / 2, cy = (height + 1) / 2
  (gazebo_ros_camera's values). Pixel (u, v), 0-based column and row, is cast along the optical direction
  ((u - cx) / f, (v - cy) / f, 1): the very intrinsics ``CameraInfo`` carries, so back-projecting a depth
  pixel with K gives the surface point the ray hit;
- depth is the distance along the optical axis (optical z), not the ray length; REP 117: -inf where the
  surface is nearer than ``near``, +inf where there is none or it is beyond ``far``. Those pixels show the
  background colour, as a real clip plane shows the clear colour there.

Shading: a shape's colour times (``AMBIENT`` + ``DIFFUSE`` max(0, n . -light)), with a directional light
along ``LIGHT_DIRECTION`` (Gazebo's default sun, (-0.5, 0.1, -0.9) normalised): a face keeps its colour's hue
and shows between 0.6 and 1.0 times its brightness, so colours are recognisable and faces distinguishable.
No shadows, no specular, alpha ignored (every shape is opaque). The background (no hit) is ``BACKGROUND``,
Gazebo Classic's default sky grey (0.7, 0.7, 0.7).

Noise (Gazebo's gaussian image noise): each channel's intensity in [0, 1] gets N(mean, stddev), drawn from
the ``rng`` the caller passes (``None``: no noise, an ideal camera), then clipped; mono8 gets it on its one
channel, after the luminance (0.299 r + 0.587 g + 0.114 b).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from nodes.render.geometry import RenderError, dot, rotate
from nodes.render.raycast import RayScene, View
from nodes.urdf.rendered_sensors import CameraSpec

LIGHT_DIRECTION = np.array([-0.5, 0.1, -0.9]) / np.linalg.norm([-0.5, 0.1, -0.9])   # where sunlight travels
AMBIENT = 0.6
DIFFUSE = 0.4
BACKGROUND = (0.7, 0.7, 0.7)
LUMINANCE = np.array([0.299, 0.587, 0.114], dtype=np.float32)
# optical frame (x right, y down, z forward) -> sensor frame (x forward, y left, z up)
OPTICAL_TO_SENSOR = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
ENCODINGS = ("rgb8", "bgr8", "mono8")


@dataclass
class CameraImage:
    """One rendered frame: ``color`` (H, W, 3) uint8 in the spec's channel order (rgb8, bgr8) or (H, W)
    for mono8; with a depth camera, ``depth`` (H, W) float32 metres along the optical axis (REP 117 -inf /
    +inf) and ``points`` (H, W, 3) float32 in the optical frame (NaN where the depth is not finite; None
    when not asked for);
    ``encoding`` is the spec's, for ``rgb``."""

    color: np.ndarray
    depth: np.ndarray | None = None
    points: np.ndarray | None = None
    encoding: str = "rgb8"

    @property
    def rgb(self) -> np.ndarray:
        """``color`` as (H, W, 3) uint8 in r g b order, what a point cloud's rgb field packs: the image
        itself for rgb8, its channels reversed (a view) for bgr8, the grey value in all three for mono8."""
        if self.encoding == "bgr8":
            return self.color[..., ::-1]
        if self.encoding == "mono8":
            return np.repeat(self.color[..., None], 3, axis=2)
        return self.color


def intrinsics(spec: CameraSpec) -> tuple[float, float, float]:
    """(f, cx, cy) in pixels, as gazebo_ros_camera puts them in CameraInfo."""
    return spec.focal, (spec.width + 1) / 2.0, (spec.height + 1) / 2.0


@dataclass(frozen=True)
class _Rays:
    sensor: np.ndarray     # (H * W, 3) float32 unit directions in the sensor frame, row-major pixels
    optical: np.ndarray    # (H * W, 3) float32 unit directions in the optical frame
    axial: np.ndarray      # (H * W,) float32: optical z of the unit direction (depth = ray length * axial)


@functools.lru_cache(maxsize=16)
def _rays(horizontal_fov: float, width: int, height: int) -> _Rays:
    spec = CameraSpec(horizontal_fov=horizontal_fov, width=width, height=height)
    f, cx, cy = intrinsics(spec)
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    optical = np.stack([(u - cx) / f, (v - cy) / f, np.ones_like(u)], axis=-1).reshape(-1, 3)
    optical /= np.linalg.norm(optical, axis=1)[:, None]
    rays = _Rays(rotate(optical, OPTICAL_TO_SENSOR).astype(np.float32), optical.astype(np.float32),
                 optical[:, 2].astype(np.float32))
    for array in (rays.sensor, rays.optical, rays.axial):
        array.flags.writeable = False      # shared by every render of this geometry
    return rays


def _noisy(image: np.ndarray, spec: CameraSpec, rng: np.random.Generator | None) -> np.ndarray:
    noise = spec.noise
    if rng is None or noise.type == "none" or not (noise.stddev or noise.mean):
        return image
    image = image + rng.normal(noise.mean, noise.stddev, image.shape).astype(np.float32)
    return np.clip(image, 0.0, 1.0, out=image)


def render_camera(scene: RayScene, spec: CameraSpec, sensor_pose: np.ndarray,
                  rng: np.random.Generator | None = None, *, with_points: bool = True) -> CameraImage:
    """The camera described by ``spec`` at ``sensor_pose`` (4x4 world pose of its sensor frame: +x forward)
    in ``scene``'s visual layer; noise from ``rng`` if the spec has some (``None``: none). ``with_points``
    False leaves a depth camera's ``points`` out (None): nobody asked for its cloud, 1 ms a 320x240 frame."""
    if spec.encoding not in ENCODINGS:
        raise RenderError(f"camera encoding '{spec.encoding}' is not one of {', '.join(ENCODINGS)}")
    rays = _rays(float(spec.horizontal_fov), int(spec.width), int(spec.height))
    pose = np.asarray(sensor_pose, dtype=np.float64)
    directions = rotate(rays.sensor, pose[:3, :3].astype(np.float32))
    # the far clip plane is a depth: along a slanted ray it is at far / axial
    # what it can see: a cone about its axis as wide as the image's half diagonal
    half_diagonal = math.atan(math.hypot(math.tan(spec.horizontal_fov / 2), spec.height / (2 * spec.focal)))
    view = View(origin=pose[:3, 3], rotation=pose[:3, :3], far=float(spec.far), half_angle=half_diagonal)
    hits = scene.cast(pose[:3, 3], directions, layer="visual", max_distance=np.float32(spec.far) / rays.axial,
                      view=view)
    depth = hits.distance * rays.axial                                   # +inf stays +inf
    depth[depth > spec.far] = np.inf
    too_near = depth < spec.near
    seen = np.isfinite(depth) & ~too_near
    depth[too_near] = -np.inf

    shade = AMBIENT + DIFFUSE * np.maximum(0.0, dot(hits.normal, -LIGHT_DIRECTION.astype(np.float32)))
    colour = np.empty((len(depth), 3), dtype=np.float32)
    colour[:] = BACKGROUND
    colour[seen] = scene.rgba[hits.shape[seen], :3] * shade[seen, None]
    h, w = spec.height, spec.width
    if spec.encoding == "mono8":
        image = _noisy(dot(colour, LUMINANCE).reshape(h, w), spec, rng)
    else:
        image = _noisy(colour.reshape(h, w, 3), spec, rng)
        if spec.encoding == "bgr8":
            image = image[..., ::-1]
    color = np.ascontiguousarray(np.clip(image * 255.0 + 0.5, 0.0, 255.0).astype(np.uint8))
    if not spec.depth:
        return CameraImage(color, encoding=spec.encoding)
    depth = depth.reshape(h, w).astype(np.float32, copy=False)
    if not with_points:
        return CameraImage(color, depth, None, spec.encoding)
    points = rays.optical * np.where(seen, hits.distance, np.float32(np.nan))[:, None]
    return CameraImage(color, depth, points.reshape(h, w, 3).astype(np.float32, copy=False), spec.encoding)
