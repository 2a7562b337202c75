"""The renderer process: draws the robots' cameras, depth cameras, lidars and lasers on the CPU and publishes
them as gazebo_ros' camera and ray plugins do (``sensor_msgs/Image``, ``CameraInfo``, ``PointCloud2``,
``LaserScan``), stamped with the sim time of the state they show.

It reads the simulator's ``sim/scene`` (every model's shapes, and each robot's URDF, whose sensor tags it parses
with ``nodes.urdf.rendered_sensors``) and its ``sim/render/frame``s (link poses at an instant, and the sensors
due then), and answers each frame with ``sim/render/done``. In lockstep it draws every frame in order; in
realtime the newest frame of each sensor, so a renderer that falls behind drops pictures, not physics time.
A stream nobody subscribes to is not drawn (as gazebo_ros' lazy plugins), and every answer names the sensors
somebody subscribes to (unprompted too, within ``WANTED_POLL_S`` of a change), so that the simulator sends
frames for those only. Noise comes from a generator seeded by (``seed``, sensor, step): the same run gives the
same bytes.
"""

from __future__ import annotations

import time
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

import msgs
from nodes.core import Node, memory
from nodes.core.delivery import Pulled
from nodes.meshes import MeshError
from nodes.meshes.convert import by_reference
from nodes.render import payloads
from nodes.render.camera import render_camera
from nodes.render.geometry import (
    MAX_SCENE_TRIANGLES,
    RenderError,
    Shape,
    mesh_from_bytes,
    triangle_count,
    triangulate,
)
from nodes.render.lidar import render_ray
from nodes.render.raycast import RayScene
from nodes.urdf.rendered_sensors import RenderedSensorSpec, parse_rendered_sensors
from nodes.urdf.sensors import SensorDeclarationError
from nodes.urdf.xml_safety import parse_xml

Scene = msgs.get_type("zenroid_msgs/msg/Scene")
RenderFrame = msgs.get_type("zenroid_msgs/msg/RenderFrame")
RenderDone = msgs.get_type("zenroid_msgs/msg/RenderDone")
MESSAGE_TYPES = {
    "image": "sensor_msgs/msg/Image", "depth": "sensor_msgs/msg/Image", "camera_info": "sensor_msgs/msg/CameraInfo",
    "depth_info": "sensor_msgs/msg/CameraInfo", "points": "sensor_msgs/msg/PointCloud2",
    "scan": "sensor_msgs/msg/LaserScan",
}
KINDS = {1: "box", 2: "cylinder", 3: "sphere", 4: "mesh"}
FRAME_BACKLOG = 64   # frames waiting to be drawn (lockstep keeps at most a few in flight)
WANTED_POLL_S = 0.01   # wall s between looks at which sensors have a subscriber (told unprompted on a change)
WANTED_REPEAT_S = 1.0  # ... and told again this often, changed or not (a simulator that started since)


@dataclass
class _Sensor:
    key: str                                  # "model::sensor"
    spec: RenderedSensorSpec
    link: int                                 # index into the scene's links
    publishers: dict[str, Any] = field(default_factory=dict)   # output -> publisher
    packers: dict[str, Any] = field(default_factory=dict)
    drawn: int = 0


def _matrix(pose: Any) -> np.ndarray:
    p, q = pose.position, pose.orientation
    x, y, z, w = q.x, q.y, q.z, q.w
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = (p.x, p.y, p.z)
    return m


