"""Cameras and range sensors declared in a URDF, as Gazebo users declare them.

``<gazebo reference="LINK"><sensor type="...">`` with Gazebo Classic's types ``camera``, ``depth``, ``ray``,
``gpu_ray`` and new Gazebo's ``rgbd_camera``, ``depth_camera``, ``lidar``, ``gpu_lidar``:

- ``<camera>``: ``<horizontal_fov>``, ``<image>`` (``width``, ``height``, ``format``), ``<clip>`` (``near``,
  ``far``), ``<noise>`` (gaussian, on intensities in [0, 1]);
- ``<ray>`` (Classic) or ``<lidar>`` (new Gazebo): ``<scan><horizontal|vertical>`` (``samples``,
  ``resolution``, ``min_angle``, ``max_angle``), ``<range>`` (``min``, ``max``, ``resolution``), ``<noise>``
  (gaussian, on ranges in metres);
- the gazebo_ros plugins that publish them: ``libgazebo_ros_camera.so`` (``<camera_name>``,
  ``<frame_name>``, ``<ros><namespace>``, ``<remapping>``) and ``libgazebo_ros_ray_sensor.so``
  (``<output_type>`` sensor_msgs/PointCloud2 or sensor_msgs/LaserScan, ``<frame_name>``, ``<ros>``).

``parse_rendered_sensors`` reads them into ``RenderedSensorSpec`` (refusing text where a number belongs);
``rendered_sensor_problems`` checks everything the renderer relies on and names the sensor and the field of
each problem: caps on pixels and rays, the field of view, the clip and range intervals, the rate, the format,
the link and the frame. The renderer (``nodes.render``) draws what these specs describe.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from lxml import etree

from nodes.urdf.sensors import (
    Noise,
    SensorDeclarationError,
    child_text,
    naming_problem,
    parse_noise,
    parse_number,
    plugin_name_problems,
    read_sensor_basics,
    resolve_topic,
    sensor_where,
)

CAMERA_TYPES = ("camera", "depth", "depth_camera", "rgbd_camera", "rgbd")
DEPTH_CAMERA_TYPES = ("depth", "depth_camera", "rgbd_camera", "rgbd")
RAY_TYPES = ("ray", "gpu_ray", "lidar", "gpu_lidar")
RENDERED_TYPES = CAMERA_TYPES + RAY_TYPES
# SDF <image><format> -> sensor_msgs/Image encoding (Gazebo Classic's names, new Gazebo's, and the ROS ones)
IMAGE_FORMATS = {
    "R8G8B8": "rgb8", "RGB_INT8": "rgb8", "rgb8": "rgb8",
    "B8G8R8": "bgr8", "BGR_INT8": "bgr8", "bgr8": "bgr8",
    "L8": "mono8", "L_INT8": "mono8", "mono8": "mono8",
}
CAMERA_PLUGIN = "libgazebo_ros_camera.so"
RAY_PLUGIN = "libgazebo_ros_ray_sensor.so"
RAY_OUTPUTS = {"sensor_msgs/PointCloud2": "points", "sensor_msgs/msg/PointCloud2": "points",
               "sensor_msgs/LaserScan": "scan", "sensor_msgs/msg/LaserScan": "scan"}
# Caps, checked before anything is allocated: a 1080p image, a million rays a scan.
MAX_PIXELS = 1920 * 1080
MAX_RAYS = 1_000_000
MAX_RANGE = 10_000.0   # m
DEFAULT_CAMERA_RATE = 30.0   # Hz, without an <update_rate>
DEFAULT_RAY_RATE = 10.0
# Bytes of the messages the renderer makes (``nodes.render.payloads`` lays them out): per pixel of an image by
# encoding, per point of a depth camera's organised cloud (x y z, rgb, padded) and of a lidar's (x y z intensity
# ring); per ray of a LaserScan, ranges and intensities as msgpack float64s (9 bytes each); plus the header and
# the other fields.
PIXEL_BYTES = {"rgb8": 3, "bgr8": 3, "mono8": 1, "32FC1": 4}
CAMERA_POINT_BYTES = 32
LIDAR_POINT_BYTES = 20
SCAN_RAY_BYTES = 18
MESSAGE_OVERHEAD_BYTES = 1024


@dataclass(frozen=True)
class CameraSpec:
    """A pinhole camera looking along the sensor frame's +x (Gazebo's convention), y left, z up."""

    horizontal_fov: float = 1.047            # rad
    width: int = 320
    height: int = 240
    encoding: str = "rgb8"                   # rgb8 | bgr8 | mono8
    near: float = 0.1                        # m
    far: float = 100.0                       # m
    depth: bool = False                      # also a 32FC1 depth image and an organised PointCloud2
    noise: Noise = Noise()                   # gaussian on intensities in [0, 1]
    format_text: str = "R8G8B8"              # as written, for messages

    @property
    def focal(self) -> float:
        """f = width / (2 tan(hfov / 2)), the same in x and y (square pixels), as gazebo_ros_camera has it."""
        return self.width / (2.0 * math.tan(self.horizontal_fov / 2.0))


@dataclass(frozen=True)
class RayAxis:
    """One axis of a scan: ``samples`` rays from ``min_angle`` to ``max_angle`` (rad), inclusive."""

    samples: int = 1
    resolution: float = 1.0
    min_angle: float = 0.0
    max_angle: float = 0.0

    @property
    def count(self) -> int:
        """Rays along this axis (Gazebo: samples x resolution)."""
        return max(1, round(self.samples * self.resolution))

    def angles(self) -> np.ndarray:
        if self.count == 1:
            return np.array([self.min_angle])
        return np.linspace(self.min_angle, self.max_angle, self.count)


@dataclass(frozen=True)
class RaySpec:
    """A laser range finder: horizontal angles about the sensor frame's z (0 along +x, counter-clockwise),
    vertical angles up from the x-y plane; one ring per vertical angle."""

    horizontal: RayAxis = RayAxis(640, 1.0, 0.0, 0.0)
    vertical: RayAxis = RayAxis()
    range_min: float = 0.1
    range_max: float = 30.0
    range_resolution: float = 0.01
    noise: Noise = Noise()                    # gaussian on ranges (m)
    output: str = "points"                    # points (PointCloud2) | scan (LaserScan)
    visual: bool = False                      # gpu_ray / gpu_lidar see visual geometry, ray / lidar collisions

    @property
    def rays(self) -> int:
        return self.horizontal.count * self.vertical.count


@dataclass
class RenderedSensorSpec:
    """One camera or range sensor of a robot, with where it publishes (Zenoh keys, ROS names without the
    leading slash) and the TF frame its messages name."""

    name: str
    type: str
    reference: str                                  # the <gazebo reference> link
    update_rate: float = 0.0                        # Hz (written <= 0 is refused: not every physics step)
    always_on: bool = True
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))   # sensor frame in the link frame
    camera: CameraSpec | None = None
    ray: RaySpec | None = None
    frame_id: str = ""                              # header.frame_id (the plugin's <frame_name>, else the link)
    keys: dict[str, str] = field(default_factory=dict)   # output -> key: image, camera_info, depth, depth_info,
                                                         # points, scan
    plugin: str = ""                                # the gazebo_ros plugin file, "" without one
    # the plugin's names as written: node name, <ros><namespace>, <remapping>s, <camera_name>
    plugin_names: tuple[str, str, dict[str, str], str] | None = None
    line: int | None = None
    update_rate_text: str | None = None

    @property
    def where(self) -> str:
        return sensor_where(self.name, self.line)


def _int(text: str | None, what: str, line: int | None) -> int:
    value = parse_number(text, what, line)
    if not math.isfinite(value) or value != int(value):
        raise SensorDeclarationError(f"{what}: '{(text or '').strip()[:80]}' is not a whole number", line)
    return int(value)


def _float_at(element: etree._Element, path: str, default: float, what: str) -> float:
    text = child_text(element, path)
    return default if text is None else parse_number(text, f"{what} <{path.replace('/', '><')}>", element.sourceline)


def _axis(element: etree._Element | None, default: RayAxis, where: str) -> RayAxis:
    if element is None:
        return default
    what = f"{where} <{element.tag}>"
    samples = child_text(element, "samples")
    return RayAxis(
        samples=default.samples if samples is None else _int(samples, f"{what} <samples>", element.sourceline),
        resolution=_float_at(element, "resolution", default.resolution, what),
        min_angle=_float_at(element, "min_angle", default.min_angle, what),
        max_angle=_float_at(element, "max_angle", default.max_angle, what))


def _camera(element: etree._Element, kind: str, where: str) -> CameraSpec:
    camera = element.find("camera")
    if camera is None:
        return CameraSpec(depth=kind in DEPTH_CAMERA_TYPES)
    what = f"{where} <camera>"
    image = camera.find("image")
    width, height, format_text = 320, 240, "R8G8B8"
    if image is not None:
        if child_text(image, "width") is not None:
            width = _int(child_text(image, "width"), f"{what} <image><width>", image.sourceline)
        if child_text(image, "height") is not None:
            height = _int(child_text(image, "height"), f"{what} <image><height>", image.sourceline)
        format_text = child_text(image, "format") or format_text
    noise = camera.find("noise")
    return CameraSpec(
        horizontal_fov=_float_at(camera, "horizontal_fov", 1.047, what), width=width, height=height,
        encoding=IMAGE_FORMATS.get(format_text, ""), format_text=format_text,
        near=_float_at(camera, "clip/near", 0.1, what), far=_float_at(camera, "clip/far", 100.0, what),
        depth=kind in DEPTH_CAMERA_TYPES,
        noise=parse_noise(noise, f"{what} <noise>") if noise is not None else Noise())


def _ray(element: etree._Element, kind: str, where: str, output: str) -> RaySpec:
    ray = element.find("ray")
    if ray is None:
        ray = element.find("lidar")
    visual = kind.startswith("gpu_")
    if ray is None:
        return RaySpec(output=output, visual=visual)
    what = f"{where} <{ray.tag}>"
    noise = ray.find("noise")
    return RaySpec(
        horizontal=_axis(ray.find("scan/horizontal"), RaySpec.horizontal, what),
        vertical=_axis(ray.find("scan/vertical"), RayAxis(), what),
        range_min=_float_at(ray, "range/min", 0.1, what), range_max=_float_at(ray, "range/max", 30.0, what),
        range_resolution=_float_at(ray, "range/resolution", 0.01, what),
        noise=parse_noise(noise, f"{what} <noise>") if noise is not None else Noise(), output=output, visual=visual)


def _remappings(plugin: etree._Element, where: str) -> dict[str, str]:
    out = {}
    for remap in plugin.findall("ros/remapping"):
        source, sep, target = (remap.text or "").strip().partition(":=")
        if not sep or not source or not target:
            raise SensorDeclarationError(f"{where} <plugin> <remapping> '{(remap.text or '')[:80]}' is not from:=to",
                                         remap.sourceline)
        out[source.strip()] = target.strip()
    return out


def _keys(spec: RenderedSensorSpec, plugin: etree._Element | None, namespace: str) -> dict[str, str]:
    """Where each output goes: the plugin's topics as gazebo_ros names them, or, without a plugin, new
    Gazebo's ``<topic>`` (default: the sensor's name) under the robot's namespace."""
    if plugin is None:
        base = resolve_topic(namespace, spec.name, spec.name, {})
        if spec.camera is not None:
            keys = {"image": f"{base}/image_raw", "camera_info": f"{base}/camera_info"}
            if spec.camera.depth:
                keys.update(depth=f"{base}/depth/image_raw", depth_info=f"{base}/depth/camera_info",
                            points=f"{base}/points")
            return keys
        return {spec.ray.output: f"{base}/{spec.ray.output}"}
    node = plugin.get("name") or spec.name
    written_namespace = (child_text(plugin, "ros/namespace") or "").strip()
    ros_namespace = written_namespace or namespace.strip()
    remappings = _remappings(plugin, spec.where)
    camera = child_text(plugin, "camera_name") or spec.name
    spec.plugin_names = (node, written_namespace, remappings, camera)
    if spec.camera is not None:   # gazebo_ros_camera: <camera_name> (default: the sensor's name) in the namespace
        keys = {"image": resolve_topic(ros_namespace, node, f"{camera}/image_raw", remappings),
                "camera_info": resolve_topic(ros_namespace, node, f"{camera}/camera_info", remappings)}
        if spec.camera.depth:
            keys.update(depth=resolve_topic(ros_namespace, node, f"{camera}/depth/image_raw", remappings),
                        depth_info=resolve_topic(ros_namespace, node, f"{camera}/depth/camera_info", remappings),
                        points=resolve_topic(ros_namespace, node, f"{camera}/points", remappings))
        return keys
    return {spec.ray.output: resolve_topic(ros_namespace, node, "~/out", remappings)}   # gazebo_ros_ray_sensor


