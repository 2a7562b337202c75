"""Soak: the main job for N minutes with its joint commander and a 100 Hz outside subscriber; lost messages,
RSS and CPU drift per process.

    python bench/soak.py [--minutes 5] [--mode realtime] [--sample 10] [--sensors]
    python bench/soak.py --churn [--rounds 3] [--pairs 200] [--names unique|reused]

Starts ``python -m launch humanoid.yaml gui:=false`` (the joint commander bends the knees every 2 s) on a free
port and, in a separate process, an outside subscriber written with zenoh + msgpack alone: it takes
``humanoid/joint_states`` (1 kHz), ``sim/clock`` and the JTC's ``controller_state`` in callbacks and works
through them in a loop that wakes 100 times a second (a GUI's or a logger's pace), counting every message
and the gaps in each publisher's sequence numbers (the zenroid attachment), i.e. messages lost on the way.
Every ``--sample`` s the RSS and CPU time of each process of the job are sampled; drift compares the first
minute after a 30 s warm-up with the last minute. Also reported: the robot stays standing, the knees keep
bending. ``--sensors``: the subscriber also takes the renderer's streams (camera rgb and depth, lidar, scan), so
the renderer draws them for the whole soak, and each one's delivered rate in the first and the last minute
is reported; it passes with every process's RSS drift within 1 MB/min and every rate steady (the last minute
within 10 % of the first). Prints a table, then a JSON line.

``--churn``: spawn/delete churn instead. After a warm-up of 20 pairs, each round spawns and deletes ``--pairs``
entities one after the other (each reply awaited), then as many again sent without waiting for any reply
(URDF robots and SDF models alternately, each with a name of its own). After each round (the job settled) the
RSS of the simulator, the renderer, the state publisher and the controller manager (and of the launcher, whose
embedded router sees every key) is sampled; it passes when each of the four ends within 10 MB of where it
started. The warm-up also spawns a model with an OBJ mesh, so the mesh readers the simulator and the renderer
import in the background at start-up are loaded before the first sample. ``--names reused``: each round
spawns the same names (what is left then is not per distinct name: not Zenoh's state of distinct keys).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import struct
import subprocess
import sys
import tempfile
import time
from collections import deque
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.common import spawn, stop  # noqa: E402 - after the path is set
from bench.fuzz import Job, rss_mb  # noqa: E402

SUBSCRIBED = ["humanoid/joint_states", "sim/clock", "humanoid/joint_trajectory_controller/controller_state"]
RENDERED = ["humanoid/camera/rgb", "humanoid/camera/depth", "humanoid/lidar/points", "humanoid/scan"]
MAX_DRIFT_MB_PER_MIN = 1.0
WARMUP_S = 30.0
_ATTACHMENT = struct.Struct("<Q16s")   # zenroid publishers: sequence number, source id


# ---------------------------------------------------------------------------------------------- subscriber
def subscriber(port: int, seconds: float, keys: list[str]) -> None:
    """The outside subscriber (its own process): prints one JSON line with what it received and lost (and
    when, in the first and the last minute, for the rendered streams)."""
    import msgpack
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", json.dumps("client"))
    config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    inbox: deque = deque()
    stats = {key: {"received": 0, "lost": 0, "out_of_order": 0, "sources": 0} for key in keys}
    arrivals: dict[str, list[float]] = {key: [] for key in keys if key in RENDERED}
    last_seq: dict[tuple[str, bytes], int] = {}
    knee = {"bends": 0, "bent": False, "max_gap_s": 0.0, "last": None}
    with zenoh.open(config) as session:
        subs = [session.declare_subscriber(key, lambda s, key=key: inbox.append((key, time.monotonic(), s)))
                for key in keys]
        start = time.monotonic()
        end = start + seconds
        while time.monotonic() < end:
            tick = time.monotonic()
            while inbox:
                key, arrived, sample = inbox.popleft()
                entry = stats[key]
                entry["received"] += 1
                if key in arrivals:
                    arrivals[key].append(arrived - start)
                att = sample.attachment.to_bytes() if sample.attachment is not None else b""
                if len(att) == _ATTACHMENT.size:
                    seq, source = _ATTACHMENT.unpack(att)
                    previous = last_seq.get((key, source))
                    if previous is None:
                        entry["sources"] += 1
                    elif seq > previous + 1:
                        entry["lost"] += seq - previous - 1
                    elif seq <= previous:
                        entry["out_of_order"] += 1
                    last_seq[(key, source)] = max(seq, previous or 0)
                if key == "humanoid/joint_states":
                    msg = msgpack.unpackb(sample.payload.to_bytes())
                    q = msg["position"][msg["name"].index("left_knee")]
                    if not knee["bent"] and q > 0.3:
                        knee["bent"], knee["bends"] = True, knee["bends"] + 1
                    elif knee["bent"] and q < 0.1:
                        knee["bent"] = False
                    if knee["last"] is not None:
                        knee["max_gap_s"] = max(knee["max_gap_s"], arrived - knee["last"])
                    knee["last"] = arrived
            time.sleep(max(0.0, 0.01 - (time.monotonic() - tick)))   # a 100 Hz loop
        for sub in subs:
            sub.undeclare()
    minute = min(60.0, seconds / 3)
    rates = {key: {"first_hz": round(sum(1 for t in ts if WARMUP_S <= t < WARMUP_S + minute) / minute, 2),
                   "last_hz": round(sum(1 for t in ts if t >= seconds - minute) / minute, 2)}
             for key, ts in arrivals.items()}
    print(json.dumps({"seconds": seconds, "keys": stats, "knee_bends": knee["bends"], "rendered_rates": rates,
                      "max_joint_states_gap_s": round(knee["max_gap_s"], 3)}), flush=True)


# ---------------------------------------------------------------------------------------------- soak
def run(minutes: float, mode: str, sample_s: float, log_dir: Path, progress=print,  # noqa: ANN001
        sensors: bool = False) -> dict[str, Any]:
    job = Job(log_dir, mode, commander="joint_commander")
    report: dict[str, Any] = {"minutes": minutes, "mode": mode, "sensors": sensors}
    keys = SUBSCRIBED + (RENDERED if sensors else [])
    sub_proc = None
    try:
        job.start()
        duration = minutes * 60.0
        sub_proc = spawn([sys.executable, str(Path(__file__).resolve()), "--subscriber", str(job.port), str(duration),
                          ",".join(keys)], stdout=subprocess.PIPE, stderr=None, text=True)
        time.sleep(3.0)   # the spawners have activated the controllers and exit: only long-running processes
        processes = {n: p for n, p in job.processes().items() if not n.startswith("spawner")}
        started = job.started()
        samples: list[dict[str, Any]] = []
        t0 = time.monotonic()
        while time.monotonic() - t0 < duration:
            now = time.monotonic() - t0
            cpu = {}
            for name, proc in processes.items():
                try:
                    cpu[name] = sum(proc.cpu_times()[:2])
                except Exception:  # noqa: BLE001 - a process gone: reported below
                    cpu[name] = math.nan
            samples.append({"t": now, "rss": rss_mb(processes), "cpu": cpu})
            progress(f"soak: {now / 60:.1f} min, RSS {sum(samples[-1]['rss'].values()):.0f} MB")
            time.sleep(min(sample_s, max(0.1, duration - (time.monotonic() - t0))))
        samples.append({"t": time.monotonic() - t0, "rss": rss_mb(processes),
                        "cpu": {n: sum(p.cpu_times()[:2]) for n, p in processes.items() if p.is_running()}})
        out, _ = sub_proc.communicate(timeout=60)
        received = json.loads(out.strip().splitlines()[-1])
        report.update(summarise(samples, duration))
        report["subscriber"] = received
        report["lost_messages"] = sum(v["lost"] for v in received["keys"].values())
        total = sum(v["received"] + v["lost"] for v in received["keys"].values())
        # In realtime these streams are droppable by design (ros2_controllers' RealtimePublisher skips a message
        # it cannot hand over at once; the clock and the controller state never wait either): a slow reader or
        # a loaded machine loses some, never the physics its pace. Up to 1 % passes; lockstep loses none.
        report["lost_fraction"] = report["lost_messages"] / total if total else 1.0
        with job.lock:
            zs = [z for _, z in job.pelvis]
        report["lowest_pelvis_z"] = round(min(zs), 3) if zs else None
        restarted = {n: c - started.get(n, 0) for n, c in job.started().items() if c > started.get(n, 0)}
        report["restarted"] = restarted
        report["pass"] = (report["lost_fraction"] < 0.01 and not restarted and zs and min(zs) > 0.8
                          and received["knee_bends"] >= duration / 4 * 0.8)
        if sensors:   # issue 27: no process grows, no stream slows down
            drift_ok = all(p["rss_drift_mb_per_min"] <= MAX_DRIFT_MB_PER_MIN for p in report["processes"].values())
            steady = all(r["first_hz"] > 0 and r["last_hz"] >= 0.9 * r["first_hz"]
                         for r in received["rendered_rates"].values())
            report["rss_drift_ok"], report["rates_steady"] = drift_ok, steady
            report["pass"] = bool(report["pass"] and drift_ok and steady)
        return report
    finally:
        if sub_proc is not None:
            stop(sub_proc, 0, signal.SIGKILL)
        job.close()


CHURNED = ("simulator", "renderer", "robot_state_publisher", "controller_manager")
CHURN_LIMIT_MB = 10.0
CHURN_URDF = ("<?xml version='1.0'?><robot name='churn'><link name='base'><inertial><mass value='1'/>"
              "<inertia ixx='0.01' iyy='0.01' izz='0.01' ixy='0' ixz='0' iyz='0'/></inertial>"
              "<visual><geometry><box size='0.2 0.2 0.2'/></geometry></visual>"
              "<collision><geometry><box size='0.2 0.2 0.2'/></geometry></collision></link></robot>")
CHURN_SDF = ("<?xml version='1.0'?><sdf version='1.7'><model name='churn'><link name='l'><collision name='c'>"
             "<geometry><box><size>0.2 0.2 0.2</size></box></geometry></collision><visual name='v'><geometry>"
             "<sphere><radius>0.1</radius></sphere></geometry></visual></link></model></sdf>")


CHURN_MESH_SDF = ("<?xml version='1.0'?><sdf version='1.7'><model name='churn_mesh'><link name='l'><visual name='v'>"
                  "<geometry><mesh><uri>model://churn_mesh/meshes/cube.obj</uri></mesh></geometry></visual>"
                  "</link></model></sdf>")
CUBE_OBJ = "".join(f"v {x} {y} {z}\n" for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)) + (
    "f 1 2 4 3\nf 5 7 8 6\nf 1 5 6 2\nf 3 4 8 7\nf 1 3 7 5\nf 2 6 8 4\n")


def churn_mesh_model_path(log_dir: Path) -> str:
    """A model folder with a text mesh (OBJ): spawned once in the warm-up, so the mesh readers that the
    simulator and the renderer import in the background at start-up are loaded before the first sample."""
    meshes = log_dir / "models" / "churn_mesh" / "meshes"
    meshes.mkdir(parents=True, exist_ok=True)
    (meshes / "cube.obj").write_text(CUBE_OBJ)
    (meshes.parent / "model.sdf").write_text(CHURN_MESH_SDF)   # what makes the folder a model of the path
    return str(log_dir / "models")


def churn_request(index: int, reuse: int = 0) -> tuple[str, dict[str, Any]]:
    """The ``index``-th spawn request; ``reuse``: names repeat every ``reuse`` requests (0: never)."""
    name = f"churn_{index % reuse if reuse else index}"
    return name, {"name": name, "xml": CHURN_URDF if index % 2 == 0 else CHURN_SDF,
                  "initial_pose": {"position": {"x": 3.0 + (index % 10) * 0.5, "y": 3.0, "z": 0.2},
                                   "orientation": {"w": 1.0}}}


def churn_round(job: Job, first: int, pairs: int, reuse: int = 0) -> int:
    """``pairs`` spawn/delete pairs awaited one by one, then ``pairs`` sent without waiting; the next index."""
    index = first
    for _ in range(pairs):
        name, request = churn_request(index, reuse)
        index += 1
        reply = job.call("sim/spawn_entity", request, timeout=30)
        if not reply.get("success"):
            raise RuntimeError(f"spawn {name}: {reply.get('status_message')}")
        job.call("sim/delete_entity", {"name": name}, timeout=30)
    import msgpack

    pending = []
    for _ in range(pairs):   # fire and forget: the replies are collected (and dropped) by Zenoh
        name, request = churn_request(index, reuse)
        index += 1
        pending.append(job.session.get("sim/spawn_entity", payload=msgpack.packb(request), timeout=120))
        pending.append(job.session.get("sim/delete_entity", payload=msgpack.packb({"name": name}), timeout=120))
    for replies in pending:   # every request served (or timed out) before the round ends
        for _ in replies:
            pass
    # zenoh-python delivers each queryable's queries on a thread of its own: a delete sent right after its
    # spawn may be served first (as two services of a ROS 2 node are not ordered either). What it left is
    # deleted now, awaited, so that each round ends with the world it started with.
    left = [m for m in job.call("sim/get_model_list", {}).get("model_names", []) if m.startswith("churn_")]
    for name in left:
        job.call("sim/delete_entity", {"name": name}, timeout=30)
    job.overtaken = getattr(job, "overtaken", 0) + len(left)
    return index


def run_churn(rounds: int, pairs: int, log_dir: Path, progress=print,  # noqa: ANN001
              names: str = "unique") -> dict[str, Any]:
    """``names``: "unique" (every spawn a name of its own) or "reused" (each round the same 2 x ``pairs``
    names: what is left then is not per distinct name, i.e. not the Zenoh state of distinct keys)."""
    model_path = os.pathsep.join(p for p in (churn_mesh_model_path(log_dir), os.environ.get("ZENROID_MODEL_PATH"))
                                 if p)
    saved = os.environ.get("ZENROID_MODEL_PATH")
    os.environ["ZENROID_MODEL_PATH"] = model_path   # the job's processes inherit it
    try:
        job = Job(log_dir, "realtime", commander="none")
    finally:
        if saved is None:
            os.environ.pop("ZENROID_MODEL_PATH")
        else:
            os.environ["ZENROID_MODEL_PATH"] = saved
    reuse = 2 * pairs if names == "reused" else 0
    report: dict[str, Any] = {"rounds": rounds, "pairs": pairs, "names": names}
    try:
        job.start()
        processes = {n: p for n, p in job.processes().items() if n in CHURNED or n == "launch"}
        started = job.started()
        # warm-up: lazily imported code (the mesh readers too), first-use caches, the allocator
        reply = job.call("sim/spawn_entity", {"name": "churn_mesh", "xml": CHURN_MESH_SDF}, timeout=120)
        if not reply.get("success"):
            raise RuntimeError(f"spawn churn_mesh: {reply.get('status_message')}")
        job.call("sim/delete_entity", {"name": "churn_mesh"}, timeout=30)
        index = churn_round(job, 0, 10)
        if reuse:
            index = reuse   # the rounds' names start over (the warm-up's are among them)

        def settled() -> dict[str, float]:
            time.sleep(5.0)
            return {n: round(v, 1) for n, v in rss_mb(processes).items()}

        rss = [settled()]
        progress(f"churn: warmed up, RSS {rss[-1]}")
        for number in range(1, rounds + 1):
            t0 = time.monotonic()
            index = churn_round(job, index, pairs, reuse)
            rss.append(settled())
            progress(f"churn: round {number} in {time.monotonic() - t0:.0f} s, RSS {rss[-1]}")
        models = job.call("sim/get_model_list", {}).get("model_names", [])
        growth = {n: round(rss[-1][n] - rss[0][n], 1) for n in rss[0]}
        restarted = {n: c - started.get(n, 0) for n, c in job.started().items() if c > started.get(n, 0)}
        report.update(rss_per_round=rss, growth_mb=growth, leftover_models=[m for m in models if "churn" in m],
                      restarted=restarted, deletes_before_their_spawn=getattr(job, "overtaken", 0))
        report["pass"] = bool(all(abs(g) <= CHURN_LIMIT_MB for n, g in growth.items() if n in CHURNED)
                              and not restarted
                              and not report["leftover_models"])
    finally:
        job.close()
    report["longest_silence_s"] = longest_silences(job.output())
    return report


def longest_silences(launch_output: str) -> dict[str, float]:
    """The launcher's closing figure: each node's longest time without answering its health probe."""
    import re

    line = next((ln for ln in launch_output.splitlines() if "health: longest time without an answer:" in ln), "")
    return {name: float(value) for name, value in re.findall(r"(\w+) (\d+(?:\.\d+)?) s", line.split(":", 3)[-1])}


def churn_table(report: dict[str, Any]) -> str:
    rounds = report["rss_per_round"]
    lines = [f"{'process':<24}{'start MB':>10}" + "".join(f"{f'round {i}':>10}" for i in range(1, len(rounds)))
             + f"{'growth MB':>11}"]
    for name in rounds[0]:
        label = "launcher (router)" if name == "launch" else name
        lines.append(f"{label:<24}" + "".join(f"{r[name]:>10.1f}" for r in rounds) + f"{report['growth_mb'][name]:>11.1f}")
    lines.append(f"{report['pairs']} awaited + {report['pairs']} unawaited spawn/delete pairs a round; leftover models "
                 f"{report['leftover_models'] or 'none'}, restarts {report['restarted'] or 'none'}; deletes served "
                 f"before their spawn (then deleted again) {report['deletes_before_their_spawn']}")
    lines.append("longest time without answering the launcher's health probe: " + ", ".join(
        f"{name} {value:.1f} s" for name, value in report.get("longest_silence_s", {}).items()))
    return "\n".join(lines)


def summarise(samples: list[dict[str, Any]], duration: float) -> dict[str, Any]:
    """Drift per process: the first minute after the warm-up against the last minute."""
    warm = [s for s in samples if s["t"] >= min(WARMUP_S, duration / 3)]
    window = min(60.0, (warm[-1]["t"] - warm[0]["t"]) / 3) if len(warm) > 1 else 0.0
    first = [s for s in warm if s["t"] <= warm[0]["t"] + window]
    last = [s for s in warm if s["t"] >= warm[-1]["t"] - window]
    span_min = max(1e-9, (last[-1]["t"] - first[0]["t"]) / 60.0)
    per_process = {}
    for name in samples[0]["rss"]:
        rss_first = sum(s["rss"][name] for s in first) / len(first)
        rss_last = sum(s["rss"][name] for s in last) / len(last)

        def cpu_percent(group: list[dict[str, Any]], name: str = name) -> float:
            dt = group[-1]["t"] - group[0]["t"]
            return 100.0 * (group[-1]["cpu"].get(name, math.nan) - group[0]["cpu"][name]) / dt if dt > 0 else math.nan

        per_process[name] = {
            "rss_first_mb": round(rss_first, 1), "rss_last_mb": round(rss_last, 1),
            "rss_drift_mb_per_min": round((rss_last - rss_first) / span_min, 3),
            "rss_drift_pct": round(100.0 * (rss_last / rss_first - 1.0), 2),
            "cpu_first_pct": round(cpu_percent(first), 1), "cpu_last_pct": round(cpu_percent(last), 1),
        }
    return {"processes": per_process, "samples": len(samples), "drift_window_s": round(window, 1)}


def table(report: dict[str, Any]) -> str:
    lines = [f"{'process':<24}{'RSS first MB':>13}{'last MB':>9}{'drift MB/min':>14}{'drift %':>9}"
             f"{'CPU% first':>11}{'last':>7}"]
    for name, p in report["processes"].items():
        lines.append(f"{name:<24}{p['rss_first_mb']:>13.1f}{p['rss_last_mb']:>9.1f}{p['rss_drift_mb_per_min']:>14.3f}"
                     f"{p['rss_drift_pct']:>8.2f}%{p['cpu_first_pct']:>11.1f}{p['cpu_last_pct']:>7.1f}")
    lines.append("")
    lines.append(f"{'outside subscriber (100 Hz loop)':<56}{'received':>10}{'lost':>7}{'out of order':>14}")
    for key, v in report["subscriber"]["keys"].items():
        lines.append(f"{key:<56}{v['received']:>10}{v['lost']:>7}{v['out_of_order']:>14}")
    for key, rate in report["subscriber"].get("rendered_rates", {}).items():
        lines.append(f"{key:<56}{'first minute':>14} {rate['first_hz']:>6.1f} Hz, last {rate['last_hz']:>6.1f} Hz")
    lines.append("")
    lines.append(f"knee bends seen {report['subscriber']['knee_bends']}, longest joint_states gap "
                 f"{report['subscriber']['max_joint_states_gap_s']} s, lowest pelvis z {report['lowest_pelvis_z']} m, "
                 f"restarts {report['restarted'] or 'none'}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=5.0, help="how long (default 5)")
    parser.add_argument("--mode", default="realtime", choices=["realtime", "lockstep"])
    parser.add_argument("--sample", type=float, default=10.0, help="s between RSS/CPU samples (default 10)")
    parser.add_argument("--sensors", action="store_true",
                        help="also take the camera, lidar and laser streams (the renderer draws them all along)")
    parser.add_argument("--churn", action="store_true", help="spawn/delete churn rounds instead of a soak")
    parser.add_argument("--rounds", type=int, default=3, help="--churn: rounds (default 3)")
    parser.add_argument("--pairs", type=int, default=200,
                        help="--churn: awaited pairs a round, and as many unawaited (default 200)")
    parser.add_argument("--names", default="unique", choices=["unique", "reused"],
                        help="--churn: a name of its own for every spawn (default), or the same ones each round")
    parser.add_argument("--subscriber", nargs=3, metavar=("PORT", "SECONDS", "KEYS"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.subscriber:
        subscriber(int(args.subscriber[0]), float(args.subscriber[1]), args.subscriber[2].split(","))
        return 0
    if args.churn:
        with tempfile.TemporaryDirectory(prefix="zenroid-churn-") as tmp:
            report = run_churn(args.rounds, args.pairs, Path(tmp),
                               progress=lambda s: print(s, file=sys.stderr, flush=True), names=args.names)
        print(churn_table(report))
        print(json.dumps(report, default=str))
        return 0 if report.get("pass") else 1
    with tempfile.TemporaryDirectory(prefix="zenroid-soak-") as tmp:
        report = run(args.minutes, args.mode, args.sample, Path(tmp),
                     progress=lambda s: print(s, file=sys.stderr, flush=True), sensors=args.sensors)
    print(table(report))
    print(json.dumps(report, default=str))
    return 0 if report.get("pass") else 1


if __name__ == "__main__":
    sys.exit(main())
