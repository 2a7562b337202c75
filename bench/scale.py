"""How lockstep scales with the number of robots, on this machine.

(a) one world, k = 1, 2, 4 humanoids: one simulator process with k entities, and per robot its own
    namespace (humanoid_0 ...) and controller manager running JSB + JTC on its 22 joints;
(b) k = 1, 2, 4 independent worlds side by side: k launches of the main job
    (``humanoid.yaml mode:=lockstep gui:=false``), each on its own Zenoh port.

Sim time is read from ``sim/clock`` by an outside process (zenoh + msgpack only). Reported per k: world
steps per wall second, robot-steps per second (steps x robots), CPU per robot (all processes' CPU / k),
and the cost per robot relative to k = 1 (1.0 = perfectly linear). Prints a table, then one JSON line.

    python bench/scale.py [--seconds 6] [--counts 1,2,4]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import Launch, child_env, free_port, loopback, spawn, stop_all  # noqa: E402 - after the path set-up
from bench.lockstep import (  # noqa: E402
    cpu_percent_between,
    finish_probe,
    process_tree_cpu,
    start_probe,
    wait_measuring,
)


def cpu_of(pids: list[int]) -> dict[int, tuple[str, float]]:
    """CPU seconds so far of every process under ``pids`` (see ``cores_used``)."""
    return {child: used for pid in pids for child, used in process_tree_cpu(pid).items()}


def cores_used(before: dict[int, tuple[str, float]], after: dict[int, tuple[str, float]], wall: float) -> float:
    """Cores used between two ``cpu_of`` snapshots, by the processes alive at both."""
    return sum(cpu_percent_between(before, after, wall).values()) / 100


def one_world(k: int, seconds: float) -> dict:
    """k humanoids in one simulator, each with its own controller manager (JSB + JTC autostarted)."""
    from nodes.core.session import open_router

    port = free_port()
    router = open_router(port)
    env = child_env({"ZENOH_CONNECT": loopback(port)})
    entities = ", ".join(f"{{name: humanoid_{i}, file: humanoid, namespace: humanoid_{i}, y: {2.0 * i}, z: 0.93}}"
                         for i in range(k))
    procs = [spawn([sys.executable, "-m", "nodes.sim", "--param", "mode:=lockstep", "--param",
                    f"entities:=[{entities}]"], env=env, stderr=subprocess.DEVNULL)]
    for i in range(k):
        procs.append(spawn([sys.executable, "-m", "nodes.control", "--ns", f"humanoid_{i}", "--params-file",
                            str(ROOT / "config" / "controllers.yaml"),
                            "--param", "activate:=[joint_state_broadcaster, joint_trajectory_controller]"],
                           env=env, stderr=subprocess.DEVNULL))
    try:
        # every JTC publishes its state once it runs: start measuring when the last one does
        probe = start_probe(port, seconds, f"humanoid_{k - 1}/joint_trajectory_controller/controller_state")
        wait_measuring(probe)
        cpu0, wall0 = cpu_of([p.pid for p in procs]), time.perf_counter()
        result = finish_probe(probe, seconds + 180)
        cpu = cores_used(cpu0, cpu_of([p.pid for p in procs]), time.perf_counter() - wall0)
    finally:
        stop_all(procs)
        router.close()
    steps = result["sim_seconds"] * 1000.0 / result["wall_seconds"]
    return {"k": k, "steps_per_s": steps, "robot_steps_per_s": steps * k, "cpu_cores": cpu,
            "cpu_per_robot": cpu / k, "pelvis_min": result["pelvis_min"]}


def side_by_side(k: int, seconds: float) -> dict:
    """k independent launches of the main job in lockstep."""
    ports = [free_port() for _ in range(k)]
    # exclusive_cpu:=false: each world's physics thread would want the same kept CPU
    procs = [Launch("humanoid.yaml", "mode:=lockstep", "exclusive_cpu:=false", port=port,
                    log_dir=Path(f"/tmp/bench-scale-{port}")).proc for port in ports]
    try:
        time.sleep(0.5)
        probes = [start_probe(port, seconds, "humanoid/joint_trajectory_controller/joint_trajectory")
                  for port in ports]
        for probe in probes:
            wait_measuring(probe)
        cpu0, wall0 = cpu_of([p.pid for p in procs]), time.perf_counter()
        results = [finish_probe(probe, seconds + 180) for probe in probes]
        cpu = cores_used(cpu0, cpu_of([p.pid for p in procs]), time.perf_counter() - wall0)
    finally:
        stop_all(procs)
    per_world = [r["sim_seconds"] * 1000.0 / r["wall_seconds"] for r in results]
    return {"k": k, "steps_per_s": sum(per_world) / k, "robot_steps_per_s": sum(per_world), "cpu_cores": cpu,
            "cpu_per_robot": cpu / k, "pelvis_min": min(r["pelvis_min"] for r in results)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=6.0)
    parser.add_argument("--counts", default="1,2,4")
    args = parser.parse_args(argv)
    counts = [int(c) for c in args.counts.split(",")]
    load = os.getloadavg()[0]
    rows = {"one_world": [], "side_by_side": []}
    for k in counts:
        rows["one_world"].append(one_world(k, args.seconds))
        print(f"one world, {k} robots: {rows['one_world'][-1]}", file=sys.stderr)
    for k in counts:
        rows["side_by_side"].append(side_by_side(k, args.seconds))
        print(f"{k} worlds side by side: {rows['side_by_side'][-1]}", file=sys.stderr)
    print(f"{'setup':<24}{'k':>3}{'world steps/s':>15}{'robot-steps/s':>15}{'CPU cores':>11}"
          f"{'CPU/robot':>11}{'cost/robot':>12}{'pelvis min':>12}")
    for setup, results in rows.items():
        base = results[0]["robot_steps_per_s"]
        for r in results:
            # wall time per robot-step relative to k = 1 (1.0: linear; above: the curve bends)
            r["cost_per_robot_vs_k1"] = base / r["robot_steps_per_s"]
            print(f"{setup:<24}{r['k']:>3}{r['steps_per_s']:>15,.0f}{r['robot_steps_per_s']:>15,.0f}"
                  f"{r['cpu_cores']:>11.2f}{r['cpu_per_robot']:>11.2f}{r['cost_per_robot_vs_k1']:>12.2f}"
                  f"{r['pelvis_min']:>12.3f}")
    print(f"load average before: {load:.1f}; {os.cpu_count()} cores")
    print(json.dumps({setup: [{k: round(v, 3) if isinstance(v, float) else v for k, v in r.items()} for r in results]
                      for setup, results in rows.items()} | {"load_average": round(load, 2)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