def _parse(element: etree._Element, reference: str, namespace: str) -> RenderedSensorSpec:
    name, kind, line = element.get("name") or "", element.get("type") or "", element.sourceline
    where = sensor_where(name, line)
    spec = RenderedSensorSpec(name=name, type=kind, reference=reference, line=line)
    read_sensor_basics(element, spec, where, line)
    plugin = None
    for candidate in element.findall("plugin"):
        if (candidate.get("filename") or "") in (CAMERA_PLUGIN, RAY_PLUGIN):
            plugin = candidate
    spec.plugin = "" if plugin is None else plugin.get("filename") or ""
    if spec.update_rate_text is None:   # SDF's 0 would mean every physics step; a rendered sensor gets its usual rate
        spec.update_rate = DEFAULT_CAMERA_RATE if kind in CAMERA_TYPES else DEFAULT_RAY_RATE
    if kind in CAMERA_TYPES:
        spec.camera = _camera(element, kind, where)
    else:
        output = "points" if kind in ("lidar", "gpu_lidar") else "scan"
        if plugin is not None:
            written = child_text(plugin, "output_type")
            output = RAY_OUTPUTS.get(written, "") if written else "points"   # gazebo_ros: PointCloud2 by default
            if not output:
                raise SensorDeclarationError(f"{where} <plugin> <output_type> '{written[:80]}' is not one of "
                                             "sensor_msgs/PointCloud2, sensor_msgs/LaserScan", plugin.sourceline)
        spec.ray = _ray(element, kind, where, output)
    spec.frame_id = (child_text(plugin, "frame_name") if plugin is not None else None) or reference
    spec.keys = _keys(spec, plugin, namespace)
    return spec


