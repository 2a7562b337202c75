"""Rendered sensors on 2 CPU cores: the main job in realtime with its camera, lidar and laser on, the viewer off.

    python bench/sensors.py [--runs 3] [--seconds 20] [--camera 320x240 --camera 640x480 ...] [--lockstep-seconds 8]

Each run starts ``python -m launch humanoid.yaml gui:=false mode:=realtime`` (the joint commander bends the knees
every 2 s) with the shipped humanoid, or with a copy whose head camera has another resolution (``--camera
WxH``, repeatable: the curve), and an outside subscriber (its own process, zenoh + msgpack only) takes every
rendered stream (camera rgb, depth, points; lidar; scan) and ``sim/clock`` for ``--seconds`` after a warm-up.
It reports, per camera resolution (medians over the runs):

- each sensor's delivered rate: messages per wall second, and per simulated second against its configured
  rate (``*_of_rate``: 1.0 means every frame the sensor was due for arrived);
- the real-time factor from ``sim/clock`` (simulated seconds per wall second);
- (the subscriber reads each message's header alone, so its own decoding does not throttle what it counts;
  ``--points`` adds the depth camera's 2.4 MB PointCloud2, which the renderer builds only when subscribed);
- each process's CPU (percent of one core).

Then the lockstep speed with the sensors on against off, in the same run (``sensors:=true|false``, the same
outside subscriber, so the renderer draws everything in the on runs): simulated seconds per wall second.

Goals (issue 27): the defaults (camera 320x240 RGB-D at 30 Hz, lidar 16x900 at 10 Hz, laser 720 at 20 Hz)
hold real time: RTF >= 0.95 with every sensor >= 95 % of its rate. Prints a table, then one JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import Launch, print_table, spawn, stop  # noqa: E402 - after the path is set
from bench.lockstep import cpu_percent_between, process_tree_cpu  # noqa: E402

STREAMS = {   # key -> configured rate (Hz) of the shipped humanoid (robots/build_robots.py)
    "humanoid/camera/rgb": 30.0, "humanoid/camera/depth": 30.0, "humanoid/camera/camera_info": 30.0,
    "humanoid/lidar/points": 10.0, "humanoid/scan": 20.0,
}
CAMERA_CLOUD = {"humanoid/camera/points": 30.0}   # --points: the depth camera's organised cloud too (2.4 MB each)

# The outside subscriber: its own process, nothing of this project imported. It counts messages and their
# stamps per key over a window that starts after the warm-up, and sim/clock at both ends of the window.
SUBSCRIBER = r"""
import json, sys, time, threading
import msgpack, zenoh
endpoint, warmup, seconds = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
keys = json.loads(sys.argv[4])
conf = zenoh.Config()
conf.insert_json5("mode", '"client"')
conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
conf.insert_json5("scouting/multicast/enabled", "false")
lock = threading.Lock()
counts = {k: 0 for k in keys}
stamps = {k: [] for k in keys}
clock = {"t": None}
measuring = {"on": False}
def stamp_of(payload):
    # the header is the first field of every sensor message: read it alone, not the megabytes after it
    unpacker = msgpack.Unpacker()
    unpacker.feed(payload[:4096])
    unpacker.read_map_header()
    while unpacker.unpack() != "header":
        unpacker.skip()
    s = unpacker.unpack()["stamp"]
    return s["sec"] + s["nanosec"] * 1e-9
def on(key):
    def callback(sample):
        if not measuring["on"]:
            return
        t = stamp_of(sample.payload.to_bytes())
        with lock:
            counts[key] += 1
            stamps[key].append(t)
    return callback
def on_clock(sample):
    c = msgpack.unpackb(sample.payload.to_bytes())["clock"]
    clock["t"] = c["sec"] + c["nanosec"] * 1e-9
