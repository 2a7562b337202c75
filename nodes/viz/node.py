"""The viewer node: subscribes to the robots' Zenoh keys and writes them to Rerun.

It needs nothing but the keys (docs/architecture.md, Key expressions): ``<ns>/robot_description`` (topic + latched queryable),
``<ns>/tf``, ``<ns>/tf_static``, ``<ns>/joint_states``, ``<ns>/<jtc>/controller_state``,
``<ns>/<jtc>/joint_trajectory``, ``<ns>/humanoid_state``, ``sim/model_states`` and ``sim/clock``; the world
from ``sim/scene`` (latched) and ``sim/link_states``; a robot's body sensors (any ``sensor_msgs/Imu`` and
``geometry_msgs/WrenchStamped`` under its namespace) and the cameras, lidars and lasers its URDF declares
(the renderer's ``Image``, ``CameraInfo``, ``PointCloud2`` and ``LaserScan`` keys).
Robots come from the ``robots`` parameter, from the models in ``sim/model_states`` and from the node
graph (anyone publishing ``<ns>/robot_description`` or ``<ns>/joint_states``). It only subscribes, so it
cannot slow the control loop; every stream has its own rate limit and excess messages are dropped.
"""

from __future__ import annotations

import argparse
import functools
import math
import queue
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import rerun as rr

import msgs
from msgs.control_msgs import JointTrajectoryControllerState as ControllerState
from msgs.gazebo_msgs import ContactsState, LinkStates, ModelStates
from msgs.geometry_msgs import WrenchStamped
from msgs.humanoid_msgs import HumanoidState
from msgs.rosgraph_msgs import Clock
from msgs.sensor_msgs import CameraInfo, Image, Imu, JointState, LaserScan, PointCloud2
from msgs.std_msgs import String
from msgs.tf2_msgs import TFMessage
from msgs.trajectory_msgs import JointTrajectory
from msgs.visualization_msgs import Marker, MarkerArray
from msgs.zenroid_msgs import Scene
from nodes.core import Node, Subscription
from nodes.core import graph as core_graph
from nodes.core.delivery import Inline, Raw
from nodes.core.latched import fetch_latched
from nodes.urdf.model import UrdfError
from nodes.urdf.rendered_sensors import RenderedSensorSpec, parse_rendered_sensors
from nodes.urdf.sensors import SensorDeclarationError
from nodes.urdf.xml_safety import parse_xml

from .blueprint import PLOT_TABS, QUANTITY_TABS, RobotLayout, build_blueprint
from .images import SensorDataError
from .markers import MarkerError, MarkerLayer
from .pulls import FramePull
from .ratelimit import RateLimiter
from .scene import SIM_TIMELINE, WALL_TIMELINE, RobotScene, SceneTime, is_wall_stamp, parse_model
from .sensors import (
    RenderedSensors,
    camera_entity,
    camera_frame,
    contact_points,
    force_arrow,
    imu_columns,
    range_points,
    sensor_part,
    to_world,
)
from .sink import Output, OutputPlan
from .world import WorldModels, WorldProblem, read_scene

MARKER_TYPES = {"visualization_msgs/msg/Marker": Marker, "visualization_msgs/msg/MarkerArray": MarkerArray}
# RViz's default marker topics (global and per robot), and seed 002's trajectory marker topic.
GLOBAL_MARKER_TOPICS = {"visualization_marker": Marker, "visualization_marker_array": MarkerArray,
                        "visualization/trajectory": Marker}
# Body sensors found in the graph under a robot's namespace, and the main job's keys (subscribed at once).
BODY_SENSOR_TYPES = {"sensor_msgs/msg/Imu": "imu", "geometry_msgs/msg/WrenchStamped": "wrench",
                     "gazebo_msgs/msg/ContactsState": "contacts"}
DEFAULT_BODY_SENSORS = {"imu": ["imu_sensor_broadcaster/imu"],
                        "wrench": ["left_foot_ft_broadcaster/wrench", "right_foot_ft_broadcaster/wrench"],
                        "contacts": ["left_foot/contacts", "right_foot/contacts"]}

DISCOVERY_PERIOD = 2.0
LATEST_FRESH = 1.0  # s a controller_state or humanoid_state stays in the plot rows after it stops coming
LAYOUT_SETTLE = 1.0  # s the plot layout must stay the same before the blueprint is sent again
LAYOUT_WAIT = 5.0  # ... and, while a robot's joints (or any robot) are still unknown, before it is sent anyway


@dataclass
class Latest:
    """The newest message on a stream, kept undecoded until a plot row needs it (most are never decoded)."""

    arrived: float  # monotonic
    payload: bytes
    decoded: Any = None


@dataclass
class LatchedStream:
    """A stream of which only the newest message is kept (``Viewer.latch``)."""

    msg_type: Any
    key: str  # for log lines, without the leading slash
    newest: Latest | None = None


@dataclass
class RobotView:
    """One robot namespace: its subscriptions, its Rerun scene (once the URDF is known) and its limits."""

    namespace: str
    subscriptions: list[Subscription] = field(default_factory=list)
    controllers: dict[str, list[Subscription]] = field(default_factory=dict)
    scene: RobotScene | None = None
    description: str = ""
    present: bool = True
    in_sim: bool = False  # seen in sim/model_states: its disappearance there means it was deleted
    has_balance: bool = False
    tf_seen: bool = False
    pending_static: list = field(default_factory=list)  # tf_static rows that came before the scene
    limits: dict[str, RateLimiter] = field(default_factory=dict)
    # "humanoid_state", "controller:<name>", "imu:<key>", "wrench:<key>", "image:<camera>", "depth:<camera>",
    # "info:<camera>", "range:<key>"
    latest: dict[str, LatchedStream] = field(default_factory=dict)
    body_sensors: dict[str, tuple[str, Subscription]] = field(default_factory=dict)  # key -> ("imu" | "wrench", sub)
    imus: dict[str, str] = field(default_factory=dict)  # key -> column part, once it has sent data
    pulls: list[FramePull] = field(default_factory=list)  # the URDF's cameras, and its lidars and lasers together
    cameras: dict[str, RenderedSensorSpec] = field(default_factory=dict)  # camera name -> its spec
    ranges: dict[str, str] = field(default_factory=dict)  # key -> "points" | "scan"
    sensors: RenderedSensors | None = None
    last_positions: dict[str, float] = field(default_factory=dict)
    first_state: float = 0.0  # monotonic time of the first joint_states with a model