def parse_rendered_sensors(root: etree._Element, namespace: str = "") -> list[RenderedSensorSpec]:
    """The camera and range sensors of every ``<gazebo reference=...>`` block; ``namespace`` is where a sensor
    without a ``<ros><namespace>`` publishes (the robot's)."""
    out = []
    for block in root.findall("gazebo"):
        reference = block.get("reference") or ""
        for element in block.findall("sensor"):
            if (element.get("type") or "") in RENDERED_TYPES:
                out.append(_parse(element, reference, namespace))
    return out


def _camera_problems(spec: RenderedSensorSpec) -> list[str]:
    camera, where = spec.camera, f"{spec.where} <camera>"
    problems = []
    if not camera.encoding:
        problems.append(f"{where} <image><format> '{camera.format_text[:40]}' is not one of "
                        f"{', '.join(sorted(IMAGE_FORMATS))}")
    if camera.width < 1 or camera.height < 1:
        problems.append(f"{where} <image> {camera.width}x{camera.height}: width and height must be at least 1")
    elif camera.width * camera.height > MAX_PIXELS:
        problems.append(f"{where} <image> {camera.width}x{camera.height} is {camera.width * camera.height} pixels, "
                        f"over the cap of {MAX_PIXELS} (1920x1080)")
    if not 0.0 < camera.horizontal_fov < math.pi:
        problems.append(f"{where} <horizontal_fov> {camera.horizontal_fov:g}: must be in (0, pi) rad")
    if not 0.0 < camera.near < camera.far <= MAX_RANGE:
        problems.append(f"{where} <clip> near {camera.near:g} far {camera.far:g}: needs 0 < near < far <= "
                        f"{MAX_RANGE:g} m")
    return problems


