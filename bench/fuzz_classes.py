"""Classes of hostile input for ``bench/fuzz.py``, each sent to the running main job over the wire contract
(zenoh + msgpack) or through a documented launch argument, then judged case by case and as a whole.

- ``names``: long and wildcard names everywhere a request or a robot file carries one (entity, namespace,
  sensor, plugin namespace, remap, frame, link);
- ``meshes``: mesh contents (NaN and inf vertices in OBJ and STL, garbage OBJ and DAE, an STL header that
  claims a billion triangles), spawned as SDF models from the model path;
- ``accumulation``: what piles up (held wrenches and efforts, far-future starts, sensors per robot, sensor
  samples, sensor messages over the payload limit);
- ``fan-out``: include fan-out (eight small model files, each including the next ten times), spawned and as a
  ``world:=`` file.

A case is **refused well** when the reply declines it with the reason it is expected to name (the limit, the
field or the file); it **broke** when it was accepted, not answered, or refused without its reason. After each
class the job must still be whole: no process died or restarted, the services answer, joint_states never
stopped for a second and the head camera still streams (an accepted item must not blind the renderer). A class
that leaves the job broken is reported and the job is started afresh for the next one.
"""

from __future__ import annotations

import math
import re
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgpack

from bench.common import Launch, child_env

CLASSES = ("names", "meshes", "accumulation", "fan-out")
NS = "humanoid"
CAMERA_KEY = f"{NS}/camera/rgb"
SILENCE_LIMIT_S = 1.0
HUMANOID_LINKS = ["pelvis", "torso", "head", "left_thigh", "left_shin", "left_foot", "right_thigh", "right_shin",
                  "right_foot"]


# ---------------------------------------------------------------------------------------------- files
def robot(name: str, body: str = "", base: str = "base") -> str:
    """A one-link URDF robot with ``body`` (<gazebo> blocks) added."""
    return (f'<?xml version="1.0"?><robot name="{name}"><link name="{base}"><inertial><mass value="1"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
            f'<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>{body}</robot>')


def imus(count: int, rate: float) -> str:
    return "".join(f'<gazebo reference="base"><sensor name="imu_{i}" type="imu"><update_rate>{rate:g}'
                   "</update_rate></sensor></gazebo>" for i in range(count))


def camera(name: str = "cam", width: int = 64, height: int = 48, kind: str = "camera", plugin: str = "") -> str:
    return (f'<gazebo reference="base"><sensor name="{name}" type="{kind}"><update_rate>1</update_rate><camera>'
            f"<image><width>{width}</width><height>{height}</height></image></camera>{plugin}</sensor></gazebo>")


def lidar(horizontal: int, vertical: int, plugin: str = "") -> str:
    return ('<gazebo reference="base"><sensor name="lidar" type="gpu_lidar"><update_rate>1</update_rate><lidar>'
            f"<scan><horizontal><samples>{horizontal}</samples><min_angle>-3.1</min_angle><max_angle>3.1</max_angle>"
            f"</horizontal><vertical><samples>{vertical}</samples><min_angle>-0.3</min_angle>"
            f"<max_angle>0.3</max_angle></vertical></scan></lidar>{plugin}</sensor></gazebo>")


def sdf_model(body: str) -> str:
    return f"<?xml version='1.0'?><sdf version='1.7'><model name='m'>{body}</model></sdf>"


def mesh_model(uri: str, visual: bool) -> str:
    tag = "visual" if visual else "collision"
    return sdf_model(f"<static>true</static><link name='l'><{tag} name='s'><geometry><mesh><uri>{uri}</uri></mesh>"
                     f"</geometry></{tag}></link>")


def stl(triangles: list[tuple[float, ...]], claimed: int | None = None) -> bytes:
    """A binary STL: an 80-byte header, a triangle count (``claimed`` if given) and the triangles."""
    out = bytearray(b"fuzz".ljust(80, b" "))
    out += struct.pack("<I", len(triangles) if claimed is None else claimed)
    for vertices in triangles:
        out += struct.pack("<12fH", 0.0, 0.0, 1.0, *vertices, 0)
    return bytes(out)