class Viewer(Node):
    """RViz and rqt_plot on Rerun: robot model, link frames, joint plots and markers."""

    default_name = "viewer"

    def __init__(self, cli_args: argparse.Namespace | None = None, **kwargs: Any) -> None:
        super().__init__("viewer", **kwargs)
        p = self.declare_parameter
        self.robot_list = [r.strip("/") for r in p("robots", [""], description="robot namespaces to show") if r]
        if cli_args is not None and getattr(cli_args, "robots", ""):
            self.robot_list += [r.strip().strip("/") for r in cli_args.robots.split(",") if r.strip()]
        self.discover = p("discover", True, description="also show robots found in sim/model_states and the graph")
        self.controller_names = [c for c in p(
            "controllers", ["joint_trajectory_controller"],
            description="trajectory controllers to plot (more are discovered from the graph)") if c]
        self.end_effectors = [e for e in p("end_effectors", [""], description="links whose paths are drawn "
                                           "(default: the URDF's leaf links)") if e]
        self.world_frames = [w for w in p("world_frames", ["world", "map", "odom"],
                                          description="tf frames drawn as the scene root") if w]
        # Rates and batching come from measuring a software-rendered browser on a 2-core machine
        # (bench/viz.py; docs/viewer.md): what it can take in while staying within 1 s of the simulation.
        self.rates = {
            "joint_states": p("joint_states_rate", 10.0, min_value=0.0, description=(
                "Hz of the plot rows: positions, velocities, efforts, the latest commanded vs actual and balance")),
            "tf": p("tf_rate", 10.0, description="Hz", min_value=0.0),
            "model_states": p("model_states_rate", 10.0, description="Hz", min_value=0.0),
            "markers": p("marker_rate", 2.0, description="Hz of the markers (paths, CoM, support polygon)",
                         min_value=0.0),
        }
        self.keyframe_period = p("keyframe_period", 2.0, min_value=0.1, description=(
            "s between re-logs of every robot's model and frames (a late viewer gets only recent history)"))
        flush_period = p("flush_period", 0.5, min_value=0.0, max_value=2.0, description=(
            "s the recording batches rows before sending (fewer, larger chunks for the viewer to take in)"))
        self.show_ground = p("ground", True, description="draw the ground grid (off for joint_animation)")
        self.plots = [t for t in p("plots", list(PLOT_TABS), choices=PLOT_TABS, description=(
            f"the plot tabs beside the 3-D scene, of {', '.join(PLOT_TABS)} (each costs a late viewer time to "
            "take in; [] for the scene alone)")) if t]
        self.quantities = [q for tab, q in QUANTITY_TABS.items() if tab in self.plots]
        self.tf_fallback_after = p("tf_fallback_after", 1.0, min_value=0.0,
                                   description="s of joint_states without tf before frames come from our FK")
        # The world and the sensors (issues 25-27): each rendered-sensor entity costs a page one chunk per
        # flush, so images and clouds come at a few Hz, images JPEG-compressed (docs/viewer.md).
        self.show_world = p("world", True, description="draw the world's models (sim/scene) beside the robots")
        self.world_rate = p("world_rate", 5.0, min_value=0.1, description=(
            "Hz of the world's moving models (sim/link_states is read at this rate)"))
        self.show_imu = p("imu", True, description="plot every sensor_msgs/Imu under a robot's namespace")
        self.show_wrenches = p("wrenches", True, description=(
            "draw every geometry_msgs/WrenchStamped under a robot's namespace as a force arrow"))
        self.wrench_scale = p("wrench_scale", 0.001, min_value=0.0, description="m of force arrow per N")
        self.show_cameras = p("cameras", True, description="draw the cameras of the robots' URDFs (images, frusta)")
        self.show_depth = p("depth", True, description="also their depth images (in the camera tab)")
        self.depth_cloud = p("depth_cloud", False, description=(
            "lift the depth images into points in the 3-D view too (RViz's DepthCloud; slow in a software-"
            "rendered page)"))
        self.show_ranges = p("ranges", True, description="draw the lidars' and lasers' points of the robots' URDFs")
        # 1 Hz: at 2 Hz the page's lag p95 was 2.1-2.8 s against 1.3-1.6 s (bench/viz.py, interleaved runs).
        self.image_rate = p("image_rate", 1.0, min_value=0.1, max_value=30.0,
                            description="Hz of each camera's rows (image, depth, pose)")
        self.cloud_rate = p("cloud_rate", 1.0, min_value=0.1, max_value=30.0,
                            description="Hz of each robot's lidar and laser row")
        self.jpeg_quality = p("jpeg_quality", 75, type=int, min_value=1, max_value=100,
                              description="JPEG quality of the camera images sent to the viewer")
        self.cloud_max_points = p("cloud_max_points", 20000, type=int, min_value=100, description=(
            "points per cloud at most (every k-th point beyond)"))
        self.sensor_pull = p("sensor_pull", True, description=(
            "subscribe to the rendered sensors for one frame at a time (the renderer draws only while someone "
            "subscribes: ~40 % of a core for a 30 Hz camera); false: stay subscribed"))

        self.sim_now = 0.0
        self.sim_clock_seen = False
        # Subscriptions run inline on Zenoh's threads (no executor queue to lag behind) and check their rate
        # limit before decoding, so dropped samples cost almost nothing; this lock serialises the handlers.
        self.lock = threading.Lock()
        self.robots: dict[str, RobotView] = {}
        self.inbox: queue.SimpleQueue = queue.SimpleQueue()  # work from the discovery thread
        self.layout_key: tuple = ()
        self.pending_layout: tuple[tuple, float] = ((), 0.0)  # the newest layout key and since when
        self.scene_checked = False  # sim/scene was asked for once (its GUI camera is the layout's view)
        self.world_names: set[str] = set()  # the models sim/scene says are not robots (no namespace)
        self.link_states: Subscription | None = None

        self.recording = rr.RecordingStream("zenroid_viz",
                                            batcher_config=rr.ChunkBatcherConfig(flush_tick=flush_period))
        args = cli_args or argparse.Namespace(save=None, serve=False, spawn=False, headless=None,
                                              web_port=9090, grpc_port=9876, server_history=None)
        plan = OutputPlan.resolve(args.save, args.serve, args.spawn, args.headless, args.web_port, args.grpc_port,
                                  getattr(args, "server_history", None), getattr(args, "bind", "127.0.0.1"))
        self.timeline = SIM_TIMELINE
        self.output = Output(self.recording, plan)
        for note in plan.notes:
            self.logger.info(note)
        if plan.save:
            self.logger.info(f"saving the recording to {plan.save}")
        self.scene_time = SceneTime(self.recording)

        self.markers = MarkerLayer(self.recording, self.marker_frame)
        self.marker_topics: dict[str, Subscription] = {}
        for topic, marker_type in GLOBAL_MARKER_TOPICS.items():
            self.add_marker_topic(topic, marker_type)
        self.create_timer(0.2, self.flush_markers, sim_time=False)
        self.clock_limit = RateLimiter(10.0)  # sim/clock runs at the physics rate: 10 Hz is plenty for us
        self.model_states_limit = RateLimiter(self.rates["model_states"])
        self.subscribe(Clock, "/sim/clock", self.on_clock, self.clock_limit)
        self.subscribe(ModelStates, "/sim/model_states", self.on_model_states, self.model_states_limit)
        self.world = WorldModels(self.recording) if self.show_world else None
        self.link_states_limit = RateLimiter(self.world_rate)
        # sim/scene also tells world models from robots; handled on the timer's thread (it may drop subscriptions)
        self.subscribe(Scene, "/sim/scene", lambda m: self.inbox.put(("scene", "", m)))
        for namespace in self.robot_list:
            self.add_robot(namespace)
        self.create_timer(0.1, self.drain_inbox, sim_time=False)
        self.create_timer(0.05, self.tick_pulls, sim_time=False)
        self.create_timer(self.keyframe_period, self.keyframe, sim_time=False)
        self.discovery_stop = threading.Event()
        self.discovery = threading.Thread(target=self.discovery_loop, name="viz-discovery", daemon=True)
        self.discovery.start()
        if self.output.viewer_url:   # last: whoever acts on the URL (Ctrl-C included) finds the viewer ready
            self.logger.info(f"web viewer: open {self.output.viewer_url}")
            print(f"Rerun web viewer: {self.output.viewer_url}", flush=True)

    def subscribe(self, msg_type: Any, key: str, handler, limiter: RateLimiter | None = None,
                  on_arrival=None) -> Subscription:
        """A raw inline subscription: rate check first, then decode (errors name the field), then handle."""

        def on_payload(payload: bytes) -> None:
            with self.lock:
                if on_arrival is not None:
                    on_arrival()
                if limiter is not None and not limiter.ready():
                    return
                try:
                    msg = msgs.decode(msg_type, payload)
                except msgs.DecodeError as exc:
                    self.logger.warn_throttle(5.0, f"dropped a message on '{key.lstrip('/')}': {exc}", key=f"dec:{key}")
                    return
                handler(msg)

        return self.create_subscription(msg_type, key, on_payload, delivery=Inline(), message=Raw())

    def latch(self, robot: RobotView, slot: str, msg_type: Any, key: str, on_arrival=None) -> Subscription:
        """A raw subscription that only keeps the newest payload in ``robot.latest[slot]``: controller_state
        and humanoid_state come at the control rate and are decoded only when a plot row takes them, so their
        values share the row (and the viewer's chunk) of the joint_states sample they go with."""
        stream = robot.latest[slot] = LatchedStream(msg_type, key.lstrip("/"))

        def on_payload(payload: bytes) -> None:
            # No lock: replacing an attribute is atomic, and the reader copes with either payload.
            stream.newest = Latest(time.monotonic(), payload)
            if on_arrival is not None:
                on_arrival()

        return self.create_subscription(msg_type, key, on_payload, delivery=Inline(), message=Raw())

    def latest(self, robot: RobotView, slot: str) -> Any:
        """The newest message of a latched stream, decoded once; None when stale, absent or undecodable."""
        stream = robot.latest.get(slot)
        entry = stream.newest if stream is not None else None
        if entry is None or time.monotonic() - entry.arrived > LATEST_FRESH:
            return None
        if entry.decoded is None:
            try:
                entry.decoded = msgs.decode(stream.msg_type, entry.payload)
            except msgs.DecodeError as exc:
                self.logger.warn_throttle(5.0, f"dropped a message on '{stream.key}': {exc}",
                                          key=f"dec:/{stream.key}")
                entry.decoded = False
        return None if entry.decoded is False else entry.decoded

    # -- robots --------------------------------------------------------------------------------------
    def add_robot(self, namespace: str) -> RobotView:
        if namespace in self.robots:
            return self.robots[namespace]
        robot = RobotView(namespace)
        robot.limits = {stream: RateLimiter(hz) for stream, hz in self.rates.items()}
        robot.limits["fk"] = RateLimiter(self.rates["tf"])
        self.robots[namespace] = robot
        sub, limits, ns = self.subscribe, robot.limits, namespace
        robot.subscriptions += [
            sub(String, f"/{ns}/robot_description", lambda m, r=robot: self.on_description(r, m.data)),
            sub(TFMessage, f"/{ns}/tf", lambda m, r=robot: self.on_tf(r, m, static=False), limits["tf"],
                on_arrival=lambda r=robot: setattr(r, "tf_seen", True)),
            sub(TFMessage, f"/{ns}/tf_static", lambda m, r=robot: self.on_tf(r, m, static=True)),
            sub(JointState, f"/{ns}/joint_states", lambda m, r=robot: self.on_joint_states(r, m),
                limits["joint_states"]),
            self.latch(robot, "humanoid_state", HumanoidState, f"/{ns}/humanoid_state",
                       on_arrival=lambda r=robot: setattr(r, "has_balance", True)),
        ]
        for controller in self.controller_names:
            self.add_controller(robot, controller)
        for kind, topics in DEFAULT_BODY_SENSORS.items():
            for topic in topics:
                self.add_body_sensor(robot, kind, f"{ns}/{topic}")
        self.add_marker_topic(f"{ns}/visualization_marker", Marker)
        self.add_marker_topic(f"{ns}/visualization_marker_array", MarkerArray)
        self.logger.info(f"showing robot '{namespace}'")
        return robot

    def drop_robot(self, namespace: str) -> None:
        """Forget a namespace taken for a robot that is not one (a world model seen in sim/model_states)."""
        robot = self.robots.pop(namespace)
        subscriptions = [*robot.subscriptions, *(s for subs in robot.controllers.values() for s in subs),
                         *(s for _, s in robot.body_sensors.values())]
        for pull in robot.pulls:
            pull.close()
        for topic in (f"{namespace}/visualization_marker", f"{namespace}/visualization_marker_array"):
            if topic in self.marker_topics:
                subscriptions.append(self.marker_topics.pop(topic))
        for sub in subscriptions:
            sub.destroy()

    def add_controller(self, robot: RobotView, controller: str) -> None:
        if controller in robot.controllers:
            return
        base = f"/{robot.namespace}/{controller}"
        robot.controllers[controller] = [
            self.latch(robot, f"controller:{controller}", ControllerState, f"{base}/controller_state"),
            self.subscribe(JointTrajectory, f"{base}/joint_trajectory",
                           lambda m, r=robot, c=controller: self.on_trajectory(r, c, m)),
        ]

    # -- sensors -------------------------------------------------------------------------------------
    def add_body_sensor(self, robot: RobotView, kind: str, key: str) -> None:
        """An IMU (plotted in the robot's rows) or a force/torque sensor (an arrow among its markers): only
        the newest message is kept, decoded when a row takes it (they come at 1 kHz)."""
        key = key.strip("/")
        if key in robot.body_sensors or (kind == "imu" and not self.show_imu) or \
                (kind in ("wrench", "contacts") and not self.show_wrenches):
            return
        if kind == "imu":
            part = sensor_part(robot.namespace, key)
            robot.body_sensors[key] = (kind, self.latch(robot, f"imu:{key}", Imu, f"/{key}", on_arrival=(
                lambda r=robot, k=key, p=part: r.imus.setdefault(k, p))))
        elif kind == "contacts":
            robot.body_sensors[key] = (kind, self.latch(robot, f"contacts:{key}", ContactsState, f"/{key}"))
        else:
            robot.body_sensors[key] = (kind, self.latch(robot, f"wrench:{key}", WrenchStamped, f"/{key}"))

    def body_sensor_values(self, robot: RobotView) -> dict[str, dict[str, np.ndarray]]:
        """The IMUs' plot columns for this row; the force arrows are updated on the way."""
        columns: dict[str, dict[str, np.ndarray]] = {}
        scene = robot.scene
        for key, (sensor, _) in robot.body_sensors.items():
            msg = self.latest(robot, f"{sensor}:{key}")
            try:
                if sensor == "imu":
                    if msg is not None and "imu" in self.plots:
                        for kind, parts in imu_columns(sensor_part(robot.namespace, key), msg).items():
                            columns.setdefault(kind, {}).update(parts)
                    continue
                if sensor == "contacts":
                    if scene is not None:
                        frame = None if msg is None else scene.frame_pose(msg.header.frame_id)
                        scene.update_contacts(key, contact_points(frame, msg) if frame is not None else None)
                    continue
                frame = None if msg is None or scene is None else scene.frame_pose(msg.header.frame_id)
                if msg is not None and frame is None:
                    self.logger.warn_throttle(10.0, f"{key}: frame_id '{msg.header.frame_id}' is not in tf (yet): "
                                              "no force arrow", key=f"wrench_frame:{key}")
                if scene is not None:
                    arrow = force_arrow(frame, msg, self.wrench_scale) if frame is not None else None
                    scene.update_arrow(key, *(arrow or (None,)))
            except SensorDataError as exc:
                self.logger.warn_throttle(5.0, f"{key}: {exc}: skipped", key=f"sensor:{key}")
                if scene is not None and sensor == "wrench":
                    scene.update_arrow(key, None)
                if scene is not None and sensor == "contacts":
                    scene.update_contacts(key, None)
        return columns

    def add_rendered_sensors(self, robot: RobotView, xml_text: str) -> None:
        """Read the cameras, lidars and lasers the robot's URDF declares, on the keys the renderer publishes
        them (gazebo_ros' names, remappings applied), a frame at a time (``FramePull``): each camera's colour
        and depth images with its CameraInfo, and the robot's lidar PointCloud2s and LaserScans together. A
        depth camera's own PointCloud2 is left out: Rerun lifts the depth image into the same points through
        the pinhole, and at 2.4 MB a frame it would be the biggest stream of the job."""
        for pull in robot.pulls:
            pull.close()
        robot.pulls, robot.cameras, robot.ranges = [], {}, {}
        if not (self.show_cameras or self.show_ranges):
            return
        try:
            specs = parse_rendered_sensors(parse_xml(xml_text.encode()), robot.namespace)
        except (SensorDeclarationError, UrdfError, ValueError) as exc:
            self.logger.warn(f"robot '{robot.namespace}': its cameras and range sensors are not drawn: {exc}")
            return
        if robot.sensors is None:
            robot.sensors = RenderedSensors(self.recording, robot.namespace, self.jpeg_quality)
        for spec in specs:
            keys = spec.keys
            if spec.camera is not None and self.show_cameras and "image" in keys:
                robot.cameras[spec.name] = spec
                streams = [("image", Image, keys["image"])]
                if self.show_depth and spec.camera.depth and "depth" in keys:
                    streams.append(("depth", Image, keys["depth"]))
                self.add_pull(robot, [(f"{part}:{spec.name}", t, k, part) for part, t, k in streams] + (
                    [(f"info:{spec.name}", CameraInfo, keys["camera_info"], "")] if "camera_info" in keys else []),
                    # ordered: the renderer sends a frame's colour image before its depth image
                    functools.partial(self.log_camera, robot, spec.name), self.image_rate, ordered=True)
            elif spec.ray is not None and self.show_ranges and ("points" in keys or "scan" in keys):
                kind = "points" if "points" in keys else "scan"
                robot.ranges[keys[kind]] = kind
        if robot.ranges:
            self.add_pull(robot, [(f"range:{key}", PointCloud2 if kind == "points" else LaserScan, key, key)
                                  for key, kind in robot.ranges.items()],
                          functools.partial(self.log_ranges, robot), self.cloud_rate)
        if specs:
            self.logger.info(f"robot '{robot.namespace}': sensors {', '.join(s.name for s in specs)} "
                             f"({', '.join(k for s in specs for k in s.keys.values())})")

    def add_pull(self, robot: RobotView, streams: list[tuple[str, Any, str, str]], on_frame: Any,
                 rate: float, ordered: bool = False) -> None:
        """A ``FramePull`` of these ``(slot, type, key, part)`` streams (part "": not needed for a frame)."""
        pull = FramePull([part for *_, part in streams if part], lambda: [], on_frame, 1.0 / rate,
                         continuous=not self.sensor_pull, ordered=ordered)

        def open_subscriptions() -> list[Subscription]:
            return [self.latch(robot, slot, msg_type, f"/{key}", on_arrival=(
                functools.partial(self.pull_arrived, pull, part) if part else None))
                for slot, msg_type, key, part in streams]

        pull.open_subscriptions = open_subscriptions
        robot.pulls.append(pull)

    def pull_arrived(self, pull: FramePull, part: str) -> None:
        """A part of a pulled frame came (on Zenoh's thread)."""
        with self.lock:
            pull.arrived(part)

    def tick_pulls(self) -> None:
        """Open the pulls that are due, close those whose frame came (a deleted robot's: all)."""
        with self.lock:
            for robot in self.robots.values():
                for pull in robot.pulls:
                    if robot.present and robot.scene is not None:
                        pull.tick()
                    else:
                        pull.close()

    def log_camera(self, robot: RobotView, camera: str) -> None:
        """The camera's newest image and depth image, its pinhole (CameraInfo's K, else the URDF's field of
        view) and its optical frame in the world."""
        spec = robot.cameras.get(camera)
        if spec is None or robot.scene is None or robot.sensors is None or not robot.present:
            return
        color_msg, depth_msg = self.latest(robot, f"image:{camera}"), self.latest(robot, f"depth:{camera}")
        first = color_msg or depth_msg
        if first is None:
            return
        frame, problems = camera_frame(color_msg, depth_msg, self.latest(robot, f"info:{camera}"),
                                       spec.camera.horizontal_fov if spec.camera else 1.047)
        for output, problem in problems:
            key = spec.keys.get(output, camera)
            self.logger.warn_throttle(5.0, f"{key}: {problem}", key=f"camera:{key}")
        if frame is None:
            return
        frame_id = first.header.frame_id or spec.frame_id
        pose = robot.scene.frame_pose(frame_id)
        if pose is None:
            key = spec.keys.get("image", camera)
            self.logger.warn_throttle(10.0, f"{key}: frame_id '{frame_id}' is not in tf (yet): not drawn",
                                      key=f"camera_frame:{key}")
            return
        frame.pose = pose
        robot.sensors.log_camera(self.stamp_or_now(first.header.stamp), camera, frame)

    def log_ranges(self, robot: RobotView) -> None:
        """Every range sensor's newest points in the world: lidars by intensity, lasers magenta."""
        if robot.scene is None or robot.sensors is None or not robot.present:
            return
        clouds, stamp = [], None
        for key, kind in robot.ranges.items():
            msg = self.latest(robot, f"range:{key}")
            if msg is None:
                continue
            try:
                xyz, colors = range_points(kind, msg, self.cloud_max_points)
            except SensorDataError as exc:
                self.logger.warn_throttle(5.0, f"{key}: skipped: {exc}", key=f"range:{key}")
                continue
            pose = robot.scene.frame_pose(msg.header.frame_id)
            if pose is None:
                self.logger.warn_throttle(10.0, f"{key}: frame_id '{msg.header.frame_id}' is not in tf (yet): "
                                          "not drawn", key=f"range_frame:{key}")
                continue
            clouds.append((to_world(pose, xyz), colors))
            stamp = msg.header.stamp if stamp is None else stamp
        if clouds:
            robot.sensors.log_ranges(self.stamp_or_now(stamp), clouds)

    # -- the world (sim/scene) -----------------------------------------------------------------------
    def on_scene(self, msg: Any) -> None:
        """A (new) scene: the world's models are drawn again (a spawned or deleted model)."""
        self.scene_checked = True
        if len(msg.namespaces) == len(msg.models):
            self.world_names = {m for m, ns in zip(msg.models, msg.namespaces, strict=True) if not ns}
            for name in self.world_names & set(self.robots):
                robot = self.robots[name]
                if robot.scene is None and name not in self.robot_list:  # taken for a robot before the scene
                    self.drop_robot(name)
        if self.world is None or (msg.version == self.world.version and self.world.layout.shapes):
            return
        try:
            layout, problems = read_scene(msg)
        except WorldProblem as exc:
            self.logger.warn_throttle(5.0, f"{exc}: scene ignored", key="scene")
            return
        for problem in problems[:5]:
            self.logger.warn_throttle(30.0, f"{problem}: skipped", key=f"scene:{problem[:60]}")
        self.world.load(layout, self.sim_now)
        self.logger.info(f"world: scene version {layout.version}, {len(layout.models)} models drawn "
                         f"({len(layout.shapes)} shapes)")

    def on_link_states(self, msg: Any) -> None:
        if self.world is None:
            return
        if len(msg.pose) != len(msg.name):
            self.logger.warn_throttle(5.0, f"sim/link_states: {len(msg.name)} names but {len(msg.pose)} poses: "
                                      "ignored", key="link_states_len")
            return
        moved, problems = self.world.update_poses(msg.name, msg.pose)
        for problem in problems[:3]:
            self.logger.warn_throttle(10.0, f"{problem}: the link keeps its last pose", key=f"link:{problem[:60]}")
        if moved:
            self.world.log(self.sim_now)

    def follow_link_states(self) -> None:
        """Read sim/link_states only while the world needs poses: the simulator publishes it (every link of
        every model at 100 Hz) only while someone subscribes."""
        want = self.world is not None and bool(self.world.layout.links) and self.world.needs_link_states()
        if want and self.link_states is None:
            self.link_states = self.subscribe(LinkStates, "/sim/link_states", self.on_link_states,
                                              self.link_states_limit)
        elif not want and self.link_states is not None:
            self.link_states.destroy()
            self.link_states = None

    # -- markers (visualization_msgs) ----------------------------------------------------------------
    def add_marker_topic(self, topic: str, marker_type: Any) -> None:
        if topic in self.marker_topics:
            return
        if marker_type is MarkerArray:
            def handler(msg: Any, t: str = topic) -> None:
                for index, marker in enumerate(msg.markers):
                    self.on_marker(t, marker, f"markers[{index}] ")
        else:
            def handler(msg: Any, t: str = topic) -> None:
                self.on_marker(t, msg)
        # Not rate-limited before decoding: markers are events (a dropped DELETE would leave a ghost);
        # the layer coalesces updates and logs at most every 0.2 s.
        self.marker_topics[topic] = self.subscribe(marker_type, f"/{topic}", handler)

    def on_marker(self, topic: str, msg: Any, where: str = "") -> None:
        try:
            self.markers.handle(topic, msg)
        except MarkerError as exc:
            self.logger.warn_throttle(5.0, f"{topic}: {where}marker '{msg.ns}' {msg.id} refused: {exc}",
                                      key=f"marker:{topic}:{msg.ns}:{msg.id}:{str(exc)[:24]}")
            return
        self.stamp_or_now(msg.header.stamp)

    def marker_frame(self, topic: str, frame_id: str) -> Any:
        """A marker's frame in the world: world-like frames are the origin; ``<ns>/<link>`` or a link of the
        robot whose namespace the topic is under, else of the one robot that has such a link."""
        frame = frame_id.lstrip("/")
        if frame in self.world_frames or frame == "":
            return np.eye(4)
        candidates = []
        namespace, _, link = frame.partition("/")
        if link and namespace in self.robots:
            candidates.append((self.robots[namespace], link))
        owner = topic.split("/", 1)[0]
        if owner in self.robots:
            candidates.append((self.robots[owner], frame))
        candidates += [(r, frame) for r in self.robots.values()]
        for robot, name in candidates:
            if robot.scene is not None and robot.present:
                pose = robot.scene.frame_pose(name)
                if pose is not None:
                    return pose
        return None

    def flush_markers(self, refresh: bool = False) -> None:
        with self.lock:
            self.scene_time(self.sim_now)
            self.markers.flush(refresh=refresh)
            for key, message in list(self.markers.unresolved.items()):
                self.logger.warn_throttle(10.0, message, key=f"marker_frame:{key}")
            self.markers.unresolved.clear()

    def on_description(self, robot: RobotView, xml_text: str) -> None:
        if xml_text == robot.description and robot.scene is not None:
            return
        try:
            model = parse_model(xml_text)
            scene = RobotScene(self.recording, robot.namespace, model, self.end_effectors, self.world_frames)
        except (UrdfError, ValueError) as exc:
            self.logger.error(f"robot '{robot.namespace}': unusable robot_description: {exc}")
            return
        robot.description = xml_text
        robot.scene = scene
        self.add_rendered_sensors(robot, xml_text)
        count = scene.log_model(self.sim_now)
        if scene.skipped_meshes:
            self.logger.warn(f"robot '{robot.namespace}': meshes not drawn: {'; '.join(scene.skipped_meshes[:3])}")
        if robot.last_positions:
            scene.positions.update(robot.last_positions)
        if robot.pending_static:
            scene.log_transforms(self.sim_now, robot.pending_static)
            robot.pending_static = []
        self.logger.info(f"robot '{robot.namespace}': model '{model.name}' with {len(model.links)} links, "
                         f"{count} visuals")

    def set_present(self, robot: RobotView, present: bool) -> None:
        if robot.present == present:
            return
        robot.present = present
        if not present:
            self.logger.info(f"robot '{robot.namespace}' was deleted")
            if robot.scene is not None:
                robot.scene.clear(self.sim_now)
            robot.description = ""  # a respawn may bring another URDF: fetch it again
            robot.scene = None
            robot.tf_seen = False
        else:
            self.logger.info(f"robot '{robot.namespace}' is back")
            self.inbox.put(("fetch", robot.namespace))

    # -- callbacks -----------------------------------------------------------------------------------
    def on_clock(self, msg: Any) -> None:
        self.sim_now = msgs.time_to_sec(msg.clock)
        self.sim_clock_seen = True
        self.timeline = SIM_TIMELINE

    def stamp_or_now(self, stamp: Any) -> float:
        seconds = msgs.time_to_sec(stamp)
        if seconds <= 0 or (is_wall_stamp(seconds) and self.sim_clock_seen):
            # A wall-clock stamp beside a simulator (a node without use_sim_time, a state publisher's
            # tf_static): its rows go at the current sim time, and it does not move sim time on.
            return self.sim_now
        self.sim_now = seconds  # stamps keep sim time current between the (rate-limited) clock samples
        if is_wall_stamp(seconds) and not self.sim_clock_seen:
            self.timeline = WALL_TIMELINE  # no simulator: the time panel shows the wall clock
        return seconds

    def on_model_states(self, msg: Any) -> None:
        if len(msg.pose) != len(msg.name):
            self.logger.warn_throttle(5.0, f"sim/model_states: {len(msg.name)} names but {len(msg.pose)} poses: "
                                      "ignored", key="model_states_len")
            return
        names = set(msg.name)
        # A model is a robot unless sim/scene says it is a world model (no namespace): wait for its answer.
        if self.discover and self.scene_checked:
            for name in names - set(self.robots) - self.world_names:
                if name and name != "ground_plane":
                    self.add_robot(name)
                    self.inbox.put(("fetch", name))
        for namespace, robot in self.robots.items():
            if namespace in names:
                robot.in_sim = True
                self.set_present(robot, True)
            elif robot.in_sim:  # only a robot the simulator had can be deleted by it
                self.set_present(robot, False)
        for name, pose in zip(msg.name, msg.pose, strict=True):
            robot = self.robots.get(name)
            if robot is None or robot.scene is None:
                continue
            position = (pose.position.x, pose.position.y, pose.position.z)
            orientation = (pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w)
            robot.scene.log_base_pose(self.sim_now, position, orientation)

    def on_tf(self, robot: RobotView, msg: Any, static: bool) -> None:
        if not msg.transforms:
            return
        rows = []
        for t in msg.transforms:
            tr, q = t.transform.translation, t.transform.rotation
            if not t.child_frame_id:
                self.logger.warn_throttle(5.0, f"{robot.namespace}/tf: transform without child_frame_id ignored",
                                          key=f"tf_child:{robot.namespace}")
                continue
            rows.append((t.header.frame_id, t.child_frame_id, (tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w)))
        when = self.stamp_or_now(msg.transforms[0].header.stamp)
        if robot.scene is None:
            if static:
                robot.pending_static = rows
            return
        robot.scene.log_transforms(when, rows)

    def on_joint_states(self, robot: RobotView, msg: Any) -> None:
        n = len(msg.name)
        for field_name in ("position", "velocity", "effort"):
            values = getattr(msg, field_name)
            if values and len(values) != n:
                self.logger.warn_throttle(5.0, f"{robot.namespace}/joint_states: {field_name} has {len(values)} "
                                          f"values for {n} names: message ignored", key=f"js:{robot.namespace}")
                return
        if len(set(msg.name)) != n:
            self.logger.warn_throttle(5.0, f"{robot.namespace}/joint_states: duplicate joint names: ignored",
                                      key=f"js:{robot.namespace}")
            return
        when = self.stamp_or_now(msg.header.stamp)
        positions = dict(zip(msg.name, msg.position, strict=False))
        robot.last_positions.update(positions)
        scene = robot.scene
        if scene is None:
            return
        scene.positions.update(positions)
        if not robot.tf_seen and when >= self.tf_fallback_after and robot.limits["fk"].ready():
            scene.log_fk_transforms(when, scene.positions)
        if not scene.base_known and not robot.in_sim:
            # No simulator places this robot (arm_viz): after a second, its root is the world origin.
            robot.first_state = robot.first_state or time.monotonic()
            scene.base_known = time.monotonic() - robot.first_state > 1.0
        balance = self.balance(robot)
        sensors = self.body_sensor_values(robot)
        if robot.limits["markers"].ready():
            if balance is not None:
                scene.update_balance(*balance[1])
            scene.update_paths()
        # The robot's row: its pose, markers and every plotted value (controllers, balance: the latest).
        scene.log_joint_states(when, msg.name, msg.position, msg.velocity, msg.effort, self.quantities,
                               controllers=self.controller_values(robot) if "commanded" in self.plots else None,
                               balance=balance[0] if balance and "balance" in self.plots else None,
                               extra=sensors)

    def controller_values(self, robot: RobotView) -> dict[str, tuple[list[str], list[float], list[float]]]:
        """Each controller's latest (joint names, reference, actual positions), for the plot row."""
        values = {}
        for controller in robot.controllers:
            key = f"{robot.namespace}/{controller}/controller_state"
            msg = self.latest(robot, f"controller:{controller}")
            if msg is None:
                continue
            # control_msgs (Jazzy) JointTrajectoryControllerState: reference (commanded) and feedback (measured).
            commanded, actual, n = msg.reference.positions, msg.feedback.positions, len(msg.joint_names)
            if len(commanded) != n or len(actual) != n or len(set(msg.joint_names)) != n:
                self.logger.warn_throttle(5.0, f"{key}: {n} joints but {len(commanded)} commanded / {len(actual)} "
                                          "actual positions (or duplicate names): ignored", key=f"cs:{key}")
                continue
            values[controller] = (list(msg.joint_names), list(commanded), list(actual))
        return values

    def balance(self, robot: RobotView) -> tuple[list[float], tuple] | None:
        """The latest humanoid_state as the balance plot's values (CoM x y z, ZMP x y, is_balanced) and the
        balance markers' arguments (with the measured centre of pressure, when the feet measured one); None
        without a fresh, finite one."""
        msg = self.latest(robot, "humanoid_state")
        if msg is None:
            return None
        com = (msg.center_of_mass.x, msg.center_of_mass.y, msg.center_of_mass.z)
        if not all(math.isfinite(v) for v in com + (msg.zmp_x, msg.zmp_y)):
            return None
        polygon = [(p.x, p.y, p.z) for p in msg.support_polygon]
        cop = (msg.cop_x, msg.cop_y) if msg.cop_measured and math.isfinite(msg.cop_x) and \
            math.isfinite(msg.cop_y) else None
        return ([*com, msg.zmp_x, msg.zmp_y, 1.0 if msg.is_balanced else 0.0],
                (com, (msg.zmp_x, msg.zmp_y), msg.is_balanced, polygon, cop))

    def on_trajectory(self, robot: RobotView, controller: str, msg: Any) -> None:
        """The target pose of a trajectory sent on the topic: its last point."""
        if robot.scene is None or not msg.points:
            return
        last = msg.points[-1].positions
        if len(last) != len(msg.joint_names):
            self.logger.warn(f"{robot.namespace}/{controller}/joint_trajectory: last point has {len(last)} "
                             f"positions for {len(msg.joint_names)} joints: no target drawn")
            return
        unknown = [j for j in msg.joint_names if j not in robot.scene.model.joints]
        if unknown:
            self.logger.warn(f"{robot.namespace}/{controller}/joint_trajectory: unknown joints {unknown[:3]}")
        robot.scene.log_target(self.stamp_or_now(msg.header.stamp), controller,
                               {j: v for j, v in zip(msg.joint_names, last, strict=True) if j not in unknown})

    # -- discovery (a thread: graph queries block) -----------------------------------------------------
    def discovery_loop(self) -> None:
        while not self.discovery_stop.wait(0.2):
            try:
                self.discover_once()
            except Exception as exc:  # noqa: BLE001 - discovery is best effort; the node keeps running
                self.logger.warn_throttle(30.0, f"discovery failed: {exc}", key="discovery")
            if self.discovery_stop.wait(DISCOVERY_PERIOD):
                return

    def discover_once(self) -> None:
        if not self.scene_checked:
            self.fetch_scene()
        if self.discover:
            for entry in core_graph.snapshot(self.session, timeout=1.0):
                if entry.kind != "pub":
                    continue
                parts = entry.name.split("/")
                if len(parts) == 2 and parts[1] in ("robot_description", "joint_states"):
                    self.inbox.put(("robot", parts[0]))
                elif len(parts) == 3 and parts[2] == "controller_state":
                    self.inbox.put(("controller", parts[0], parts[1]))
                if entry.type_name in MARKER_TYPES:  # anyone publishing markers, as RViz lets you pick
                    self.inbox.put(("markers", entry.name, entry.type_name))
                if entry.type_name in BODY_SENSOR_TYPES and len(parts) > 1:
                    self.inbox.put(("body", parts[0], BODY_SENSOR_TYPES[entry.type_name], entry.name))
        for namespace, robot in list(self.robots.items()):
            if robot.scene is None and robot.present:
                self.fetch(namespace)

    def fetch_scene(self) -> None:
        """The latched sim/scene, published before we subscribed (later ones come on the topic)."""
        try:
            scene = fetch_latched(self.session, Scene, "sim/scene", timeout=1.0)
        except msgs.DecodeError as exc:
            self.logger.warn_throttle(30.0, f"sim/scene: bad latched reply: {exc}", key="fetch:scene")
            scene = None
        if scene is not None:
            self.inbox.put(("scene", "", scene))
        self.inbox.put(("scene_checked", ""))

    def fetch(self, namespace: str) -> None:
        """Ask the latched queryables for what was published before we subscribed."""
        try:
            description = fetch_latched(self.session, String, f"{namespace}/robot_description", timeout=1.0)
            static = fetch_latched(self.session, TFMessage, f"{namespace}/tf_static", timeout=0.5)
        except msgs.DecodeError as exc:
            self.logger.warn_throttle(10.0, f"robot '{namespace}': bad latched reply: {exc}", key=f"fetch:{namespace}")
            return
        if description is not None:
            self.inbox.put(("description", namespace, description.data))
        if static is not None:
            self.inbox.put(("tf_static", namespace, static))

    def drain_inbox(self) -> None:
        with self.lock:
            self._drain_inbox()

    def _drain_inbox(self) -> None:
        while True:
            try:
                item = self.inbox.get_nowait()
            except queue.Empty:
                break
            kind, namespace = item[0], item[1]
            if kind == "robot":
                self.add_robot(namespace)
            elif kind == "controller":
                self.add_controller(self.add_robot(namespace), item[2])
            elif kind == "markers":
                self.add_marker_topic(namespace, MARKER_TYPES[item[2]])
            elif kind == "fetch":
                threading.Thread(target=self.fetch, args=(namespace,), daemon=True).start()
            elif kind == "scene":
                self.on_scene(item[2])
            elif kind == "scene_checked":
                self.scene_checked = True
            elif kind == "body":
                if namespace in self.robots:
                    self.add_body_sensor(self.robots[namespace], item[2], item[3])
            elif namespace in self.robots:
                robot = self.robots[namespace]
                if kind == "description" and robot.scene is None and robot.present:
                    self.on_description(robot, item[2])
                elif kind == "tf_static":
                    self.on_tf(robot, item[2], static=True)
        self.follow_link_states()
        self.update_layout()

    def robot_layout(self, robot: RobotView) -> RobotLayout:
        scene = robot.scene
        if scene is None:
            return RobotLayout(has_balance=robot.has_balance)
        return RobotLayout(groups=list(scene.plot_groups), controllers={
            c: scene.controller_groups[c] for c in sorted(robot.controllers) if c in scene.controller_groups},
            has_balance=robot.has_balance,
            imus=tuple((part, key.removeprefix(f"{robot.namespace}/")) for key, part in sorted(robot.imus.items())),
            cameras=tuple((camera_entity(robot.namespace, name), bool(self.show_depth and spec.camera.depth))
                          for name, spec in sorted(robot.cameras.items()) if spec.camera is not None))

    def update_layout(self) -> None:
        """Send the blueprint when robots, plot groups, controllers, balance plots or the timeline change,
        once the change has settled for ``LAYOUT_SETTLE``: the server keeps every blueprint for the viewers
        that open later, and each one costs them a chunk per view and property (the humanoid's: ~160) to take
        in before they show the present. So there is no start-up layout either (``Output`` sends none)."""
        layout = {ns: self.robot_layout(r) for ns, r in sorted(self.robots.items()) if r.present}
        eye = self.world.layout.eye if self.world is not None else None
        key = (self.timeline, tuple((ns, lay.key()) for ns, lay in layout.items()), repr(eye))
        now = time.monotonic()
        if key != self.pending_layout[0]:
            self.pending_layout = (key, now)
        settled = now - self.pending_layout[1]
        # Until every robot's joints are known, the layout would only be sent again a moment later: wait
        # (up to LAYOUT_WAIT), and a viewer opened meanwhile shows Rerun's own layout of what it has.
        incomplete = not layout or any(not lay.groups for lay in layout.values()) or \
            (self.world is not None and not self.scene_checked)
        if key != self.layout_key and settled >= (LAYOUT_WAIT if incomplete else LAYOUT_SETTLE):
            self.layout_key = key
            self.recording.send_blueprint(build_blueprint(layout, self.timeline, self.show_ground, self.plots,
                                                          eye=eye, depth_cloud=self.depth_cloud))

    def keyframe(self) -> None:
        """Every idle robot's model and markers again (see ``RobotScene.refresh``), and the user markers."""
        with self.lock:
            for robot in self.robots.values():
                if robot.scene is not None and robot.present:
                    robot.scene.refresh(self.sim_now, self.keyframe_period)
            if self.world is not None:
                self.world.refresh(self.sim_now, self.keyframe_period)
        self.flush_markers(refresh=True)

    def on_process_exit(self) -> None:
        self.discovery_stop.set()
        self.output.close()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    out = parser.add_argument_group("viewer output")
    out.add_argument("--save", metavar="FILE.rrd", help="also write the recording to this file")
    out.add_argument("--serve", action="store_true", help="serve the web viewer (default without a display)")
    out.add_argument("--spawn", action="store_true", help="open the native viewer (default with a display)")
    out.add_argument("--headless", dest="headless", action="store_const", const=True, default=None,
                     help="never open a window even if a display is present")
    out.add_argument("--web-port", type=int, default=9090, help="web viewer HTTP port (0: any free port)")
    out.add_argument("--grpc-port", type=int, default=9876, help="Rerun gRPC port (0: any free port)")
    out.add_argument("--bind", default="127.0.0.1", metavar="ADDRESS",
                     help="address the web viewer's servers listen on (default loopback only; 0.0.0.0 inside a "
                          "container whose ports are published)")
    out.add_argument("--server-history", metavar="SIZE", default=None,
                     help="what the web viewer server keeps for viewers that connect later, e.g. 4MiB (default "
                          "1KiB: the layout and the newest message; a late viewer starts at the present)")
    out.add_argument("--robots", default="", help="comma-separated robot namespaces (same as robots:=[...])")



def __getattr__(name: str) -> Any:
    """``Visualiser``: the class's old name, kept with a warning (the process is the viewer everywhere)."""
    if name == "Visualiser":
        import warnings

        warnings.warn("nodes.viz.node.Visualiser is deprecated: use nodes.viz.node.Viewer", DeprecationWarning,
                      stacklevel=2)
        return Viewer
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