def _ray_problems(spec: RenderedSensorSpec) -> list[str]:
    ray, where = spec.ray, f"{spec.where} <ray>"
    problems = []
    for axis_name, axis in (("horizontal", ray.horizontal), ("vertical", ray.vertical)):
        what = f"{where} <scan><{axis_name}>"
        if axis.samples < 1:
            problems.append(f"{what} <samples> {axis.samples}: must be at least 1")
        if not (math.isfinite(axis.resolution) and axis.resolution > 0):
            problems.append(f"{what} <resolution> {axis.resolution:g}: must be positive")
        if not (math.isfinite(axis.min_angle) and math.isfinite(axis.max_angle)):
            problems.append(f"{what}: min_angle and max_angle must be finite")
        elif axis.min_angle > axis.max_angle:
            problems.append(f"{what} <min_angle> {axis.min_angle:g} > <max_angle> {axis.max_angle:g}")
        elif axis.max_angle - axis.min_angle > 2 * math.pi + 1e-9:
            problems.append(f"{what}: max_angle - min_angle {axis.max_angle - axis.min_angle:g} is over 2 pi")
    if not problems and ray.rays > MAX_RAYS:
        problems.append(f"{where} <scan>: {ray.horizontal.count} x {ray.vertical.count} = {ray.rays} rays a scan, "
                        f"over the cap of {MAX_RAYS}")
    if not 0.0 <= ray.range_min < ray.range_max <= MAX_RANGE:
        problems.append(f"{where} <range> min {ray.range_min:g} max {ray.range_max:g}: needs 0 <= min < max <= "
                        f"{MAX_RANGE:g} m")
    if not (math.isfinite(ray.range_resolution) and ray.range_resolution >= 0):
        problems.append(f"{where} <range><resolution> {ray.range_resolution:g}: must not be negative")
    return problems