MESHES: dict[str, tuple[str, bytes]] = {
    "NaN vertex OBJ": ("mesh.obj", b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    "inf vertex OBJ": ("mesh.obj", b"v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
    "inf vertex STL": ("mesh.stl", stl([(math.inf, 0, 0, 1, 0, 0, 0, 1, 0)])),
    "NaN vertex STL": ("mesh.stl", stl([(math.nan, 0, 0, 1, 0, 0, 0, 1, 0)])),
    "garbage OBJ": ("mesh.obj", bytes(range(256)) * 64),
    "garbage DAE": ("mesh.dae", b"<COLLADA><library_geometries><geometry><mesh><source><float_array count='9'>"
                                b"1 2 nan</float_array></source></mesh></geometry></library_geometries></COLLADA>"),
    "huge STL header": ("mesh.stl", stl([(0, 0, 0, 1, 0, 0, 0, 1, 0)], claimed=1_000_000_000)),
}
LEAF = ("<link name='l'><inertial><mass>1</mass></inertial><collision name='c'><geometry><box><size>0.1 0.1 0.1"
        "</size></box></geometry></collision></link>")


def model_folders(root: Path) -> Path:
    """The model path the job is started with: the meshes of MESHES, an 8-level include fan-out (fan1..fan8),
    a 100-link block; returns it."""
    for i, (filename, data) in enumerate(MESHES.values()):
        folder = root / f"mesh{i}"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / filename).write_bytes(data)
        (folder / "model.sdf").write_text(mesh_model(f"model://mesh{i}/{filename}", visual=True))
    for i in range(1, 9):
        folder = root / f"fan{i}"
        folder.mkdir(parents=True, exist_ok=True)
        body = LEAF if i == 8 else "".join(f"<include><uri>model://fan{i + 1}</uri><name>m{k}</name></include>"
                                           for k in range(10))
        (folder / "model.sdf").write_text(f"<?xml version='1.0'?><sdf version='1.7'><model name='fan{i}'>{body}"
                                          "</model></sdf>")
    block = root / "block"
    block.mkdir(parents=True, exist_ok=True)
    links = "".join(LEAF.replace("name='l'", f"name='l{i}'") for i in range(100))
    (block / "model.sdf").write_text(f"<?xml version='1.0'?><sdf version='1.7'><model name='block'>{links}"
                                     "</model></sdf>")
    return root


# ---------------------------------------------------------------------------------------------- cases
@dataclass
class Case:
    """One request: sent to ``key``; refused well when declined with a reply matching ``reason``."""

    name: str
    key: str
    request: dict
    reason: str                        # regex the refusal must carry
    entity: str = ""                   # what to delete if it was wrongly accepted
    pile: str = ""                     # one of many alike: the first ones may be taken, until a cap refuses


@dataclass
class Outcome:
    name: str
    verdict: str                       # refused well | accepted | no reply | refused without its reason
    seconds: float
    text: str = ""


@dataclass
class ClassReport:
    name: str
    outcomes: list[Outcome] = field(default_factory=list)
    health: list[str] = field(default_factory=list)        # what the job lost (empty: whole)
    figures: dict[str, Any] = field(default_factory=dict)

    @property
    def refused_well(self) -> int:
        return sum(o.verdict == "refused well" for o in self.outcomes)

    @property
    def broke(self) -> list[str]:
        return [f"{o.name}: {o.verdict}" + (f" ({o.text[:160]})" if o.text else "") for o in self.outcomes
                if o.verdict != "refused well"] + self.health


def spawn(name: str, xml: str, reason: str, namespace: str = "", case: str = "") -> Case:
    return Case(case or name, "sim/spawn_entity", {"name": name, "xml": xml, "robot_namespace": namespace}, reason,
                entity=name)


def names_cases() -> list[Case]:
    long, wild = "n" * 100_000, ("**", "$*", "a//b", "a/*/b", "~x", "")
    cases = [spawn("long_ns", robot("long_ns"), r"robot_namespace", long, "robot_namespace of 100,000 characters"),
             spawn(long, robot("r"), r"name", case="name of 100,000 characters")]
    for i, bad in enumerate(wild):
        if bad:
            cases.append(spawn(f"wild_ns{i}", robot(f"wild_ns{i}"), r"robot_namespace", bad,
                               f"robot_namespace {bad!r}"))
            cases.append(spawn(bad, robot("r"), r"name", case=f"entity name {bad!r}"))
    for i, bad in enumerate(("**", "$*", "a//b", "n" * 10_000)):
        shown = bad if len(bad) < 20 else f"{len(bad)} characters"
        plugin = (f'<plugin name="p" filename="libgazebo_ros_camera.so"><ros><namespace>{bad}</namespace></ros>'
                  "</plugin>")
        cases.append(spawn(f"cam_ns{i}", robot(f"cam_ns{i}", camera(plugin=plugin)), r"namespace",
                           case=f"camera plugin namespace {shown!r}"))
    for i, bad in enumerate(("a/*/b", "**", "n" * 10_000)):
        shown = bad if len(bad) < 20 else f"{len(bad)} characters"
        cases.append(spawn(f"cam_name{i}", robot(f"cam_name{i}", camera(name=bad)), r"sensor|name",
                           case=f"sensor name {shown!r}"))
    remap = ('<plugin name="l" filename="libgazebo_ros_ray_sensor.so"><ros><remapping>~/out:=**</remapping></ros>'
             "<output_type>sensor_msgs/LaserScan</output_type></plugin>")
    cases.append(spawn("remap", robot("remap", lidar(16, 1, plugin=remap)), r"remap|\*\*", case="remap ~/out:=**"))
    frame = '<plugin name="p" filename="libgazebo_ros_camera.so"><frame_name>**</frame_name></plugin>'
    cases.append(spawn("frame", robot("frame", camera(plugin=frame)), r"frame", case="frame_name '**'"))
    cases.append(spawn("link_name", robot("link_name", base="a/*/b"), r"link|name", case="link name 'a/*/b'"))
    cases.append(Case("apply_link_wrench on a 100,000-character link", "sim/apply_link_wrench",
                      {"link_name": long, "wrench": {"force": {"x": 1.0}}, "duration": {"sec": 1, "nanosec": 0}},
                      r"link_name"))
    return cases


def meshes_cases() -> list[Case]:
    cases = []
    for i, (what, (filename, _)) in enumerate(MESHES.items()):
        for visual in (True, False):
            where = "visual" if visual else "collision"
            cases.append(spawn(f"mesh{i}_{where}", mesh_model(f"model://mesh{i}/{filename}", visual),
                               re.escape(filename), case=f"{what} as a {where} mesh"))
    return cases


def accumulation_cases() -> list[Case]:
    held = {"wrench": {}, "duration": {"sec": -1, "nanosec": 0}}
    cases = [Case(f"held zero-newton wrench #{i + 1} on box_small", "sim/apply_link_wrench",
                  {"link_name": "box_small", **held}, r"limit per link", pile="300 held wrenches on box_small")
             for i in range(300)]
    cases += [Case(f"held wrench #{i + 1} on {NS}::{link}", "sim/apply_link_wrench",
                   {"link_name": f"{NS}::{link}", **held}, r"limit (per link|in total)",
                   pile=f"12 held wrenches on each of {len(HUMANOID_LINKS)} humanoid links")
              for link in HUMANOID_LINKS for i in range(12)]
    cases.append(Case("wrench starting at 2^31 s", "sim/apply_link_wrench",
                      {"link_name": "box_medium", "start_time": {"sec": 2**31 - 1, "nanosec": 0}, **held},
                      r"horizon"))
    cases += [Case(f"held effort #{i + 1} on {NS}::left_knee", "sim/apply_joint_effort",
                   {"joint_name": f"{NS}::left_knee", "effort": 0.0, "duration": held["duration"]},
                   r"limit (per joint|in total)",
                   pile="40 held zero efforts on left_knee") for i in range(40)]
    cases += [
        spawn("imus", robot("imus", imus(1000, 1000.0)), r"limit of \d+ sensors a robot",
              case="1,000 IMUs at 1 kHz"),
        spawn("fast_imus", robot("fast_imus", imus(60, 1000.0)), r"samples a simulated second.*over the limit",
              case="60 IMUs at 1 kHz"),
        spawn("hd", robot("hd", camera(width=1920, height=1080)), r"payload limit", case="1920x1080 camera"),
        spawn("hd_depth", robot("hd_depth", camera(width=1920, height=1080, kind="depth")), r"payload limit",
              case="1920x1080 depth camera"),
        spawn("mega_lidar", robot("mega_lidar", lidar(1000, 1000)), r"payload limit", case="10^6-ray lidar"),
    ]
    return cases


def fan_out_cases() -> list[Case]:
    fan = sdf_model("<include><uri>model://fan1</uri></include>")
    two = sdf_model("".join(f"<include><uri>model://block</uri><name>b{k}</name></include>" for k in range(2)))
    return [spawn("fan", fan, r"more than \d+ (links|models)", case="include fan-out, 10^7 links"),
            spawn("blocks", two, r"more than \d+ links", case="two 100-link blocks in one model")]


MAKERS: dict[str, Callable[[], list[Case]]] = {"names": names_cases, "meshes": meshes_cases,
                                               "accumulation": accumulation_cases, "fan-out": fan_out_cases}


# ---------------------------------------------------------------------------------------------- the job
class Watch:
    """joint_states silence and camera frames, from the job's own publishers (with a zenroid attachment)."""

    def __init__(self, session: Any) -> None:
        self.lock = threading.Lock()
        self.last_js = time.monotonic()
        self.max_silence = 0.0
        self.js_count = 0
        self.frames = 0
        self.subscribers = [session.declare_subscriber(f"{NS}/joint_states", self._on_js),
                            session.declare_subscriber(CAMERA_KEY, self._on_frame)]

    def _on_js(self, sample: Any) -> None:
        if sample.attachment is None:
            return
        now = time.monotonic()
        with self.lock:
            self.max_silence = max(self.max_silence, now - self.last_js)
            self.last_js = now
            self.js_count += 1

    def _on_frame(self, sample: Any) -> None:
        if sample.attachment is not None:
            with self.lock:
                self.frames += 1

    def restart(self) -> None:
        with self.lock:
            self.last_js, self.max_silence = time.monotonic(), 0.0

    def rate(self, seconds: float = 2.0) -> tuple[float, float]:
        """(joint_states Hz, camera frames a second) over the next ``seconds``."""
        with self.lock:
            js, frames = self.js_count, self.frames
        time.sleep(seconds)
        with self.lock:
            return (self.js_count - js) / seconds, (self.frames - frames) / seconds


def call(session: Any, key: str, request: dict, timeout: float) -> tuple[str, str]:
    """('ok' | 'error' | 'none', the reply's text)."""
    for reply in session.get(key, payload=msgpack.packb(request, use_bin_type=True), timeout=timeout):
        if reply.ok is not None:
            data = msgpack.unpackb(reply.ok.payload.to_bytes())
            return ("ok" if data.get("success", True) else "declined"), str(data.get("status_message", ""))
        raw = reply.err.payload.to_bytes()
        try:
            return "error", str(msgpack.unpackb(raw)["error"])
        except Exception:  # noqa: BLE001 - not our {"error": ...} layout
            return "error", raw[:2000].decode(errors="replace")
    return "none", ""


def judge(session: Any, case: Case, timeout: float) -> Outcome:
    started = time.monotonic()
    got, text = call(session, case.key, case.request, timeout)
    seconds = round(time.monotonic() - started, 3)
    if got == "none":
        return Outcome(case.name, "no reply", seconds)
    if got == "ok":
        return Outcome(case.name, "accepted", seconds, text)
    if not re.search(case.reason, text, re.IGNORECASE):
        return Outcome(case.name, "refused without its reason", seconds, text)
    return Outcome(case.name, "refused well", seconds, text)


def fold_piles(cases: list[Case], outcomes: list[Outcome]) -> list[Outcome]:
    """One outcome per pile: refused well when a refusal with its reason came, and nothing was left unanswered
    or refused without a reason (the ones taken before the cap was reached are fine)."""
    out: list[Outcome] = []
    piles: dict[str, list[Outcome]] = {}
    for case, outcome in zip(cases, outcomes, strict=False):
        if not case.pile:
            out.append(outcome)
            continue
        if case.pile not in piles:
            piles[case.pile] = []
            out.append(Outcome(case.pile, "", 0.0))
        piles[case.pile].append(outcome)
    for outcome in out:
        if outcome.name not in piles:
            continue
        items = piles[outcome.name]
        taken = sum(o.verdict == "accepted" for o in items)
        refusals = [o for o in items if o.verdict == "refused well"]
        bad = [o for o in items if o.verdict in ("no reply", "refused without its reason")]
        outcome.seconds = max(o.seconds for o in items)
        if bad:
            outcome.verdict, outcome.text = bad[0].verdict, f"{bad[0].name}: {bad[0].text}"
        elif not refusals:
            outcome.verdict, outcome.text = "accepted", f"all {taken} taken"
        else:
            outcome.verdict = "refused well"
            outcome.text = f"{taken} taken, {len(refusals)} refused: {refusals[0].text}"
    return out


def health(job: Launch, session: Any, watch: Watch, started_before: int) -> list[str]:
    """What the job lost: a process ended or restarted, a service silent, joint_states stopped, the camera
    blind."""
    lost = []
    if job.proc.poll() is not None:
        return [f"the launch ended (status {job.proc.returncode})"]
    restarts = len(re.findall(r"started '[^']+' \[pid \d+\]", job.output())) - started_before
    if restarts:
        lost.append(f"{restarts} node(s) restarted: " + ", ".join(re.findall(r"respawning '([^']+)'",
                                                                             job.output())[-3:]))
    for key in ("sim/get_physics_properties", f"{NS}/controller_manager/list_controllers"):
        if call(session, key, {}, 5.0)[0] == "none":
            lost.append(f"{key} does not answer")
    if watch.max_silence > SILENCE_LIMIT_S:
        lost.append(f"joint_states silent for {watch.max_silence:.1f} s")
    js_hz, camera_hz = watch.rate(3.0)
    if camera_hz == 0:
        lost.append(f"{CAMERA_KEY} stopped (renderer blinded)")
    if js_hz == 0:
        lost.append("joint_states stopped")
    return lost


def cleanup(session: Any, cases: list[Case], outcomes: list[Outcome]) -> None:
    """Undo what was accepted: spawned entities deleted, held pushes cleared."""
    for case, outcome in zip(cases, outcomes, strict=True):
        if outcome.verdict == "accepted" and case.entity:
            call(session, "sim/delete_entity", {"name": case.entity}, 10.0)
    links = {c.request["link_name"] for c in cases if c.key == "sim/apply_link_wrench"
             and isinstance(c.request.get("link_name"), str) and len(c.request["link_name"]) < 200}
    for link in links:
        call(session, "sim/clear_link_wrenches", {"link_name": link}, 5.0)
    for joint in {c.request["joint_name"] for c in cases if c.key == "sim/apply_joint_effort"}:
        call(session, "sim/clear_joint_efforts", {"joint_name": joint}, 5.0)


def start_job(log_dir: Path, models: Path) -> tuple[Launch, Any, Watch]:
    job = Launch("humanoid.yaml", "commander:=none", "mode:=realtime", log_dir=log_dir,
                 env=child_env({"ZENROID_MODEL_PATH": str(models)}))
    session = job.peer(60.0)
    watch = Watch(session)
    job.wait(lambda: "controller manager ready" in job.output() and watch.js_count > 100, 90.0, "the main job")
    job.wait(lambda: watch.frames > 0, 60.0, "the head camera streaming")
    return job, session, watch


def world_fan_out(log_dir: Path, models: Path) -> ClassReport:
    """An include fan-out as ``world:=``: the launch must end with status 1 at once, naming the limit."""
    report = ClassReport("fan-out (world:=)")
    world = log_dir / "fan.world"
    world.write_text("<?xml version='1.0'?><sdf version='1.7'><world name='fan'><include><uri>model://fan1</uri>"
                     "</include></world></sdf>")
    started = time.monotonic()
    job = Launch("humanoid.yaml", "commander:=none", f"world:={world}", log_dir=log_dir / "world",
                 env=child_env({"ZENROID_MODEL_PATH": str(models)}))
    try:
        job.proc.wait(timeout=90)
    except Exception:  # noqa: BLE001 - still running: reported below
        pass
    seconds = round(time.monotonic() - started, 1)
    status = job.proc.poll()
    text = job.output()
    found = re.search(r"more than \d+ (links|models)[^\n]*", text)
    verdict = ("refused well" if status == 1 and found else
               "no reply" if status is None else "refused without its reason")
    report.outcomes.append(Outcome("world:= include fan-out, 10^7 links", verdict, seconds,
                                   found.group(0) if found else text[-300:]))
    report.figures["launch_seconds_to_exit"] = seconds
    job.close()
    return report


def run_classes(classes: list[str], log_dir: Path, progress: Callable[[str], None] = print,
                timeout: float = 30.0) -> list[ClassReport]:
    models = model_folders(log_dir / "models")
    reports: list[ClassReport] = []
    job = session = watch = None
    try:
        for number, name in enumerate(classes):
            if job is None:
                job, session, watch = start_job(log_dir / f"job{number}", models)
            progress(f"fuzz class {name}...")
            report = ClassReport(name)
            cases = MAKERS[name]()
            started_before = len(re.findall(r"started '[^']+' \[pid \d+\]", job.output()))
            if name == "accumulation":
                report.figures["joint_states_hz_before"], _ = (round(v) for v in watch.rate(2.0))
            watch.restart()
            for case in cases:
                report.outcomes.append(judge(session, case, timeout))
                if report.outcomes[-1].verdict == "no reply" and job.proc.poll() is not None:
                    break
            if name == "accumulation":
                report.figures["joint_states_hz_at_the_caps"], _ = (round(v) for v in watch.rate(2.0))
            report.health = health(job, session, watch, started_before)
            cleanup(session, cases[:len(report.outcomes)], report.outcomes)
            report.outcomes = fold_piles(cases, report.outcomes)
            reports.append(report)
            progress(f"  {report.refused_well}/{len(report.outcomes)} refused well, {len(report.broke)} broke")
            if report.health:
                job.close()
                job = None
            if name == "fan-out":
                reports.append(world_fan_out(log_dir, models))
    finally:
        if job is not None:
            job.close()
    return reports


def summary(reports: list[ClassReport]) -> dict[str, Any]:
    return {r.name: {"cases": len(r.outcomes), "refused_well": r.refused_well, "broke": r.broke,
                     "slowest_reply_s": max((o.seconds for o in r.outcomes), default=0.0), **r.figures}
            for r in reports}


def table(reports: list[ClassReport]) -> str:
    lines = [f"{'class':<22}{'cases':>7}{'refused well':>14}{'broke':>7}  slowest reply",
             *(f"{r.name:<22}{len(r.outcomes):>7}{r.refused_well:>14}{len(r.broke):>7}  "
               f"{max((o.seconds for o in r.outcomes), default=0.0):.2f} s" for r in reports)]
    for r in reports:
        for key, value in r.figures.items():
            lines.append(f"  {r.name}: {key.replace('_', ' ')} {value}")
        for line in r.broke[:12]:
            lines.append(f"  {r.name}: {line}")
        if len(r.broke) > 12:
            lines.append(f"  {r.name}: ... and {len(r.broke) - 12} more")
    return "\n".join(lines)
