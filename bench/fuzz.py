"""Hostile input at scale: malformed payloads on every input of the running main job, then a health check.

    python bench/fuzz.py [--payloads 10000] [--seconds 300] [--seed 1] [--big 60]
                         [--classes names,meshes,accumulation,fan-out | all | none] [--no-random]

Starts ``python -m launch humanoid.yaml gui:=false commander:=none`` (realtime) on a free port, finds every
input of the job on its graph (our ``@graph`` tokens: subscriptions, services, actions; rmw_zenoh's
``@ros2_lv`` tokens: the ROS 2 wire's subscriptions and services) and sends, seeded and bounded in time:

- first the regressions found by hand (issue #13, and issue #25's worlds: SDF models with entities, 400,000
  models, absurd masses and sizes, zero inertia, meshes out of their folder; entity states, wrenches and
  efforts beyond bounds or on what is not there): gravity 1e308, a time step of 5e-324, a 10,000-link URDF,
  ``../../etc/passwd`` meshes, strictness 99, a million controller names, a 10 MB name, ``this:Nope`` as a
  controller type, a forged hardware/state frame with stamp 0, a second source on hardware/command,
  trajectories of ±100 rad, 10⁴ rad/s, 68 years, negative stamps, 110,000 points;
- then random cases on every target: random bytes, truncated messages, wrong types, NaN/inf, unknown fields,
  integers out of range, top-level non-maps, deep nesting, wrong UUID lengths, 10⁶-element arrays,
  multi-MB payloads (over the 4 MiB decode limit, and over the 16 MiB transport limit), unknown joints,
  mismatched lengths, absurd durations. Every payload is checked locally to be one no decoder accepts, or is a
  request the node must decline (so the fuzz never pauses, resets or moves the robot by accident).

Then it checks: every process alive and never restarted (crashes), every service answering a valid request
and joint_states never silent for a second (hangs), the robot standing, the controllers, entities and physics
as before and a valid trajectory still followed (state lost), RSS growth per process under 10 %, and every
target's rejections logged on rosout naming the key and the field. Prints a table, then a JSON line.

Then the classes of ``bench/fuzz_classes.py`` (long and wildcard names, mesh contents, accumulation, include
fan-out), each on a job started with a model path of hostile files: per class, what was refused well (declined
with the limit, field or file named) and what broke (accepted, unanswered, refused without its reason, or the
job hurt: a process restarted, joint_states stopped, the camera blinded).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgpack
import psutil
import zenoh

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import msgs  # noqa: E402 - after the path is set (bench scripts run from anywhere)
from bench import fuzz_classes  # noqa: E402
from bench.common import MAIN_JOB_CONTROLLERS, Launch  # noqa: E402
from msgs import cdr  # noqa: E402
from msgs.idl import FLOAT_TYPES, INT_RANGES, STRING_TYPES  # noqa: E402
from msgs.registry import get_spec  # noqa: E402
from nodes.core import graph  # noqa: E402
from nodes.core.log import SITE_RATE  # noqa: E402
from nodes.core.ros2 import names as ros2_names  # noqa: E402
from nodes.core.session import DEFAULT_MAX_PAYLOAD, max_transport_message_bytes  # noqa: E402
from nodes.sim import interfaces as _sim_interfaces  # noqa: E402,F401 - registers the simulator's service types
from tests.support.samples import chain_urdf  # noqa: E402

NS = "humanoid"
JTC = f"{NS}/joint_trajectory_controller"
STANDING_Z = 0.8            # the pelvis stands at ~0.91 m
SILENCE_LIMIT_S = 1.0       # joint_states arrive every 10 ms; a second without them is a stall
RSS_LIMIT = 0.10
KNEE_JOINTS = ["left_hip_pitch", "left_knee", "left_ankle_pitch", "right_hip_pitch", "right_knee",
               "right_ankle_pitch"]
KNEE_BEND = [-0.2, 0.4, -0.2, -0.2, 0.4, -0.2]


# ---------------------------------------------------------------------------------------------- the job
class Job(Launch):
    """The launched main job and a plain Zenoh peer watching joint_states, model_states and rosout."""

    def __init__(self, log_dir: Path, mode: str = "realtime", commander: str = "none") -> None:
        super().__init__("humanoid.yaml", f"commander:={commander}", f"mode:={mode}", log_dir=log_dir)
        self.lock = threading.Lock()
        self.joint_states: list[tuple[float, dict[str, float]]] = []
        self.last_positions: dict[str, float] = {}
        self.max_silence = 0.0
        self.pelvis: list[tuple[float, float]] = []
        self.entities: set[str] = set()
        self.rosout: list[tuple[float, int, str, str]] = []   # (time, level, node, text)
        self.session: zenoh.Session | None = None
        self.ros2_tokens: list[Any] = []
        self._watch_silence = False
        self._last_js = 0.0

    def start(self, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        s = self.session = self.peer(timeout)
        s.declare_subscriber(f"{NS}/joint_states", self._on_joint_states)
        s.declare_subscriber("sim/model_states", self._on_model_states)
        s.declare_subscriber("rosout", self._on_rosout)
        self.wait(lambda: self.last_positions, deadline - time.monotonic(), "joint_states")
        self.wait(lambda: "controller manager ready" in self.output() and self._controllers_active(),
                  deadline - time.monotonic(), "the main job's controllers active", interval=0.2)

    def _controllers_active(self) -> bool:
        try:
            return {c["name"]: c["state"] for c in self.controllers()} == dict.fromkeys(MAIN_JOB_CONTROLLERS, "active")
        except RuntimeError:
            return False

    def _on_joint_states(self, sample: zenoh.Sample) -> None:
        msg = observed(sample, ("name", "position"))
        if msg is None:
            return   # one of our own fuzz payloads (joint_states is an input of the state publisher)
        now = time.monotonic()
        with self.lock:
            if self._watch_silence and self._last_js:
                self.max_silence = max(self.max_silence, now - self._last_js)
            self._last_js = now
            self.last_positions = dict(zip(msg["name"], msg["position"]))

    def _on_model_states(self, sample: zenoh.Sample) -> None:
        msg = observed(sample, ("name", "pose"))
        if msg is None:
            return
        with self.lock:
            self.entities = set(msg["name"])
            if NS in msg["name"]:
                self.pelvis.append((time.monotonic(), msg["pose"][msg["name"].index(NS)]["position"]["z"]))
                del self.pelvis[:-20000]

    def _on_rosout(self, sample: zenoh.Sample) -> None:
        try:
            msg = msgpack.unpackb(sample.payload.to_bytes())
            line = (time.monotonic(), int(msg["level"]), str(msg["name"]), str(msg["msg"]))
        except Exception:  # noqa: BLE001 - our own fuzz payloads are not sent to rosout, but be safe
            return
        with self.lock:
            self.rosout.append(line)

    def watch_silence(self, on: bool) -> None:
        with self.lock:
            self._watch_silence = on
            self._last_js = time.monotonic()

    def call(self, key: str, request: dict, timeout: float = 5.0) -> dict:
        assert self.session is not None
        for reply in self.session.get(key, payload=msgpack.packb(request, use_bin_type=True), timeout=timeout):
            if reply.ok is not None:
                return msgpack.unpackb(reply.ok.payload.to_bytes())
            raise RuntimeError(f"{key}: {reply.err.payload.to_bytes()[:300]!r}")
        raise RuntimeError(f"{key}: no reply within {timeout} s")

    def controllers(self) -> list[dict]:
        rows = self.call(f"{NS}/controller_manager/list_controllers", {})["controller"]
        return [{"name": r["name"], "state": r["state"], "type": r["type"]} for r in rows]

    def physics(self) -> dict:
        props = self.call("sim/get_physics_properties", {})
        return {k: props[k] for k in ("time_step", "pause", "gravity", "has_ground", "mode", "real_time_factor")}

    def processes(self) -> dict[str, psutil.Process]:
        """The launcher ('launch', holding the embedded router) and each node process, by node name."""
        found = {"launch": psutil.Process(self.proc.pid)}
        for child in found["launch"].children(recursive=True):
            try:
                cmd = child.cmdline()
            except psutil.Error:
                continue
            if "--name" in cmd:
                found[cmd[cmd.index("--name") + 1]] = child
            elif "-m" in cmd:
                found[cmd[cmd.index("-m") + 1]] = child
        return found

    def started(self) -> Counter:
        return Counter(re.findall(r"started '([^']+)' \[pid \d+\]", self.output()))


def observed(sample: zenoh.Sample, fields: tuple[str, ...]) -> dict | None:
    """A message of the job itself (our fuzz payloads on the same keys carry no zenroid attachment)."""
    if sample.attachment is None:
        return None
    try:
        msg = msgpack.unpackb(sample.payload.to_bytes())
        return msg if isinstance(msg, dict) and all(f in msg for f in fields) else None
    except Exception:  # noqa: BLE001
        return None


def rss_mb(processes: dict[str, psutil.Process]) -> dict[str, float]:
    out = {}
    for name, proc in processes.items():
        try:
            out[name] = proc.memory_info().rss / 1e6
        except psutil.Error:
            out[name] = float("nan")
    return out


# ---------------------------------------------------------------------------------------------- targets
@dataclass(frozen=True)
class Target:
    kind: str          # topic | service | ros2_topic | ros2_service
    key: str           # what we put or query
    type_name: str     # the message (topic) or request type our decoder applies
    node: str = ""


def discover(session: zenoh.Session) -> list[Target]:
    targets: dict[str, Target] = {}
    for entry in graph.snapshot(session, timeout=3.0):
        if entry.node.startswith("/fuzz"):
            continue
        if entry.kind == "sub":
            targets[entry.name] = Target("topic", entry.name, entry.type_name, entry.node)
        elif entry.kind == "srv":
            srv = msgs.get_type(entry.type_name)
            targets[entry.name] = Target("service", entry.name, srv.Request._type, entry.node)
        elif entry.kind == "act":
            action = msgs.get_type(entry.type_name)
            for part, request in (("send_goal", action.SendGoalRequest), ("cancel_goal", msgs.get_type("action_msgs/srv/CancelGoal").Request),
                                  ("get_result", action.GetResultRequest)):
                key = f"{entry.name}/{part}"
                targets[key] = Target("service", key, request._type, entry.node)
    seen = set()
    tokens: list[str] = []
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:   # a fresh session may see none or part of the tokens: until stable
        found = sorted(str(r.ok.key_expr) for r in session.liveliness().get(f"{ros2_names.ADMIN_SPACE}/**",
                                                                              timeout=2.0) if r.ok is not None)
        if found and found == tokens:
            break
        tokens = found
        time.sleep(0.2)
    for token in tokens:
        endpoint = ros2_names.parse_endpoint_token(token)
        if endpoint is None or endpoint.data_key in seen:
            continue
        if endpoint.kind == ros2_names.SUBSCRIPTION:
            seen.add(endpoint.data_key)
            targets[endpoint.data_key] = Target("ros2_topic", endpoint.data_key, endpoint.type_name)
        elif endpoint.kind == ros2_names.SERVICE:
            seen.add(endpoint.data_key)
            targets[endpoint.data_key] = Target("ros2_service", endpoint.data_key, f"{endpoint.type_name}_Request")
    return sorted(targets.values(), key=lambda t: (t.kind, t.key))


def announce_ros2_publishers(session: zenoh.Session, targets: list[Target]) -> list[Any]:
    """The liveliness tokens of a ROS 2 publisher on every ROS 2 topic target, as rmw_zenoh declares them:
    our subscription mirrors listen on a data key only while a foreign publisher announces it."""
    zid = str(session.info.zid())
    tokens = []
    for entity_id, target in enumerate((t for t in targets if t.kind == "ros2_topic"), start=1):
        domain, rest = target.key.split("/", 1)
        ros_name = "/" + rest.rsplit("/", 2)[0]
        tokens.append(session.liveliness().declare_token(ros2_names.endpoint_token(
            int(domain), zid, 0, entity_id, ros2_names.PUBLISHER, "/", "fuzzer", ros_name, target.type_name,
            ros2_names.DEFAULT_QOS)))
    return tokens


# ---------------------------------------------------------------------------------------------- payloads
@dataclass
class Case:
    target: Target
    category: str
    payload: bytes
    semantic: bool = False     # decodes, and the node must decline it


def pack(obj: Any) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


def dur(seconds: float) -> dict:
    sec = math.floor(seconds)
    return {"sec": int(sec), "nanosec": int(round((seconds - sec) * 1e9)) % 1_000_000_000}


def trajectory(joints: list[str], points: list[tuple[float, list[float]]], **extra: Any) -> dict:
    return {"joint_names": joints, "points": [{"positions": p, "time_from_start": dur(t)} for t, p in points],
            **extra}


def mesh_urdf(path: str) -> str:
    return ('<robot name="meshy"><link name="base"><visual><geometry><mesh filename="' + path + '"/></geometry>'
            '</visual><collision><geometry><mesh filename="' + path + '"/></geometry></collision>'
            '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>'
            '</inertial></link></robot>')


def bad_sdf_models() -> list[tuple[str, str]]:
    """SDF spawn requests the simulator must refuse (issue #25), by category."""
    def model(body: str) -> str:
        return f"<?xml version='1.0'?><sdf version='1.7'><model name='m'>{body}</model></sdf>"

    box = ("<link name='l'><inertial><mass>{mass}</mass><inertia><ixx>{i}</ixx><iyy>{i}</iyy><izz>{i}</izz>"
           "</inertia></inertial><collision name='c'><geometry><box><size>{size}</size></box></geometry>"
           "</collision></link>")
    return [
        ("SDF billion laughs", "<?xml version='1.0'?><!DOCTYPE sdf [<!ENTITY a 'aaaa'><!ENTITY b '&a;&a;&a;'>]>"
                               "<sdf version='1.7'><model name='&b;'/></sdf>"),
        ("SDF external entity", "<?xml version='1.0'?><!DOCTYPE sdf SYSTEM 'file:///etc/passwd'><sdf version='1.7'/>"),
        ("SDF unknown model://", model("<link name='l'/><include><uri>model://no_such_model</uri></include>")),
        # 400,000 (3.2 MB) stays under the 4 MiB decode limit, so the simulator's own count refuses it
        ("SDF 400,000 models", "<sdf version='1.7'>" + "<model/>" * 400_000 + "</sdf>"),
        ("SDF absurd values", model(box.format(mass="1e30", i="1", size="1 1 1"))),
        ("SDF absurd values", model(box.format(mass="1", i="1", size="1e9 1 1"))),
        ("SDF absurd values", model("<pose>nan 0 0 0 0 0</pose>" + box.format(mass="1", i="1", size="1 1 1"))),
        ("SDF zero inertia", model(box.format(mass="1", i="0", size="1 1 1"))),
        ("SDF mesh escape", model("<static>true</static><link name='l'><visual name='v'><geometry><mesh>"
                                  "<uri>file:///etc/passwd</uri></mesh></geometry></visual></link>")),
    ]


def bad_camera_urdfs() -> list[tuple[str, str]]:
    """The shipped humanoid with one bad camera or laser declaration each (issue #27), by category."""
    xml = (ROOT / "robots" / "humanoid.urdf").read_text()
    edits = [
        ("camera pixel cap", "<width>320</width><height>240</height>", "<width>40000</width><height>30000</height>"),
        ("camera fov", "<horizontal_fov>1.047</horizontal_fov>", "<horizontal_fov>3.2</horizontal_fov>"),
        ("camera clip", "<near>0.05</near><far>10</far>", "<near>10</near><far>0.05</far>"),
        ("camera format", "<format>R8G8B8</format>", "<format>ZZZ</format>"),
        ("camera rate", "<update_rate>30</update_rate>", "<update_rate>1e6</update_rate>"),
        ("laser rays cap", "<samples>720</samples>", "<samples>10000000</samples>"),
        ("laser range", "<min>0.1</min><max>10</max>", "<min>10</min><max>0.1</max>"),
        # names that are no ROS names (issue 36): each once blinded every rendered sensor
        ("camera namespace **", "<remapping>camera/image_raw:=camera/rgb</remapping>",
         "<namespace>**</namespace><remapping>camera/image_raw:=camera/rgb</remapping>"),
        ("sensor name a/*/b", '<sensor name="camera" type="depth">', '<sensor name="a/*/b" type="depth">'),
        ("remap ~/out:=**", "<remapping>camera/depth/image_raw:=camera/depth</remapping>",
         "<remapping>~/out:=**</remapping>"),
    ]
    return [(category, xml.replace(good, bad, 1)) for category, good, bad in edits]


# What the job must say on rosout about the regressions (each names the field or the sender).
REGRESSION_LOG_LINES = {
    "gravity 1e308": r"gravity\.z = 1e\+308 m/s\^2 is outside",
    "time_step 5e-324": r"time_step: 5e-324 s is outside",
    "10,000-link URDF": r"10001 <link> elements, over the simulator's limit",
    "mesh ../../etc/passwd": r"mesh (of link '\w+': )?'\.\./\.\./etc/passwd'",
    "strictness 99": r"strictness: 99 is not BEST_EFFORT",
    "10⁶ controller names": r"activate_controllers: too long \(1000000 exceeds max_array_len",
    "this:Nope as a type": r"type must be 'package/Class', got 'this:Nope'",
    "forged hardware/state": r"hardware/state: ignored \d+ frame",
    "second commander": r"two sources command this robot",
    "110,000 points": r"JointTrajectory.*: points: too long \(110000 exceeds max_array_len",
    "±100 rad": r"100 rad is outside|outside its (upper|lower) limit",
    "68 years": r"time_from_start .* longer than",
    "SDF billion laughs": r"XML declares entities",
    "SDF 400,000 models": r"400000 <model>/<include> elements, more than the limit",
    "SDF zero inertia": r"inertia is not positive definite",
    "SDF mesh escape": r"mesh 'file:///etc/passwd'",
    "set_entity_state 1e9 m": r"set_entity_state 'humanoid' refused: state.pose.position: \[1000000000.0",
    "apply_link_wrench 1e12 N": r"apply_link_wrench 'humanoid::torso' refused: wrench.force",
    "apply_joint_effort 1e12": r"apply_joint_effort 'humanoid::left_knee' refused: effort",
    "camera pixel cap": r"sensor 'camera'.*1200000000 pixels, over the cap",
    "camera fov": r"sensor 'camera'.*<horizontal_fov> 3.2: must be in \(0, pi\)",
    "camera format": r"sensor 'camera'.*<format> 'ZZZ' is not one of",
    "laser rays cap": r"sensor 'laser'.*rays a scan, over the cap",
    "100,000-character robot_namespace": r"robot_namespace 'n+'\.\.\. \(100000 characters\): 100000 characters, "
                                         r"over the limit of 245",
    "camera namespace **": r"<ros><namespace> '\*\*': has '\*'",
    "sensor name a/*/b": r"sensor 'a/\*/b'.*<sensor name> has '\*'",
    "remap ~/out:=**": r"<remapping> '~/out:=\*\*': to '\*\*' has '\*'",
    "render frame of the wrong size": r"sim/render/frame: 3 pose values for \d+ links: ignored",
}


def regressions(targets: dict[str, Target]) -> list[Case]:
    """The cases found by hand (issue #13), each a request the job must decline."""
    cases: list[Case] = []

    def add(key: str, category: str, obj: Any, semantic: bool = True) -> None:
        if key in targets:
            cases.append(Case(targets[key], category, obj if isinstance(obj, bytes) else pack(obj), semantic))

    physics = "sim/set_physics_properties"
    for gravity in ({"z": 1e308}, {"z": 1e6}, {"x": -101.0}):
        add(physics, "physics out of range", {"set_gravity": True, "gravity": gravity})
    for step in (5e-324, -0.001, 0.5):
        add(physics, "physics out of range", {"time_step": step})
    add(physics, "physics out of range", {"real_time_factor": 1e9})
    add(physics, "long string", {"mode": "x" * 100_000})
    spawn = "sim/spawn_entity"
    add(spawn, "10,000-link URDF", {"name": "chain", "xml": chain_urdf(10_000)})
    for path in ("../../etc/passwd", "/etc/passwd", "/dev/zero", "file:///etc/shadow"):
        add(spawn, "mesh path escape", {"name": "meshy", "xml": mesh_urdf(path)})
    add(spawn, "billion laughs", {"name": "lol", "xml": '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa">'
                                  '<!ENTITY b "&a;&a;&a;&a;">]><robot name="r"><link name="&b;"/></robot>'})
    add(spawn, "bad name", {"name": "../../x", "xml": mesh_urdf("m.stl")})
    add(spawn, "100,000-character robot_namespace", {"name": "fuzz_ns", "xml": chain_urdf(2),
                                                     "robot_namespace": "n" * 100_000})
    for category, xml in bad_sdf_models():
        add(spawn, category, {"name": "fuzz_sdf", "xml": xml})
    for category, xml in bad_camera_urdfs():
        add(spawn, category, {"name": "fuzz_eyes", "xml": xml, "robot_namespace": "fuzz_eyes"})
    # the renderer's inputs: a frame that does not fit the scene, a frame of a scene nobody published
    frame = msgs.packer("zenroid_msgs/msg/RenderFrame")
    for version in range(1, 6):   # one of them is the scene the renderer has
        add("sim/render/frame", "render frame of the wrong size", frame(
            stamp={"sec": 1, "nanosec": 0}, step=1, scene_version=version, poses=[0.0, 0.0, 0.0],
            sensors=[f"fuzz::sensor_{version}"]))   # realtime: the renderer draws each sensor's newest frame
    add("sim/render/frame", "render frame of another scene", frame(
        stamp={"sec": 1, "nanosec": 0}, step=1, scene_version=10**6, poses=[], sensors=["humanoid::camera"]))
    entity_state = "sim/set_entity_state"
    add(entity_state, "entity: unknown", {"state": {"name": "no_such_model"}})
    add(entity_state, "entity: absurd pose", {"state": {"name": NS, "pose": {"position": {"x": 1e9}}}})
    add(entity_state, "entity: absurd twist", {"state": {"name": NS, "twist": {"linear": {"z": 1e9}}}})
    add(entity_state, "entity: the ground", {"state": {"name": "ground_plane"}})
    add("sim/get_entity_state", "entity: unknown", {"name": "humanoid::no_such_link"})
    wrench = "sim/apply_link_wrench"
    add(wrench, "wrench: absurd force", {"link_name": f"{NS}::torso", "wrench": {"force": {"x": 1e12}},
                                         "duration": {"sec": 1, "nanosec": 0}})
    add(wrench, "wrench: unknown link", {"link_name": "nope::x", "wrench": {"force": {"x": 1.0}},
                                         "duration": {"sec": 1, "nanosec": 0}})
    add(wrench, "wrench: zero duration", {"link_name": f"{NS}::torso", "wrench": {"force": {"x": 1.0}}})
    add(wrench, "wrench: static model", {"link_name": "table", "wrench": {"force": {"x": 1.0}},
                                         "duration": {"sec": 1, "nanosec": 0}})
    effort = "sim/apply_joint_effort"
    add(effort, "effort: unknown joint", {"joint_name": "nope", "effort": 1.0, "duration": {"sec": 1, "nanosec": 0}})
    add(effort, "effort: absurd", {"joint_name": f"{NS}::left_knee", "effort": 1e12,
                                   "duration": {"sec": 1, "nanosec": 0}})
    cm = f"{NS}/controller_manager"
    add(f"{cm}/switch_controller", "strictness", {"deactivate_controllers": ["joint_trajectory_controller"],
                                                   "strictness": 99})
    add(f"{cm}/switch_controller", "strictness", {"activate_controllers": ["nope"], "strictness": 99})
    add(f"{cm}/switch_controller", "unknown controller", {"activate_controllers": ["nope"], "strictness": 2})
    add(f"{cm}/switch_controller", "10⁶ names", {"activate_controllers": ["c"] * 1_000_000, "strictness": 2})
    add(f"{cm}/switch_controller", "multi-MB payload", {"activate_controllers": ["n" * 10_000_000], "strictness": 2},
        semantic=False)
    add(f"{cm}/switch_controller", "long string", {"activate_controllers": ["n" * 100_000], "strictness": 2})
    add(f"{cm}/set_controller_parameters", "controller type import", {"names": ["fuzz_evil"],
                                                                       "values_yaml": ["type: this:Nope"]})
    add(f"{cm}/set_controller_parameters", "YAML alias", {"names": ["fuzz_evil"], "values_yaml": ["a: &a [*a]"]})
    add(f"{cm}/load_controller", "controller type import", {"name": "fuzz_evil"})
    add(f"{cm}/load_controller", "controller type import", {"name": "os:system"})
    add(f"{cm}/load_controller", "long string", {"name": "x" * 100_000})
    add(f"{NS}/hardware/state", "forged frame", msgs.packer("zenroid_msgs/msg/HardwareState")(
        step=0, stamp={"sec": 0, "nanosec": 0}, name=["left_knee"], position=[0.0], velocity=[0.0], effort=[0.0]))
    legs = ["left_hip_pitch", "left_knee", "right_hip_pitch", "right_knee"]
    for _ in range(200):
        add(f"{NS}/hardware/command", "second commander", msgs.packer("zenroid_msgs/msg/HardwareCommand")(
            step=10**9, update_rate=1000, name=legs, interface=["position"] * 4, value=[-1.5, 2.0, 1.0, 0.0]))
    for category, traj in bad_trajectories():
        add(f"{JTC}/joint_trajectory", category, traj)
        add(f"{JTC}/follow_joint_trajectory/send_goal", category,
            {"goal_id": {"uuid": os.urandom(16)}, "goal": {"trajectory": traj}})
    return cases


def bad_trajectories() -> list[tuple[str, dict]]:
    knee = ["left_knee"]
    return [
        ("out of limits", trajectory(knee, [(1.0, [100.0])])),
        ("out of limits", trajectory(knee, [(1.0, [-100.0])])),
        ("absurd duration", trajectory(knee, [(2**31 - 1, [0.1])])),
        ("absurd duration", trajectory(knee, [(68 * 365.25 * 86400, [0.1])])),
        ("negative stamp", trajectory(knee, [(1.0, [0.1])], header={"stamp": {"sec": -5, "nanosec": 0}})),
        ("negative duration", {"joint_names": knee, "points": [
            {"positions": [0.1], "time_from_start": {"sec": -3, "nanosec": 0}}]}),
        ("unknown joint", trajectory(["no_such_joint"], [(1.0, [0.1])])),
        ("mismatched lengths", trajectory(["left_knee", "right_knee"], [(1.0, [0.1])])),
        ("duplicate joint", trajectory(["left_knee", "left_knee"], [(1.0, [0.1, 0.1])])),
        ("non-increasing times", trajectory(knee, [(1.0, [0.1]), (1.0, [0.2])])),
        ("110,000 points", {"joint_names": knee, "points": [{"positions": [0]}] * 110_000}),   # 1.5 MB
    ]


class Generator:
    """Random malformed payloads for one target at a time (seeded)."""

    def __init__(self, seed: int, big_budget: int) -> None:
        self.rng = random.Random(seed)
        self.big_left = big_budget

    # --- building blocks --------------------------------------------------------------------------
    def sample(self, type_name: str, depth: int = 0) -> dict:
        """A plausible valid message as plain data (random sizes, then made invalid by a mutation)."""
        out: dict[str, Any] = {}
        for f in get_spec(type_name).fields:
            n = f.array_size if f.array_size is not None else self.rng.randint(0, 3 if depth < 2 else 0)
            if f.is_bytes:
                out[f.name] = bytes(self.rng.getrandbits(8) for _ in range(n))
            elif f.is_array:
                out[f.name] = [self.scalar(f.base, depth) for _ in range(n)]
            else:
                out[f.name] = self.scalar(f.base, depth)
        return out

    def scalar(self, base: str, depth: int) -> Any:
        if base == "bool":
            return self.rng.random() < 0.5
        if base in FLOAT_TYPES:
            return self.rng.uniform(-1, 1)
        if base in INT_RANGES:
            lo, hi = INT_RANGES[base]
            return self.rng.randint(max(lo, -5), min(hi, 5))
        if base in STRING_TYPES:
            return self.rng.choice(["", "left_knee", "x", "joint_trajectory_controller", "é"])
        return self.sample(base, depth + 1)

    def wrong_value(self, base: str, is_array: bool, is_bytes: bool) -> Any:
        if is_bytes:
            return self.rng.choice([1.5, "text", {}, [300], [-1]])
        if is_array:
            return self.rng.choice([1.5, "text", {}, [{}], [None], ["x"] if base not in STRING_TYPES else [1]])
        if base in INT_RANGES:
            lo, hi = INT_RANGES[base]
            return self.rng.choice(["x", 1.5, [], {}, math.nan, *(v for v in (lo - 1, hi + 1) if -(2**63) <= v < 2**64)])
        if base in FLOAT_TYPES:
            return self.rng.choice(["x", [], {}, math.nan, math.inf, -math.inf])
        if base == "bool":
            return self.rng.choice(["x", 1.5, [], {}])
        if base in STRING_TYPES:
            return self.rng.choice([1, 1.5, [], {}])
        return self.rng.choice([[], "text", 1.5, {"zz_unknown": 1}])

    def _paths(self, type_name: str, prefix: tuple = ()) -> list[tuple[tuple, Any]]:
        """(path, field spec) of every field, nested messages included (depth-limited)."""
        out = []
        for f in get_spec(type_name).fields:
            out.append((prefix + (f.name,), f))
            if not f.is_primitive and not f.is_array and len(prefix) < 3:
                out += self._paths(f.base, prefix + (f.name,))
        return out

    # --- categories -------------------------------------------------------------------------------
    def make(self, target: Target) -> Case:
        if target.kind.startswith("ros2"):
            return self._cdr(target)
        cls = msgs.get_type(target.type_name)
        categories = ["random bytes", "truncated", "wrong type", "unknown field", "not a map", "deep nesting"]
        paths = self._paths(target.type_name)
        if any(f.base in FLOAT_TYPES for _, f in paths):
            categories.append("NaN/inf")
        if any(f.base in INT_RANGES and not f.is_array for _, f in paths):
            categories.append("integer out of range")
        if "uuid" in json.dumps([p for p, _ in paths]):
            categories.append("wrong UUID length")
        if self.big_left > 0 and self.rng.random() < 0.02:
            self.big_left -= 1
            categories = ["10⁶-element array", "multi-MB payload", "over the transport limit"]
        category = self.rng.choice(categories)
        payload = self._makers[category](self, target, cls, paths)
        if category not in ("10⁶-element array", "multi-MB payload", "over the transport limit"):
            payload = self._ensure_invalid(cls, payload)
        return Case(target, category, payload)

    def _ensure_invalid(self, cls: Any, payload: bytes) -> bytes:
        """Every random case must be one no decoder accepts (an accepted one could pause or reset the world)."""
        try:
            msgs.decode(cls, payload)
        except msgs.DecodeError:
            return payload
        return pack({"zz_not_a_field": payload})

    def _random_bytes(self, target: Target, cls: Any, paths: list) -> bytes:
        return bytes(self.rng.getrandbits(8) for _ in range(self.rng.randint(1, 2048)))

    def _truncated(self, target: Target, cls: Any, paths: list) -> bytes:
        data = pack(self.sample(target.type_name))
        return data[: self.rng.randint(0, max(0, len(data) - 1))] or b"\x81"

    def _set(self, doc: dict, path: tuple, value: Any) -> None:
        for part in path[:-1]:
            doc = doc.setdefault(part, {})
            if not isinstance(doc, dict):
                return
        doc[path[-1]] = value

    def _wrong_type(self, target: Target, cls: Any, paths: list) -> bytes:
        doc = self.sample(target.type_name)
        if paths:
            path, f = self.rng.choice(paths)
            self._set(doc, path, self.wrong_value(f.base, f.is_array, f.is_bytes))
        return pack(doc)

    def _nan_inf(self, target: Target, cls: Any, paths: list) -> bytes:
        doc = self.sample(target.type_name)
        floats = [(p, f) for p, f in paths if f.base in FLOAT_TYPES]
        path, f = self.rng.choice(floats)
        bad = self.rng.choice([math.nan, math.inf, -math.inf])
        self._set(doc, path, [bad] * self.rng.randint(1, 3) if f.is_array else bad)
        return pack(doc)

    def _integer_out_of_range(self, target: Target, cls: Any, paths: list) -> bytes:
        doc = self.sample(target.type_name)
        ints = [(p, f) for p, f in paths if f.base in INT_RANGES and not f.is_array]
        path, f = self.rng.choice(ints)
        lo, hi = INT_RANGES[f.base]
        candidates = [v for v in (lo - 1, hi + 1, -(2**63), 2**64 - 1)
                      if not lo <= v <= hi and -(2**63) <= v < 2**64]   # what msgpack can carry
        self._set(doc, path, self.rng.choice(candidates) if candidates else "x")
        return pack(doc)

    def _unknown_field(self, target: Target, cls: Any, paths: list) -> bytes:
        doc = self.sample(target.type_name)
        doc[self.rng.choice(["zz", "Position", "joint_names ", "__class__", "x" * 300])] = 1
        return pack(doc)

    def _not_a_map(self, target: Target, cls: Any, paths: list) -> bytes:
        return pack(self.rng.choice([[1, 2, 3], 7, "text", None, 1.5, b"bytes", True]))

    def _deep_nesting(self, target: Target, cls: Any, paths: list) -> bytes:
        depth = self.rng.choice([100, 10_000, 200_000])
        return b"\x81\xa1a" + b"\x91" * depth + b"\x00"   # {"a": [[[...0...]]]}

    def _wrong_uuid_length(self, target: Target, cls: Any, paths: list) -> bytes:
        doc = self.sample(target.type_name)
        uuid = bytes(self.rng.getrandbits(8) for _ in range(self.rng.choice([0, 1, 15, 17, 1000])))
        text = json.dumps(doc, default=lambda b: "")
        if '"goal_info"' in text:
            doc["goal_info"] = {"goal_id": {"uuid": uuid}}
        else:
            doc["goal_id"] = {"uuid": uuid}
        return pack(doc)

    def _million_element_array(self, target: Target, cls: Any, paths: list) -> bytes:
        doc = self.sample(target.type_name)
        arrays = [(p, f) for p, f in paths if f.is_array] or [(("zz_array",), None)]
        path, _ = self.rng.choice(arrays)
        self._set(doc, path, [0] * 1_000_000)          # ~1 MB of msgpack, a million Python objects to build
        doc["zz_not_a_field"] = 1                       # and invalid whatever the array's type
        return pack(doc)

    def _multi_mb_payload(self, target: Target, cls: Any, paths: list) -> bytes:
        doc = self.sample(target.type_name)
        doc["zz_not_a_field"] = "m" * self.rng.randint(DEFAULT_MAX_PAYLOAD + 1, 3 * DEFAULT_MAX_PAYLOAD)
        return pack(doc)

    def _over_the_transport_limit(self, target: Target, cls: Any, paths: list) -> bytes:
        return b"\xc1" * (max_transport_message_bytes() + 1024 * self.rng.randint(1, 4096))

    _makers: dict[str, Callable[..., bytes]] = {
        "random bytes": _random_bytes, "truncated": _truncated, "wrong type": _wrong_type, "NaN/inf": _nan_inf,
        "integer out of range": _integer_out_of_range, "unknown field": _unknown_field, "not a map": _not_a_map,
        "deep nesting": _deep_nesting, "wrong UUID length": _wrong_uuid_length,
        "10⁶-element array": _million_element_array, "multi-MB payload": _multi_mb_payload,
        "over the transport limit": _over_the_transport_limit,
    }

    def _cdr(self, target: Target) -> Case:
        for _ in range(100):
            n = self.rng.choice([0, 1, 3, 4, 8, 64, 1024])
            data = bytes(self.rng.getrandbits(8) for _ in range(n))
            if self.rng.random() < 0.5 and n >= 4:
                data = b"\x00\x01\x00\x00" + data[4:]     # a valid CDR header, garbage after it
            try:
                msgs.decode(msgs.get_type(target.type_name), pack(cdr.decode(target.type_name, data)))
            except Exception:  # noqa: BLE001 - what we want: the wire refuses it
                return Case(target, "random CDR", data)
        return Case(target, "random CDR", b"\x00")


# ---------------------------------------------------------------------------------------------- running
@dataclass
class Stats:
    tried: int = 0
    by_category: Counter = field(default_factory=Counter)
    by_target: Counter = field(default_factory=Counter)
    replies: Counter = field(default_factory=Counter)   # ok / error / none
    bad_error_replies: list[str] = field(default_factory=list)
    accepted_semantic: list[str] = field(default_factory=list)
    longest_reply_chars: int = 0


def send(job: Job, case: Case, stats: Stats, query_timeout: float) -> None:
    assert job.session is not None
    stats.tried += 1
    stats.by_category[case.category] += 1
    stats.by_target[case.target.key] += 1
    if case.target.kind in ("topic", "ros2_topic"):
        job.session.put(case.target.key, case.payload, congestion_control=zenoh.CongestionControl.BLOCK)
        return
    got = "none"
    for reply in job.session.get(case.target.key, payload=case.payload, timeout=query_timeout):
        if reply.ok is not None:
            got = "ok"
            data = reply.ok.payload.to_bytes()
            stats.longest_reply_chars = max(stats.longest_reply_chars, len(data))
            if case.semantic and case.target.kind == "service":
                response = msgpack.unpackb(data)
                if any(response.get(k) is True for k in ("ok", "success", "accepted")) or (
                        response.get("successful") and all(response["successful"])):
                    stats.accepted_semantic.append(f"{case.target.key}: {case.category}")
        else:
            got = "error"
            raw = reply.err.payload.to_bytes()
            stats.longest_reply_chars = max(stats.longest_reply_chars, len(raw))
            if case.target.kind == "service":
                try:
                    text = msgpack.unpackb(raw)["error"]
                    assert isinstance(text, str) and text
                except Exception:  # noqa: BLE001 - not a clean {"error": ...} (Zenoh's own "Timeout" included)
                    if raw != b"Timeout":
                        stats.bad_error_replies.append(f"{case.target.key}: {raw[:120]!r}")
                    got = "none"
        break
    if got == "none" and case.category == "over the transport limit":
        got = "dropped by Zenoh"   # beyond max_message_size: the transport drops it, as intended
    stats.replies[got] += 1


def run(payloads: int, seconds: float, seed: int, big: int, log_dir: Path, mode: str = "realtime",
        progress: Callable[[str], None] = print) -> dict:
    job = Job(log_dir, mode)
    report: dict[str, Any] = {"payloads_goal": payloads, "seconds_limit": seconds, "seed": seed, "mode": mode}
    try:
        job.start()
        time.sleep(3.0)    # settle: the baseline is the job at rest
        targets = discover(job.session)
        job.ros2_tokens = announce_ros2_publishers(job.session, targets)  # held: dropped, they would end
        time.sleep(1.0)  # the job's subscription mirrors see the tokens and declare their subscribers
        by_key = {t.key: t for t in targets}
        report["targets"] = len(targets)
        report["target_kinds"] = dict(Counter(t.kind for t in targets))
        processes = {n: p for n, p in job.processes().items() if not n.startswith("spawner")}
        started_before = job.started()
        controllers_before = job.controllers()
        physics_before = job.physics()
        entities_before = set(job.entities)
        # Warm-up: every kind of input once (and the regressions), so one-time costs - a decoder compiled per
        # message type and limits, the log's repeat filters, Zenoh's routes and buffers - are in the baseline
        # and what is measured is what a flood leaves behind.
        rss_cold = rss_mb(processes)
        warm = Stats()
        warm_generator = Generator(seed + 1_000_003, 0)
        for case in regressions(by_key) + [warm_generator.make(t) for t in targets for _ in range(3)]:
            send(job, case, warm, query_timeout=2.0)
        time.sleep(3.0)
        rss_before = rss_mb(processes)
        cpu_before = {n: sum(p.cpu_times()[:2]) for n, p in processes.items()}
        report["warmup_payloads"] = warm.tried
        report["rss_cold_mb"] = {n: round(v, 1) for n, v in rss_cold.items()}
        progress(f"fuzz: {len(targets)} targets, RSS {sum(rss_cold.values()):.0f} MB at rest, "
                 f"{sum(rss_before.values()):.0f} MB after a warm-up of {warm.tried} payloads; sending...")

        stats = Stats()
        generator = Generator(seed, big)
        job.watch_silence(True)
        fuzz_start = time.monotonic()
        deadline = fuzz_start + seconds
        fixed = regressions(by_key)
        order = list(targets)
        i = 0
        while time.monotonic() < deadline and (fixed or stats.tried < payloads):
            if fixed:
                case = fixed.pop(0)
                if case.category in REGRESSION_LOG_LINES and case.target.kind == "service":
                    # the refusals a regression must find on rosout come from one call site each (a spawn's,
                    # a set_entity_state's): paced at the log's per-site rate, none is rate-limited away
                    time.sleep(1.0 / SITE_RATE)
            else:
                case = generator.make(order[i % len(order)])
                i += 1
            send(job, case, stats, query_timeout=2.0)
            if stats.tried % 1000 == 0:
                progress(f"  {stats.tried} payloads, {time.monotonic() - fuzz_start:.0f} s")
        fuzz_seconds = time.monotonic() - fuzz_start
        job.watch_silence(False)
        progress(f"fuzz: {stats.tried} payloads in {fuzz_seconds:.0f} s; checking...")
        time.sleep(5.0)    # let queued work drain and memory be returned

        report.update(check(job, processes, started_before, rss_before, cpu_before, controllers_before,
                            physics_before, entities_before, targets, stats, fuzz_start, fuzz_seconds))
        return report
    finally:
        job.close()


def check(job: Job, processes: dict[str, psutil.Process], started_before: Counter, rss_before: dict,
          cpu_before: dict, controllers_before: list, physics_before: dict, entities_before: set,
          targets: list[Target], stats: Stats, fuzz_start: float, fuzz_seconds: float) -> dict:
    out: dict[str, Any] = {"tried": stats.tried, "fuzz_seconds": round(fuzz_seconds, 1),
                           "by_category": dict(stats.by_category), "replies": dict(stats.replies)}
    # crashes: a process gone, or restarted by the launcher
    alive = {name: proc.is_running() and proc.status() != psutil.STATUS_ZOMBIE for name, proc in processes.items()}
    restarted = {n: c - started_before.get(n, 0) for n, c in job.started().items() if c > started_before.get(n, 0)}
    out["crashes"] = sum(not a for a in alive.values()) + sum(restarted.values())
    out["dead"] = sorted(n for n, a in alive.items() if not a)
    out["restarted"] = restarted
    # hangs: a service that does not answer a valid request, joint_states silent for a second
    unanswered = []
    probes = [(f"{NS}/controller_manager/list_controllers", {}), ("sim/get_physics_properties", {}),
              (f"{NS}/hardware/info", {})]
    probes += [(t.key, {"names": []}) for t in targets if t.key.endswith("/get_parameters")]
    for key, request in probes:
        try:
            job.call(key, request, timeout=5.0)
        except RuntimeError as exc:
            unanswered.append(f"{key}: {exc}")
    out["unanswered"] = unanswered
    out["max_joint_states_silence_s"] = round(job.max_silence, 3)
    out["hangs"] = (len(unanswered) + (1 if job.max_silence > SILENCE_LIMIT_S else 0)
                    + stats.replies.get("none", 0))   # a request neither answered nor refused within 2 s
    # state lost: robot down, controllers/physics/entities changed, a request we had to refuse accepted,
    # a valid trajectory not followed
    with job.lock:
        during = [z for t, z in job.pelvis if t >= fuzz_start]
    out["lowest_pelvis_z"] = round(min(during), 3) if during else None
    lost = []
    if not during or min(during) < STANDING_Z:
        lost.append(f"robot fell (lowest pelvis z {out['lowest_pelvis_z']})")
    try:
        if job.controllers() != controllers_before:
            lost.append(f"controllers changed: {job.controllers()}")
        if job.physics() != physics_before:
            lost.append(f"physics changed: {job.physics()} (was {physics_before})")
    except RuntimeError as exc:
        lost.append(str(exc))
    if set(job.entities) != entities_before:
        lost.append(f"entities changed: {sorted(job.entities)} (was {sorted(entities_before)})")
    lost += [f"accepted: {a}" for a in stats.accepted_semantic]
    restarts = [text for _, node, text in [(t, n, x) for t, _, n, x in job.rosout if t >= fuzz_start]
                if "controllers restarted" in text or "sim time went back" in text]
    if restarts:
        lost.append(f"controllers restarted: {restarts[0]}")
    followed = follow_trajectory(job)
    out["trajectory_followed"] = followed
    if not followed:
        lost.append("a valid trajectory was not followed")
    out["state_lost"] = lost
    out["bad_error_replies"] = stats.bad_error_replies[:10]
    out["longest_reply_bytes"] = stats.longest_reply_chars
    # memory and CPU
    rss_after = rss_mb(processes)
    out["rss_mb"] = {n: {"before": round(rss_before[n], 1), "after": round(rss_after.get(n, math.nan), 1),
                         "growth": round(rss_after.get(n, math.nan) / rss_before[n] - 1.0, 3)} for n in rss_before}
    out["rss_ok"] = all(v["growth"] < RSS_LIMIT for v in out["rss_mb"].values())
    out["cpu_s"] = {n: round(sum(p.cpu_times()[:2]) - cpu_before[n], 1) for n, p in processes.items() if alive[n]}
    # rosout: every target's rejections logged, naming the key
    with job.lock:
        lines = [(lvl, node, text) for t, lvl, node, text in job.rosout if t >= fuzz_start]
    out["rosout_lines"] = len(lines)
    out["launch_output_mb"] = round(job.out_path.stat().st_size / 1e6, 2)   # every node's stdout, prefixed
    out["rosout_longest_chars"] = max((len(text) for _, _, text in lines), default=0)
    unlogged = []
    for target in targets:
        if stats.by_target.get(target.key) and not logged(target, lines):
            unlogged.append(target.key)
    out["unlogged_targets"] = unlogged
    texts = [text for _, _, text in lines]
    out["regressions_logged"] = {what: any(re.search(pattern, t) for t in texts)
                                 for what, pattern in REGRESSION_LOG_LINES.items()}
    out["pass"] = (out["crashes"] == 0 and out["hangs"] == 0 and not lost and out["rss_ok"] and not unlogged
                   and not stats.bad_error_replies and all(out["regressions_logged"].values()))
    return out


def logged(target: Target, lines: list[tuple[int, str, str]]) -> bool:
    """A warning or error on rosout that names the target (its key, or its ROS name for the ROS 2 wire)."""
    if target.kind.startswith("ros2"):
        name = target.key.split("/", 1)[1].rsplit("/", 2)[0]      # <domain>/<name>/<type>/<hash>
        marks = [name, "/" + name]
    else:
        base, _, last = target.key.rpartition("/")
        marks = [target.key, f"{last} refused", f"{last}:"]
        if last in ("send_goal", "cancel_goal", "get_result"):
            marks.append(f"action '{base}'")      # the action server logs its three services under its key
        if target.key.endswith("/joint_trajectory"):
            marks.append(base.rsplit("/", 1)[-1] + ": ")
    return any(level >= 30 and any(m in text for m in marks) for level, _, text in lines)


def follow_trajectory(job: Job, timeout: float = 15.0) -> bool:
    """A knee bend and back, through the JTC's topic: both reached (0.05 rad)."""
    assert job.session is not None
    for target in (KNEE_BEND, [0.0] * len(KNEE_JOINTS)):
        job.session.put(f"{JTC}/joint_trajectory", pack(trajectory(KNEE_JOINTS, [(1.0, target)])))
        deadline = time.monotonic() + timeout
        while True:
            with job.lock:
                q = [job.last_positions.get(j, math.nan) for j in KNEE_JOINTS]
            if all(abs(a - b) < 0.05 for a, b in zip(q, target)):
                break
            if time.monotonic() > deadline:
                return False
            time.sleep(0.05)
    return True


# ---------------------------------------------------------------------------------------------- report
def table(report: dict) -> str:
    rows = [("payloads tried", report.get("tried")), ("targets (keys, services, actions)", report.get("targets")),
            ("seconds", report.get("fuzz_seconds")), ("crashes", report.get("crashes")),
            ("hangs", report.get("hangs")), ("state lost", len(report.get("state_lost", []))),
            ("max joint_states silence (s)", report.get("max_joint_states_silence_s")),
            ("lowest pelvis z (m)", report.get("lowest_pelvis_z")),
            ("trajectory followed after", report.get("trajectory_followed")),
            ("targets without a rosout line", len(report.get("unlogged_targets", []))),
            ("rosout lines / longest (chars)", f"{report.get('rosout_lines')} / {report.get('rosout_longest_chars')}"),
            ("launch output (MB)", report.get("launch_output_mb")),
            ("service replies ok / error / none / dropped by Zenoh",
             " / ".join(str(report.get("replies", {}).get(k, 0)) for k in ("ok", "error", "none", "dropped by Zenoh")))]
    width = max(len(r[0]) for r in rows)
    lines = [f"{k:<{width}}  {v}" for k, v in rows]
    lines.append("")
    lines.append(f"{'process':<24}{'RSS before MB':>14}{'after MB':>10}{'growth':>9}{'CPU s':>8}")
    for name, r in report.get("rss_mb", {}).items():
        lines.append(f"{name:<24}{r['before']:>14.1f}{r['after']:>10.1f}{r['growth'] * 100:>8.1f}%"
                     f"{report.get('cpu_s', {}).get(name, math.nan):>8.1f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--payloads", type=int, default=10_000, help="at least this many payloads (default 10000)")
    parser.add_argument("--seconds", type=float, default=300.0, help="stop sending after this long (default 300)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--big", type=int, default=60, help="1e6-element / multi-MB payloads among them (default 60)")
    parser.add_argument("--mode", default="realtime", choices=["realtime", "lockstep"])
    parser.add_argument("--classes", default="all",
                        help=f"classes of hostile input after the random fuzz: all, none, or some of "
                             f"{','.join(fuzz_classes.CLASSES)}")
    parser.add_argument("--no-random", action="store_true", help="only the classes")
    args = parser.parse_args(argv)
    classes = (list(fuzz_classes.CLASSES) if args.classes == "all" else
               [] if args.classes == "none" else [c.strip() for c in args.classes.split(",") if c.strip()])
    unknown = [c for c in classes if c not in fuzz_classes.CLASSES]
    if unknown:
        parser.error(f"unknown class(es) {unknown}: choose from {', '.join(fuzz_classes.CLASSES)}")

    def progress(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    report: dict[str, Any] = {"pass": True}
    with tempfile.TemporaryDirectory(prefix="zenroid-fuzz-") as tmp:
        if not args.no_random:
            report = run(args.payloads, args.seconds, args.seed, args.big, Path(tmp) / "random", args.mode,
                         progress=progress)
        class_reports = fuzz_classes.run_classes(classes, Path(tmp) / "classes", progress) if classes else []
    if class_reports:
        report["classes"] = fuzz_classes.summary(class_reports)
        report["pass"] = report.get("pass", True) and not any(r.broke for r in class_reports)
        print(fuzz_classes.table(class_reports))
    if args.no_random:
        print(json.dumps(report, default=str))
        return 0 if report["pass"] else 1
    print(table(report))
    if report.get("state_lost"):
        print("state lost: " + "; ".join(report["state_lost"])[:2000])
    missing = [k for k, v in report.get("regressions_logged", {}).items() if not v]
    if missing:
        print("regressions not reported on rosout: " + ", ".join(missing))
    if report.get("unlogged_targets"):
        print("no rosout line for: " + ", ".join(report["unlogged_targets"]))
    print(json.dumps(report, default=str))
    return 0 if report.get("pass") else 1


if __name__ == "__main__":
    sys.exit(main())