with zenoh.open(conf) as session:
    subs = [session.declare_subscriber(k, on(k)) for k in keys]
    subs.append(session.declare_subscriber("sim/clock", on_clock))
    print("subscribed", flush=True)
    while clock["t"] is None or clock["t"] < warmup:
        time.sleep(0.05)
    sim0, wall0 = clock["t"], time.perf_counter()
    measuring["on"] = True
    time.sleep(seconds)
    measuring["on"] = False
    sim1, wall1 = clock["t"], time.perf_counter()
    for s in subs:
        s.undeclare()
with lock:
    out = {"wall_seconds": wall1 - wall0, "sim_seconds": sim1 - sim0,
           "streams": {k: {"count": counts[k], "sim_span": (max(stamps[k]) - min(stamps[k])) if len(stamps[k]) > 1 else 0.0}
                       for k in keys}}
print(json.dumps(out), flush=True)
"""


def camera_variant(width: int, height: int, directory: Path) -> Path:
    """The shipped humanoid with its head camera at ``width`` x ``height`` (everything else as shipped)."""
    xml = (ROOT / "robots" / "humanoid.urdf").read_text()
    shipped = "<width>320</width><height>240</height>"
    assert shipped in xml, "the shipped camera's resolution changed: update bench/sensors.py"
    path = directory / f"humanoid_{width}x{height}.urdf"
    path.write_text(xml.replace(shipped, f"<width>{width}</width><height>{height}</height>", 1))
    return path


def measure(launch_args: list[str], seconds: float, warmup: float, keys: list[str]) -> dict:
    """One main job with the outside subscriber: its report, plus CPU per process over the window."""
    log_dir = Path(tempfile.mkdtemp(prefix="bench-sensors-"))
    launch = Launch("humanoid.yaml", *launch_args, log_dir=log_dir)
    try:
        launch.wait_output(Launch.ROUTER_UP, 60)
        subscriber = spawn([sys.executable, "-c", SUBSCRIBER, launch.endpoint, str(warmup), str(seconds),
                            json.dumps(keys)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        assert subscriber.stdout is not None
        line = subscriber.stdout.readline().decode()
        if "subscribed" not in line:
            raise RuntimeError(f"the subscriber failed: {line}{subscriber.stdout.read().decode()}")
        # CPU over (about) the measuring window: from the end of the warm-up, in wall time
        launch.wait_match(r"Configured and activated joint_trajectory_controller", 120)
        time.sleep(max(0.0, warmup / 2))
        before, started = process_tree_cpu(launch.proc.pid), time.perf_counter()
        output, _ = subscriber.communicate(timeout=seconds + warmup + 180)
        after, wall = process_tree_cpu(launch.proc.pid), time.perf_counter() - started
        stop(subscriber)
        report = json.loads(output.decode().strip().splitlines()[-1])
        report["cpu_percent"] = cpu_percent_between(before, after, wall)
        return report
    finally:
        launch.close()


def rates(report: dict, configured: dict[str, float]) -> dict[str, dict[str, float]]:
    out = {}
    for key, stream in report["streams"].items():
        per_wall = stream["count"] / report["wall_seconds"]
        per_sim = stream["count"] / report["sim_seconds"] if report["sim_seconds"] > 0 else 0.0
        out[key] = {"hz": round(per_wall, 2), "of_rate": round(per_sim / configured[key], 3)}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=20.0, help="measured window (wall s)")
    parser.add_argument("--warmup", type=float, default=8.0, help="sim s before the window starts")
    parser.add_argument("--camera", action="append", default=[], help="WxH of the head camera (repeatable)")
    parser.add_argument("--lockstep-seconds", type=float, default=8.0, help="0: no lockstep comparison")
    parser.add_argument("--points", action="store_true",
                        help="also subscribe the depth camera's PointCloud2 (the renderer then builds it too)")
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0]
    cameras = args.camera or ["320x240"]
    streams = {**STREAMS, **(CAMERA_CLOUD if args.points else {})}
    keys = list(streams)
    variants = Path(tempfile.mkdtemp(prefix="bench-sensors-robots-"))
    results: dict[str, list[dict]] = {camera: [] for camera in cameras}
    lockstep: dict[str, list[float]] = {"on": [], "off": []}
    for run in range(args.runs):
        for camera in cameras:   # interleaved: the machine's noise hits every resolution alike
            width, height = (int(v) for v in re.fullmatch(r"(\d+)x(\d+)", camera).groups())
            robot = ["robot_file:=" + str(camera_variant(width, height, variants))] if camera != "320x240" else []
            report = measure(["mode:=realtime", *robot], args.seconds, args.warmup, keys)
            report["rates"] = rates(report, streams)
            report["rtf"] = report["sim_seconds"] / report["wall_seconds"]
            results[camera].append(report)
            print(f"run {run + 1} {camera}: rtf {report['rtf']:.3f}, "
                  + ", ".join(f"{k.split('/', 1)[1]} {v['hz']} Hz ({v['of_rate']:.0%})"
                              for k, v in report["rates"].items()), file=sys.stderr, flush=True)
        if args.lockstep_seconds > 0:
            for sensors in ("on", "off"):
                report = measure(["mode:=lockstep", f"sensors:={'true' if sensors == 'on' else 'false'}"],
                                 args.lockstep_seconds, 2.0, keys)
                lockstep[sensors].append(report["sim_seconds"] / report["wall_seconds"])
                print(f"run {run + 1} lockstep sensors {sensors}: {lockstep[sensors][-1]:.2f} x real time",
                      file=sys.stderr, flush=True)

    summary: dict = {"runs": args.runs, "seconds": args.seconds, "points": args.points, "cameras": {}}
    rows = []
    for camera, reports in results.items():
        rtf = statistics.median(r["rtf"] for r in reports)
        per_key = {key: {"hz": statistics.median(r["rates"][key]["hz"] for r in reports),
                         "of_rate": statistics.median(r["rates"][key]["of_rate"] for r in reports)} for key in keys}
        cpu: dict[str, float] = {}
        for label in reports[0]["cpu_percent"]:
            cpu[label] = statistics.median(r["cpu_percent"].get(label, 0.0) for r in reports)
        holds = rtf >= 0.95 and all(v["hz"] >= 0.95 * streams[k] for k, v in per_key.items())
        summary["cameras"][camera] = {"rtf": round(rtf, 3), "streams": per_key, "cpu_percent": cpu,
                                      "holds_real_time": holds}
        rows.append((f"camera {camera}: real-time factor", f"{rtf:.3f}", "sim s per wall s from sim/clock (>= 0.95)"))
        for key, value in per_key.items():
            rows.append((f"  {key}", f"{value['hz']:.1f} Hz", f"{value['of_rate']:.0%} of its {streams[key]:g} Hz per "
                         "sim s"))
        rows.append(("  CPU (% of a core)", "", ", ".join(f"{k} {v:.0f}" for k, v in sorted(cpu.items()))))
        rows.append(("  holds real time", "yes" if holds else "no", "RTF >= 0.95, every stream >= 95 % of its rate"))
    held = [c for c in cameras if summary["cameras"][c]["holds_real_time"]]
    summary["largest_camera_holding_real_time"] = max(held, key=lambda c: pixels(c)) if held else None
    if lockstep["on"]:
        on, off = statistics.median(lockstep["on"]), statistics.median(lockstep["off"])
        summary["lockstep_x_real_time"] = {"sensors_on": round(on, 2), "sensors_off": round(off, 2),
                                           "ratio": round(on / off, 3)}
        rows.append(("lockstep, sensors on / off", f"{on:.2f} / {off:.2f}", f"x real time; ratio {on / off:.3f}"))
    print_table(rows, load_before)
    print(json.dumps(summary))
    return 0


def pixels(camera: str) -> int:
    width, height = (int(v) for v in camera.split("x"))
    return width * height


if __name__ == "__main__":
    sys.exit(main())
