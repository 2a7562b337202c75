"""Simulator throughput and pacing.

(a) in-process DART stepping of the humanoid with the joint servo and ground contacts (the ceiling);
(b) the simulator process in lockstep with a minimal hardware client process at a 1 kHz control rate;
(c) realtime mode for 30 s: achieved real-time factor and p99 lateness of control periods.

    python bench/sim.py [--lockstep-seconds 10] [--realtime-seconds 30]

Prints a table, then one JSON line (last).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import child_env, free_port, loopback, print_table, spawn, stop  # noqa: E402 - after the path set-up
from nodes.core.delivery import Inline  # noqa: E402

HUMANOID_ENTITY = "entities:=[{name: humanoid, file: humanoid, z: 0.915}]"


def inprocess_steps_per_s(steps: int = 5000) -> tuple[float, float]:
    """(steps per wall second, steps per CPU second): the second is what the machine's load cannot skew."""
    from nodes.sim.config import parse_gains
    from nodes.sim.entity import EntitySpec, Pose
    from nodes.sim.simulation import Simulation
    from nodes.sim.world import PhysicsWorld

    world = PhysicsWorld(1000.0)
    world.add_ground()
    sim = Simulation(world, parse_gains({"*": {"p": 2000.0, "d": 20.0}}))
    sim.spawn(EntitySpec("humanoid", (ROOT / "robots" / "humanoid.urdf").read_text(),
                         pose=Pose.from_xyz_rpy(0, 0, 0.915)))
    # keep the world awake and in contact: a small knee motion, as a controller would command
    hw = sim.hardware["humanoid"]
    sim.step(500)
    start, cpu = time.perf_counter(), time.process_time()
    for k in range(steps):
        hw.apply_command(["left_knee", "right_knee"], ["position", "position"], [0.1 * (k % 2000) / 2000] * 2)
        sim.step(1)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    sim.clear()
    return steps / elapsed, steps / cpu


class SimRun:
    """A router in this process, the simulator process and the minimal hardware client process."""

    def __init__(self, *params: str) -> None:
        from nodes.core import Node
        from nodes.core.session import open_router

        self.port = free_port()
        self.router = open_router(self.port)
        env = child_env({"ZENOH_CONNECT": loopback(self.port)})
        argv = [sys.executable, "-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml")]
        for param in (HUMANOID_ENTITY, *params):
            argv += ["--param", param]
        self.sim = spawn(argv, env=env)
        self.client = spawn([sys.executable, "-m", "tests.support.hardware_client"], env=env)
        self.node = Node("bench_sim", connect=[loopback(self.port)], log_level="error")
        self.diagnostics: list[dict] = []
        self._lock = threading.Lock()
        from nodes.sim.interfaces import String

        self.node.create_subscription(String, "/sim/diagnostics", self._on_diag, delivery=Inline())

    def _on_diag(self, msg) -> None:
        with self._lock:
            self.diagnostics.append(json.loads(msg.data))

    def props(self):
        from nodes.sim.interfaces import GetPhysicsProperties

        return self.node.create_client(GetPhysicsProperties, "/sim/get_physics_properties").call(timeout=5.0)

    def wait_commanded(self, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self._lock:
                if self.diagnostics and self.diagnostics[-1]["robots"].get("humanoid") == "commanded":
                    return
            time.sleep(0.1)
        raise RuntimeError("the hardware client never took over the humanoid")

    def cpu_seconds(self) -> tuple[float, float]:
        """CPU time used so far by (simulator, hardware client)."""
        import psutil

        def used(proc: subprocess.Popen) -> float:
            times = psutil.Process(proc.pid).cpu_times()
            return times.user + times.system

        return used(self.sim), used(self.client)

    def window(self, seconds: float) -> tuple[float, float, float, list[dict]]:
        """(sim time advanced, steps, wall seconds, diagnostics) over ``seconds`` of wall time."""
        before = self.props()
        cpu_before = self.cpu_seconds()
        with self._lock:
            self.diagnostics.clear()
        start = time.perf_counter()
        time.sleep(seconds)
        after = self.props()
        wall = time.perf_counter() - start
        cpu_after = self.cpu_seconds()
        self.cpu_per_step_us = tuple((a - b) / max(1, after.step - before.step) * 1e6
                                     for a, b in zip(cpu_after, cpu_before, strict=True))
        with self._lock:
            diagnostics = list(self.diagnostics)
        return after.sim_time - before.sim_time, after.step - before.step, wall, diagnostics

    def close(self) -> None:
        self.node.destroy()
        for proc in (self.client, self.sim):
            stop(proc, 10, signal.SIGTERM)
        self.router.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--lockstep-seconds", type=float, default=10.0)
    parser.add_argument("--realtime-seconds", type=float, default=30.0)
    args = parser.parse_args(argv)

    load_before = os.getloadavg()[0]
    inprocess, inprocess_cpu = inprocess_steps_per_s()

    run = SimRun("mode:=lockstep")
    try:
        run.wait_commanded()
        _, lockstep_steps, lockstep_wall, _ = run.window(args.lockstep_seconds)
        sim_cpu_us, client_cpu_us = run.cpu_per_step_us
    finally:
        run.close()
    lockstep = lockstep_steps / lockstep_wall

    run = SimRun("mode:=realtime")
    try:
        run.wait_commanded()
        sim_advanced, _, realtime_wall, diagnostics = run.window(args.realtime_seconds)
    finally:
        run.close()
    rtf = sim_advanced / realtime_wall
    p99_windows = [d["p99_late_ms"] for d in diagnostics if d["mode"] == "realtime"]
    p99 = max(p99_windows) if p99_windows else float("nan")
    p99_median = statistics.median(p99_windows) if p99_windows else float("nan")
    worst = max((d["max_late_ms"] for d in diagnostics), default=float("nan"))

    rows = [
        ("(a) in-process DART humanoid, servo + contacts", f"{inprocess:,.0f} steps/s",
         f"the ceiling; {inprocess_cpu:,.0f} steps per CPU second"),
        ("(b) lockstep, sim + hardware client processes, 1 kHz", f"{lockstep:,.0f} steps/s",
         f"{lockstep / inprocess:.2f} of (a); {lockstep / 1000:.2f}x real time (goal >= 3000)"),
        ("(b) lockstep: CPU per step, simulator / client", f"{sim_cpu_us:.0f} / {client_cpu_us:.0f} us",
         "load-independent cost of one control period"),
        (f"(c) realtime {args.realtime_seconds:g} s: real-time factor", f"{rtf:.4f}", "goal 1.00 +- 1 %"),
        ("(c) realtime: p99 period lateness (worst 1-s window)", f"{p99:.3f} ms",
         f"median window {p99_median:.3f} ms, max single {worst:.2f} ms (goal p99 < 1 ms)"),
    ]
    print_table(rows, load_before)
    print(json.dumps({
        "inprocess_steps_per_s": round(inprocess, 1), "lockstep_steps_per_s": round(lockstep, 1),
        "lockstep_ratio": round(lockstep / inprocess, 4), "realtime_factor": round(rtf, 5),
        "realtime_p99_late_ms": round(p99, 4), "inprocess_steps_per_cpu_s": round(inprocess_cpu, 1),
        "lockstep_sim_cpu_us_per_step": round(sim_cpu_us, 1), "realtime_p99_late_ms_median_window": round(p99_median, 4),
        "load_average": round(load_before, 2),
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