def message_bytes(spec: RenderedSensorSpec) -> dict[str, int]:
    """The largest message each output of ``spec`` can make, in bytes (every pixel and every ray returned)."""
    out: dict[str, int] = {}
    if spec.camera is not None:
        pixels = spec.camera.width * spec.camera.height
        out["image"] = pixels * PIXEL_BYTES.get(spec.camera.encoding, 3) + MESSAGE_OVERHEAD_BYTES
        if spec.camera.depth:
            out["depth"] = pixels * PIXEL_BYTES["32FC1"] + MESSAGE_OVERHEAD_BYTES
            out["points"] = pixels * CAMERA_POINT_BYTES + MESSAGE_OVERHEAD_BYTES
    if spec.ray is not None:
        if spec.ray.output == "scan":
            out["scan"] = spec.ray.horizontal.count * SCAN_RAY_BYTES + MESSAGE_OVERHEAD_BYTES
        else:
            out["points"] = spec.ray.rays * LIDAR_POINT_BYTES + MESSAGE_OVERHEAD_BYTES
    return out


def message_size_problem(spec: RenderedSensorSpec, limit: int) -> str | None:
    """Why ``spec``'s messages could not be sent under a payload limit of ``limit`` bytes (receivers drop a
    bigger message unread), naming each output over it; None when all fit."""
    sizes = message_bytes(spec)
    over = {output: size for output, size in sizes.items() if size > limit}
    if not over:
        return None
    if spec.camera is not None:
        what = f"<camera> <image> {spec.camera.width}x{spec.camera.height}"
    else:
        what = f"<scan> {spec.ray.horizontal.count} x {spec.ray.vertical.count} rays"
    made = ", ".join(f"{spec.keys.get(output, output)} up to {size} bytes" for output, size in over.items())
    return (f"{spec.where} {what}: its messages would be too big to send ({made}), over the payload limit of "
            f"{limit} bytes (ZENROID_MAX_PAYLOAD_BYTES)")


