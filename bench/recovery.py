"""Recovery after ``kill -9``: how long until ``humanoid/joint_states`` flow again, and until the killed
node is back on the graph, for each node type of the main job while the robot follows the joint
commander's trajectories; and, last, how long the launcher's children outlive a ``kill -9`` of the
launcher itself.

    python bench/recovery.py [--runs 3] [--mode realtime] [--nodes controller_manager,simulator,...,launcher]

Each run starts ``python -m launch humanoid.yaml gui:=false`` on a free port and, once joint_states flow,
kills each node in turn (``kill -9`` of the process), waiting for the job to settle in between. Measured
per kill: "joint_states again" = from the kill to the end of the outage it caused (0 when joint_states
never stopped: only the controller manager and the simulator produce them), the longest silence of
joint_states in the window after the kill (hiccups while a respawned process starts on a shared machine),
the time until the node's liveliness token is back, and the lowest pelvis height seen (standing is
~0.91 m: the robot never falls). Prints a table, then (last line) JSON with the medians and every
sample. Goal: joint_states flowing again < 2 s after a kill of anything but the simulator.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from urllib.parse import unquote

import msgpack
import psutil
import zenoh

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.common import Launch  # noqa: E402 - after the path is set (bench scripts run from anywhere)

NODES = ["controller_manager", "robot_state_publisher", "joint_commander", "simulator", "launcher"]
GAP_S = 0.1  # joint_states arrive every 10 ms (JSB at 100 Hz): a silence longer than this is an outage
OUTAGE_START_S = 0.2  # an outage caused by the kill starts within this long after it


class MainJob(Launch):
    """The launched main job plus a plain Zenoh peer that timestamps joint_states, model_states, tokens."""

    def __init__(self, mode: str, log_dir: Path) -> None:
        super().__init__("humanoid.yaml", f"mode:={mode}", log_dir=log_dir)
        self.lock = threading.Lock()
        self.joint_states: list[float] = []
        self.pelvis: list[tuple[float, float]] = []
        self.tokens: dict[str, list[tuple[float, bool]]] = {}

    def connect(self, timeout: float = 30.0) -> None:
        session = self.peer(timeout)
        session.declare_subscriber("humanoid/joint_states", self._on_joint_states)
        session.declare_subscriber("sim/model_states", self._on_model_states)
        session.liveliness().declare_subscriber("@graph/node/**", self._on_token, history=True)

    def _on_joint_states(self, _sample: zenoh.Sample) -> None:
        with self.lock:
            self.joint_states.append(time.monotonic())

    def _on_model_states(self, sample: zenoh.Sample) -> None:
        msg = msgpack.unpackb(sample.payload.to_bytes())
        if "humanoid" in msg["name"]:
            z = msg["pose"][msg["name"].index("humanoid")]["position"]["z"]
            with self.lock:
                self.pelvis.append((time.monotonic(), z))

    def _on_token(self, sample: zenoh.Sample) -> None:
        name = unquote(str(sample.key_expr).rsplit("/", 1)[-1]).rsplit("/", 1)[-1]
        with self.lock:
            self.tokens.setdefault(name, []).append((time.monotonic(), sample.kind == zenoh.SampleKind.PUT))

    def pid_of(self, node: str) -> int:
        found = re.findall(rf"started '{node}' \[pid (\d+)\]", self.output())
        if not found:
            raise RuntimeError(f"no pid for '{node}' in the launch output")
        return int(found[-1])

    def flowing(self, since: float, count: int = 20) -> bool:
        with self.lock:
            return sum(1 for t in self.joint_states if t > since) >= count


def kill_and_measure(job: MainJob, node: str, window_s: float) -> dict[str, float | None]:
    """kill -9 ``node``; measure the joint_states outage, its return to the graph, the lowest pelvis."""
    pid = job.pid_of(node)
    restarts_before = job.output().count(f"started '{node}'")
    killed = time.monotonic()
    os.kill(pid, signal.SIGKILL)
    job.wait(lambda: job.output().count(f"started '{node}'") > restarts_before, 30, f"'{node}' respawned")

    def back() -> bool:
        with job.lock:
            return any(up and t > killed for t, up in job.tokens.get(node, []))

    job.wait(back, 30, f"'{node}' back on the graph")
    job.wait(lambda: job.flowing(killed, 50), 30, "joint_states flowing again")
    time.sleep(max(0.0, killed + window_s - time.monotonic()))
    with job.lock:
        stamps = [t for t in job.joint_states if t >= killed - 0.5]
        token_back = min(t for t, up in job.tokens[node] if up and t > killed)
        pelvis = [z for t, z in job.pelvis if t >= killed]
    # The outage the kill caused: a silence that began when the node died (messages already in flight
    # may still land just after the kill). Also the longest silence anywhere in the window (hiccups while
    # the respawned process starts on a shared machine).
    again, longest, previous = 0.0, 0.0, None
    for t in stamps:
        if previous is not None:
            silence = t - previous
            longest = max(longest, silence) if t > killed else longest
            if silence > GAP_S and killed - GAP_S <= previous <= killed + OUTAGE_START_S and not again:
                again = t - killed
        previous = t
    return {"joint_states_s": again, "longest_silence_s": longest,
            "back_on_graph_s": token_back - killed,
            "min_pelvis_z": min(pelvis) if pelvis else None}


def kill_launcher(job: MainJob) -> float:
    """kill -9 of the launcher itself: seconds until every process it started is gone (its watchdog)."""
    children = psutil.Process(job.proc.pid).children(recursive=True)
    killed = time.monotonic()
    os.kill(job.proc.pid, signal.SIGKILL)
    job.proc.wait()
    while True:
        alive = [c for c in children if c.is_running() and c.status() != psutil.STATUS_ZOMBIE]
        if not alive or time.monotonic() - killed > 30:
            return time.monotonic() - killed if not alive else float("inf")
        time.sleep(0.01)


def one_run(mode: str, nodes: list[str], window_s: float, settle_s: float) -> dict[str, dict]:
    with tempfile.TemporaryDirectory(prefix="zenroid-recovery-") as tmp:
        job = MainJob(mode, Path(tmp))
        try:
            job.connect()
            job.wait(lambda: job.flowing(0.0, 100), 60, "first joint_states")
            time.sleep(settle_s)
            results = {}
            for node in nodes:
                if node == "launcher":
                    results[node] = {"children_gone_s": kill_launcher(job)}
                    continue
                results[node] = kill_and_measure(job, node, window_s)
                time.sleep(settle_s)
            return results
        finally:
            job.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--mode", default="realtime", choices=["realtime", "lockstep"])
    parser.add_argument("--nodes", default=",".join(NODES), help="comma-separated node names to kill, in order")
    parser.add_argument("--window", type=float, default=8.0, help="seconds observed after each kill")
    parser.add_argument("--settle", type=float, default=3.0, help="seconds between kills")
    args = parser.parse_args()
    nodes = [n for n in args.nodes.split(",") if n]
    samples: dict[str, list[dict]] = {n: [] for n in nodes}
    for run in range(args.runs):
        results = one_run(args.mode, nodes, args.window, args.settle)
        for node, values in results.items():
            samples[node].append(values)
        print(f"run {run + 1}/{args.runs}: " + ", ".join(
            f"{n} again {v['joint_states_s']:.2f} s (silence {v['longest_silence_s']:.2f} s), back "
            f"{v['back_on_graph_s']:.2f} s" if n != "launcher" else f"launcher: children gone {v['children_gone_s']:.2f} s"
            for n, v in results.items()), flush=True)

    def med(node: str, key: str) -> float:
        return statistics.median(s[key] for s in samples[node])

    print(f"\nkill -9 while following trajectories ({args.mode}, {args.runs} runs, medians; load "
          f"{os.getloadavg()[0]:.1f})")
    print(f"{'node':24} {'joint_states again (s)':>23} {'max (s)':>8} {'longest silence (s)':>20} "
          f"{'back on graph (s)':>18} {'lowest pelvis z (m)':>20}")
    summary = {}
    for node in nodes:
        if node == "launcher":
            gone = [s["children_gone_s"] for s in samples[node]]
            summary[node] = {"children_gone_s": statistics.median(gone), "children_gone_max_s": max(gone)}
            continue
        lowest = min((s["min_pelvis_z"] for s in samples[node] if s["min_pelvis_z"] is not None), default=float("nan"))
        worst = max(s["joint_states_s"] for s in samples[node])
        summary[node] = {"joint_states_s": med(node, "joint_states_s"), "joint_states_max_s": worst,
                         "longest_silence_s": med(node, "longest_silence_s"),
                         "back_on_graph_s": med(node, "back_on_graph_s"), "min_pelvis_z": lowest}
        print(f"{node:24} {summary[node]['joint_states_s']:23.2f} {worst:8.2f} "
              f"{summary[node]['longest_silence_s']:20.2f} {summary[node]['back_on_graph_s']:18.2f} {lowest:20.3f}")
    if "launcher" in summary:
        print(f"kill -9 of the launcher: every child gone after {summary['launcher']['children_gone_s']:.2f} s "
              f"(max {summary['launcher']['children_gone_max_s']:.2f} s)")
    print(json.dumps({"bench": "recovery", "mode": args.mode, "runs": args.runs, "median": summary,
                      "samples": samples}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