class RendererNode(Node):
    """CPU renderer of the simulator's cameras, depth cameras, lidars and lasers (no GPU, no display)."""

    default_name = "renderer"
    callbacks_on_spin_thread = True   # a new scene replaces the publishers: never while a frame is drawn

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("renderer", **kwargs)
        self.seed = int(self.declare_parameter("seed", 0, type=int, min_value=0, max_value=2**63 - 1,
                                               description="seed of the sensors' noise (the same seed, the "
                                               "same noise)", read_only=True))
        self.threads = int(self.declare_parameter("threads", 1, type=int, min_value=1, max_value=8,
                                                  description="threads casting one picture's rays",
                                                  read_only=True))
        self.scene: RayScene | None = None
        self.scene_version = -1
        self.link_names: list[str] = []
        self.sensors: dict[str, _Sensor] = {}
        self.done_pub = self.create_publisher(RenderDone, "/sim/render/done")
        # only the newest scene matters: a burst of spawns and deletes must not queue one build after another
        self.scenes = self.create_subscription(Scene, "/sim/scene", self._on_scene,
                                               delivery=Pulled(backlog=1))
        self.frames = self.create_subscription(RenderFrame, "/sim/render/frame", self._queue_frame,
                                               delivery=Pulled(backlog=FRAME_BACKLOG))
        self._pending: list[Any] = []
        self._skipped: set[tuple[str, str, str]] = set()   # shapes left out, said once each
        self._next_resync = 0.0
        self._last_step = 0
        self._told: list[str] | None = None   # the wanted sensors last sent to the simulator
        self._next_look = self._next_tell = 0.0
        latched = self.fetch_latched(Scene, "/sim/scene", timeout=2.0)
        if latched is not None:
            self._on_scene(latched)
        self.logger.info("renderer ready" + (f": {len(self.sensors)} sensor(s)" if self.sensors else
                                             ", waiting for a scene with cameras or range sensors"))

    # -- the scene ----------------------------------------------------------------------------------------
    def _on_scene(self, scene: Any) -> None:
        if int(scene.version) == self.scene_version:
            return
        try:
            shapes = self._usable_shapes(scene)
            static_models = {i for i, static in enumerate(scene.static_models) if static}
            static_links = {i for i, model in enumerate(scene.link_models) if int(model) in static_models}
            ray_scene = RayScene(list(scene.links), shapes, static_links, threads=self.threads)
            sensors = self._sensors(scene)
        except (RenderError, SensorDeclarationError, ValueError) as exc:
            self.logger.error(f"sim/scene version {scene.version} refused: {exc}; keeping the previous scene")
            return
        for old in self.sensors.values():
            for publisher in old.publishers.values():
                self.destroy_entity(publisher)
        previous = self.scene
        self.scene, self.scene_version, self.link_names, self.sensors = ray_scene, int(scene.version), \
            list(scene.links), sensors
        if previous is not None:
            previous.close()    # its casting threads end with it
        memory.release_soon()   # the previous scene's geometry and BVH back to the system
        if sensors:
            self.logger.info(f"scene {scene.version}: {len(scene.models)} models, {len(shapes)} shapes; sensors "
                             + ", ".join(f"{s.key} ({s.spec.type}, {s.spec.update_rate:g} Hz -> "
                                         f"{', '.join(s.spec.keys.values())})" for s in sensors.values()))

    def _usable_shapes(self, scene: Any) -> list[tuple[int, Shape]]:
        """The scene's shapes the renderer can draw. One it cannot (a bad mesh, a size, over a triangle cap)
        is left out and said once on rosout, with its model, link and file: the rest is still drawn."""
        shapes: list[tuple[int, Shape]] = []
        total = 0
        for entry in scene.shapes:
            link = int(entry.link)
            name = scene.links[link] if 0 <= link < len(scene.links) else f"link #{link}"
            try:
                if not 0 <= link < len(scene.links):
                    raise RenderError(f"link index {link} is not one of the {len(scene.links)} links")
                shape = self._shape(entry)
                shape.name = name
                triangulate(shape)
                if not np.isfinite(shape.pose).all():
                    raise RenderError("its pose is not finite")
                count = triangle_count(shape)
                if total + count > MAX_SCENE_TRIANGLES:
                    raise RenderError(f"{count} more triangles would pass the scene's cap of {MAX_SCENE_TRIANGLES}")
            except (RenderError, ValueError, TypeError) as exc:
                model, _, link_name = name.partition("::")
                source = f" mesh {entry.mesh_uri!r}" if entry.mesh_uri else ""
                key = (name, entry.mesh_uri, str(exc))
                if key not in self._skipped:
                    self._skipped.add(key)
                    self.logger.warn(f"model {model!r} link {link_name!r}{source}: not drawn ({exc}); the rest of "
                                     "the scene is")
                continue
            total += count
            shapes.append((link, shape))
        return shapes

    @staticmethod
    def _shape(entry: Any) -> Shape:
        kind = KINDS.get(int(entry.kind))
        if kind is None:
            raise RenderError(f"shape of link {entry.link}: kind {entry.kind} is not one of {sorted(KINDS)}")
        vertices = triangles = None
        if kind == "mesh" and not entry.vertices and entry.mesh_uri:   # too big for the scene: by reference
            try:
                vertices, triangles = by_reference(entry.mesh_uri, entry.size)
            except MeshError as exc:
                raise RenderError(str(exc)) from None
        elif kind == "mesh":
            vertices, triangles = mesh_from_bytes(bytes(entry.vertices), bytes(entry.triangles))
        color = entry.color
        return Shape(kind=kind, size=tuple(float(v) for v in entry.size), pose=_matrix(entry.pose),
                     rgba=(color.r, color.g, color.b, color.a), visual=bool(entry.visual),
                     collision=bool(entry.collision), vertices=vertices, triangles=triangles)

    def _sensors(self, scene: Any) -> dict[str, _Sensor]:
        out: dict[str, _Sensor] = {}
        links = {name: i for i, name in enumerate(scene.links)}
        for model, namespace, description in zip(scene.models, scene.namespaces, scene.descriptions):
            if not description:
                continue
            for spec in parse_rendered_sensors(parse_xml(description.encode()), namespace):
                link = links.get(f"{model}::{spec.reference}")
                if link is None or not spec.always_on:
                    continue
                key = f"{model}::{spec.name}"
                sensor = _Sensor(key, spec, link)
                for output, topic in spec.keys.items():
                    type_name = MESSAGE_TYPES[output]
                    sensor.publishers[output] = self.create_publisher(msgs.get_type(type_name), f"/{topic}")
                    sensor.packers[output] = msgs.packer(type_name)
                out[key] = sensor
        return out

    # -- frames -------------------------------------------------------------------------------------------
    def _queue_frame(self, frame: Any) -> None:
        self._pending.append(frame)

    def _next_jobs(self) -> list[tuple[Any, list[str]]]:
        """(frame, sensors) to draw now: every frame in order in lockstep, else each sensor's newest frame."""
        pending, self._pending = self._pending, []
        if not pending:
            return []
        if all(frame.lockstep for frame in pending):
            return [(frame, list(frame.sensors)) for frame in pending]
        newest: dict[str, Any] = {}
        for frame in pending:
            for key in frame.sensors:
                newest[key] = frame
        jobs: dict[int, tuple[Any, list[str]]] = {}
        for key, frame in newest.items():
            jobs.setdefault(id(frame), (frame, []))[1].append(key)
        return sorted(jobs.values(), key=lambda job: job[0].step)

    def render_frame(self, frame: Any, keys: list[str]) -> int:
        """Draw ``keys`` as ``frame`` shows them; returns the messages published."""
        if int(frame.scene_version) != self.scene_version:
            self._await_scene(int(frame.scene_version))
        if self.scene is None or int(frame.scene_version) != self.scene_version:
            return 0   # a frame of another scene (one replaced since): its links do not match ours
        poses = np.asarray(frame.poses, dtype=np.float64)
        if poses.size != 12 * len(self.link_names):
            self.logger.warn_throttle(5.0, f"sim/render/frame: {poses.size} pose values for "
                                      f"{len(self.link_names)} links: ignored", key="frame_size")
            return 0
        transforms = np.tile(np.eye(4), (len(self.link_names), 1, 1))
        transforms[:, :3, :] = poses.reshape(-1, 3, 4)
        wanted = [(self.sensors[k], outputs) for k in keys if k in self.sensors
                  if (outputs := [o for o, p in self.sensors[k].publishers.items() if p.has_subscribers])]
        if not wanted:
            return 0
        self.scene.update(transforms)
        stamp = {"sec": int(frame.stamp.sec), "nanosec": int(frame.stamp.nanosec)}
        published = 0
        for sensor, outputs in wanted:
            rng = np.random.default_rng([self.seed, zlib.crc32(sensor.key.encode()), int(frame.step)])
            pose = transforms[sensor.link] @ sensor.spec.pose
            for output, payload in self._draw(sensor, outputs, pose, stamp, rng):
                # realtime: a congested subscriber loses pictures (ROS's sensor-data QoS is best effort), it
                # never holds the renderer up; lockstep: every picture is delivered, as every frame is drawn
                sensor.publishers[output].publish_raw(sensor.packers[output](**payload), droppable=not frame.lockstep)
                published += 1
            sensor.drawn += 1
        return published

    def _await_scene(self, version: int, timeout: float = 2.0) -> None:
        """A frame of another scene than ours. A newer one was published before the frame: take it first (the
        subscription's callback may still be queued). Otherwise ours is not the simulator's (a scene someone
        else published on sim/scene): ask the simulator's latched one, at most once a second."""
        deadline = time.monotonic() + timeout
        while self.scene_version < version and time.monotonic() < deadline:
            if self.scenes.take_pending():
                continue
            if not self.spin_once(0.05):
                break
        if self.scene_version == version or time.monotonic() < self._next_resync:
            return
        self._next_resync = time.monotonic() + 1.0
        latched = self.fetch_latched(Scene, "/sim/scene", timeout=0.5)
        if latched is not None and int(latched.version) == version:
            self.logger.warn(f"sim/scene: version {self.scene_version} is not the simulator's ({version}): "
                             "taking the simulator's again")
            self.scene_version = -1
            self._on_scene(latched)

    def _draw(self, sensor: _Sensor, outputs: list[str], pose: np.ndarray, stamp: dict, rng: np.random.Generator):
        spec, frame_id = sensor.spec, sensor.spec.frame_id
        if spec.camera is not None:
            camera = spec.camera
            picture = render_camera(self.scene, camera, pose, rng, with_points="points" in outputs)
            if "image" in outputs:
                yield "image", payloads.image(stamp, frame_id, picture.color, camera.encoding)
            for info in ("camera_info", "depth_info"):
                if info in outputs:
                    yield info, payloads.camera_info(stamp, frame_id, camera)
            if "depth" in outputs:
                yield "depth", payloads.image(stamp, frame_id, picture.depth, "32FC1")
            if "points" in outputs:
                yield "points", payloads.camera_points(stamp, frame_id, picture.points, picture.rgb)
            return
        ray = spec.ray
        scan = render_ray(self.scene, ray, pose, rng)
        if "points" in outputs:
            xyz, intensity, ring = scan.points()
            yield "points", payloads.lidar_points(stamp, frame_id, xyz, intensity, ring)
        if "scan" in outputs:
            middle = ray.vertical.count // 2
            yield "scan", payloads.laser_scan(stamp, frame_id, ray, scan.ranges[middle], scan.intensities[middle],
                                              1.0 / spec.update_rate)

    def wanted(self) -> list[str]:
        """The sensors with a subscriber to one of their outputs now."""
        return sorted(k for k, sensor in self.sensors.items() if any(p.has_subscribers for p in sensor.publishers.values()))

    def _answer(self, step: int, published: int, wanted: list[str] | None = None) -> None:
        self._told = self.wanted() if wanted is None else wanted
        self._next_tell = time.monotonic() + WANTED_REPEAT_S
        self.done_pub.publish(RenderDone(step=step, published=published, wanted=self._told))

    def _tell_wanted_if_changed(self) -> None:
        now = time.monotonic()
        if now < self._next_look:
            return
        self._next_look = now + WANTED_POLL_S
        wanted = self.wanted()
        if now >= self._next_tell or wanted != self._told:
            self._answer(self._last_step, 0, wanted)

    def spin(self) -> None:
        """Take frames as they come; draw; answer each with sim/render/done."""
        while self.ok:
            if not self._pending:
                self.frames.wait(WANTED_POLL_S)
            self.spin_once(0.0)
            self.scenes.take_pending()
            self._tell_wanted_if_changed()
            for frame, keys in self._next_jobs():
                try:
                    published = self.render_frame(frame, keys)
                except (RenderError, ValueError) as exc:
                    self.logger.error(f"frame at step {frame.step}: {exc}")
                    published = 0
                except Exception as exc:  # noqa: BLE001 - one bad frame must not end the sensors
                    self.logger.error(f"frame at step {frame.step}: {type(exc).__name__}: {exc}")
                    published = 0
                self._last_step = int(frame.step)
                self._answer(self._last_step, published)