def rendered_sensor_problems(specs: list[RenderedSensorSpec], links: dict | set, physics_rate: float | None = None,
                             taken: set[str] = frozenset()) -> list[str]:
    """Everything wrong with the specs, each problem naming the sensor and the field. ``links``: the robot's
    link names (sensors go on links; frames must be links TF publishes); ``physics_rate``: a sensor may not
    update faster than the physics steps; ``taken``: names of the robot's other sensors."""
    problems: list[str] = []
    seen = set(taken)
    for spec in specs:
        from nodes.core.names import shown, topic_problem  # here: no Zenoh for a robot without such sensors

        where = spec.where
        if (problem := naming_problem(spec.name, where, seen)) is not None:
            problems.append(problem)
            continue
        seen.add(spec.name)
        if spec.plugin_names is not None:
            node, namespace, remappings, camera = spec.plugin_names
            problems += plugin_name_problems(where, node, namespace, remappings, spec.frame_id)
            if spec.camera is not None and (problem := topic_problem(camera)) is not None:
                problems.append(f"{where} <plugin> <camera_name> {shown(camera)}: {problem}")
        if spec.reference not in links:
            problems.append(f"{where}: <gazebo reference={shown(spec.reference)}> is not a link of the robot")
        if spec.frame_id not in links:
            problems.append(f"{where} <plugin> <frame_name> {shown(spec.frame_id)} is not a link of the robot (a TF "
                            "frame the state publisher publishes)")
        rate, written = spec.update_rate, spec.update_rate_text or f"{spec.update_rate:g}"
        if not (math.isfinite(rate) and rate > 0):
            problems.append(f"{where} <update_rate> {written}: must be a positive number of Hz")
        elif physics_rate is not None and rate > physics_rate:
            problems.append(f"{where} <update_rate> {written}: over the physics rate ({physics_rate:g} Hz)")
        for channel, noise in (("camera noise", spec.camera.noise if spec.camera else None),
                               ("ray noise", spec.ray.noise if spec.ray else None)):
            if noise is None:
                continue
            if noise.type not in ("none", "gaussian", "gaussian_quantized"):
                problems.append(f"{where} {channel}: type '{noise.type}' is not gaussian")
            if not (math.isfinite(noise.stddev) and noise.stddev >= 0):
                problems.append(f"{where} {channel}: <stddev> {noise.stddev:g} must be finite and not negative")
            if not math.isfinite(noise.mean):
                problems.append(f"{where} {channel}: <mean> must be finite")
        if spec.plugin == CAMERA_PLUGIN and spec.camera is None:
            problems.append(f"{where} <plugin filename='{CAMERA_PLUGIN}'> belongs in a camera sensor, not {spec.type}")
        if spec.plugin == RAY_PLUGIN and spec.ray is None:
            problems.append(f"{where} <plugin filename='{RAY_PLUGIN}'> belongs in a ray sensor, not {spec.type}")
        if spec.camera is not None:
            problems += _camera_problems(spec)
        if spec.ray is not None:
            problems += _ray_problems(spec)
    return problems
