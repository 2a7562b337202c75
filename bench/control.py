"""Controller manager benchmark.

1. Update cost: the manager's cycle (every active controller's ``update`` + collecting the hardware
   command) with joint_state_broadcaster + joint_trajectory_controller on the humanoid's 22 joints, the JTC
   following a trajectory and the broadcaster publishing on a real Zenoh session. Budget at 1 kHz: 1000 µs.
   Reported as thread CPU time (the work itself; on a shared 2-core machine wall-clock percentiles mostly
   measure preemption by other processes), with the wall-clock figures alongside.
2. Command latency (realtime mode, three processes): a JointTrajectory published by this process to the
   first ``hardware/command`` from the controller manager process that carries it; and, of it, the wait
   from the publish to the next ``hardware/state`` seen by this process (about when the manager's next
   cycle starts: on average half a control period, as in ros2_control); from that state to the command,
   for the trajectories taken by that cycle; and how many arrived too late for it (taken one period later).
3. The baseline of a hop, in the same conditions (simulator and manager still running, a message every
   ~30 ms): a raw zenoh-python put -> callback in another process, with the stamp in the payload.

``--composed``: 2. and 3. with the simulator and the controller manager composed in one container process
(``python -m nodes.core.container``, as ``humanoid.yaml composed:=true``): the hardware frames go between them
in-process; the trajectory still comes over Zenoh from this process, and the command still comes back to it
over Zenoh (a hop the simulator itself no longer pays).

Prints a small table, then one JSON line: update_p99_us, command_latency_p50_us, command_latency_p99_us,
wait_for_state_p50_us, state_to_command_p50_us, taken_a_period_later, raw_hop_p50_us, composed.
    python bench/control.py [--cycles 5000] [--samples 200] [--sensors on|off|both] [--composed]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import msgpack  # noqa: E402
import numpy as np  # noqa: E402

import msgs  # noqa: E402
from bench.common import child_env, free_port, spawn, stop_all  # noqa: E402
from nodes.control.config import load_config_file  # noqa: E402
from nodes.control.interfaces import HardwareInterfaces, JointInfo, SensorInfo  # noqa: E402
from nodes.control.manager import STRICT, ControllerManager  # noqa: E402
from nodes.control.node import NodeControllerContext  # noqa: E402
from nodes.core import Node  # noqa: E402
from nodes.core.delivery import Inline, Raw  # noqa: E402
from nodes.core.session import loopback_endpoint, open_peer, open_router  # noqa: E402
from nodes.urdf.sensors import FORCE_TORQUE_INTERFACES, IMU_INTERFACES  # noqa: E402

JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")


def pct(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q)) if values else float("nan")


class _ContextHost:
    """Just enough of ControllerManagerNode for NodeControllerContext: a node and the control time."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.control_time = 0.0
        self.logger = node.logger
        self.deferred_publications = None   # controllers publish at once (no hardware cycle to follow)
        self.cycle_thread = None
        self.realtime_hardware = True

    def __getattr__(self, name: str):
        return getattr(self.node, name)


SENSOR_BROADCASTERS = ["imu_sensor_broadcaster", "left_foot_ft_broadcaster", "right_foot_ft_broadcaster"]
# the humanoid's sensors (robots/humanoid.urdf) and a standing robot's readings
SENSORS = [SensorInfo("imu_sensor", "imu", "pelvis", list(IMU_INTERFACES)),
           SensorInfo("left_foot_ft", "force_torque", "left_foot", list(FORCE_TORQUE_INTERFACES)),
           SensorInfo("right_foot_ft", "force_torque", "right_foot", list(FORCE_TORQUE_INTERFACES))]
SENSOR_VALUES = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 9.81] + [0.0, 0.0, 269.8, 0.0, 0.0, 0.0] * 2


def controllers(sensors: bool) -> list[str]:
    return ["joint_state_broadcaster", "joint_trajectory_controller", *(SENSOR_BROADCASTERS if sensors else [])]


def bench_update(endpoint: str, cycles: int, sensors: bool = True) -> dict[str, float]:
    config = load_config_file(ROOT / "config" / "controllers.yaml")
    joints = config.controllers["joint_trajectory_controller"].params["joints"]
    hw = HardwareInterfaces([JointInfo(j, ["position"]) for j in joints], SENSORS if sensors else [])
    sensor_values = SENSOR_VALUES if sensors else []
    node = Node("bench_control_manager", namespace="bench", connect=[endpoint], log_level="warn")
    host = _ContextHost(node)
    manager = ControllerManager(hw, config, 1000, lambda name: NodeControllerContext(host, name), node.logger)
    for name in controllers(sensors):
        manager.load(name)
        manager.configure(name)
    ok, message = manager.switch(controllers(sensors), [], STRICT)
    assert ok, message
    jtc = manager.controllers["joint_trajectory_controller"].controller
    positions = [0.0] * len(joints)
    zeros = [0.0] * len(joints)
    t, dt = 0.0, 0.001
    samples: list[float] = []
    cpu_samples: list[float] = []
    try:
        for i in range(cycles):
            if i % 2000 == 0:  # a fresh 2 s trajectory with 4 points on every joint
                jtc._on_trajectory_msg(msgs.from_dict(JointTrajectory, {"joint_names": joints, "points": [
                    {"positions": [0.1 * k * ((i // 2000) % 2 * 2 - 1)] * len(joints),
                     "time_from_start": {"sec": 0, "nanosec": 500_000_000 * k}} for k in range(1, 5)]}))
            hw.read_state(joints, positions, zeros, zeros, sensor_values)
            host.control_time = t
            started = time.perf_counter()
            cpu_started = time.thread_time_ns()
            manager.update(t, dt)
            manager.command()
            cpu_samples.append((time.thread_time_ns() - cpu_started) / 1e3)
            samples.append((time.perf_counter() - started) * 1e6)
            time.sleep(0.0002)  # leave the Zenoh threads their share, as a real 1 kHz loop would
            t += dt
    finally:
        node.destroy()
    inactive = [n for n, e in manager.controllers.items() if e.state != "active"]
    if inactive:
        raise RuntimeError(f"controllers deactivated during the measurement: {inactive} (see the log above)")
    warm = samples[len(samples) // 10:]
    cpu = cpu_samples[len(cpu_samples) // 10:]
    return {"p50": pct(cpu, 50), "p99": pct(cpu, 99), "wall_p50": pct(warm, 50), "wall_p99": pct(warm, 99),
            "n": len(warm)}


LATE_US = 800.0   # state -> command beyond this: the trajectory was taken a cycle later (periods are 1 ms)


def bench_latency(endpoint: str, port: int, samples: int, sensors: bool = True,
                  composed: bool = False) -> dict[str, float]:
    env = child_env({"ZENOH_CONNECT": endpoint})
    simulator = ["--params-file", "config/sim.yaml", "--param", "mode:=realtime", "--param",
                 "entities:=[{name: humanoid, file: humanoid, z: 0.93}]", "--param",
                 f"sensors:={'true' if sensors else 'false'}"]
    manager = ["--ns", "humanoid", "--params-file", "config/controllers.yaml", "--param",
               f"activate:=[{', '.join(controllers(sensors))}]"]
    if composed:   # one process: the simulator's loop on its main thread, the manager beside it
        procs = [spawn([sys.executable, "-m", "nodes.core.container", "--name", "simulation",
                        "--composable", json.dumps({"plugin": "nodes.sim.node::SimulatorNode", "argv": simulator}),
                        "--composable", json.dumps({"plugin": "nodes.control.node::ControllerManagerNode",
                                                    "argv": manager})],
                       env=env, stderr=subprocess.DEVNULL)]
    else:
        procs = [spawn([sys.executable, "-m", "nodes.sim", *simulator], env=env, stderr=subprocess.DEVNULL),
                 spawn([sys.executable, "-m", "nodes.control", *manager], env=env, stderr=subprocess.DEVNULL)]
    node = Node("bench_control_client", connect=[endpoint], log_level="warn")
    lock = threading.Lock()
    pending: dict[str, float] = {}  # target -> publish time
    latencies: list[float] = []
    waits: list[float] = []   # publish -> the next hardware/state seen here (the manager's next cycle starts then)
    state_arrivals: list[float] = []
    after_state: list[float] = []   # that state -> the command carrying the trajectory
    commands = [0]

    def on_command(payload: bytes) -> None:
        received = time.perf_counter()
        frame = msgpack.unpackb(payload)
        commands[0] += 1
        with lock:
            if not pending:
                return
            target, sent = next(iter(pending.items()))
            for name, value in zip(frame["name"], frame["value"], strict=True):
                if name == "neck_pitch" and abs(value - float(target)) < 1e-9:
                    latencies.append((received - sent) * 1e6)
                    later = [t for t in state_arrivals[-100:] if t > sent]
                    if later:
                        waits.append((later[0] - sent) * 1e6)
                        after_state.append((received - later[0]) * 1e6)
                    pending.clear()
                    return

    def on_state(_payload: bytes) -> None:
        state_arrivals.append(time.perf_counter())
        if len(state_arrivals) > 1000:
            del state_arrivals[:500]

    try:
        node.create_subscription(None, "/humanoid/hardware/command", on_command,
                                 delivery=Inline(), message=Raw())
        node.create_subscription(None, "/humanoid/hardware/state", on_state, delivery=Inline(), message=Raw())
        pub = node.create_publisher(JointTrajectory, "/humanoid/joint_trajectory_controller/joint_trajectory",
                                    express=True)
        deadline = time.monotonic() + 120
        while commands[0] < 2000 and time.monotonic() < deadline:
            time.sleep(0.1)
        if commands[0] < 2000:
            raise RuntimeError("the simulator and controller manager did not start within 120 s")
        stats = node.create_client(msgs.get_type("std_srvs/srv/Trigger"), "/humanoid/controller_manager/statistics")
        for i in range(samples):
            target = f"{0.1 + 0.0001 * i:.4f}"  # a distinct neck position per sample
            msg = msgs.from_dict(JointTrajectory, {"joint_names": ["neck_pitch"], "points": [
                {"positions": [float(target)], "time_from_start": {"sec": 0, "nanosec": 0}}]})
            with lock:
                pending.clear()
                pending[target] = time.perf_counter()
            pub.publish(msg)
            time.sleep(0.03 + 0.01 * (i % 3) / 3)  # not phase-locked to the 1 kHz cycle
        time.sleep(0.2)
        manager_stats = json.loads(stats.call(timeout=5.0).message)
        hop = raw_hop(endpoint, samples)
    finally:
        node.destroy()
        stop_all(procs, timeout=10)
    return {"p50": pct(latencies, 50), "p99": pct(latencies, 99), "n": len(latencies), "sent": samples,
            "wait_p50": pct(waits, 50), "wait_p99": pct(waits, 99),
            # more than ~a period after that state: the trajectory missed that cycle and was taken by the next
            "next_cycle": [a for a in after_state if a < LATE_US], "late": sum(a >= LATE_US for a in after_state),
            "cycle_p50": manager_stats["cycle_p50_us"], "cycle_p99": manager_stats["cycle_p99_us"],
            "hop_p50": pct(hop, 50), "hop_p99": pct(hop, 99), "hop_n": len(hop)}


HOP_KEY = "bench/control/hop"


def raw_hop_child(endpoint: str, count: int) -> None:
    """The receiving end of ``raw_hop``: prints each one-way delay (µs) as a JSON list once ``count`` have
    arrived, or the sender has been silent for a second (a few early ones lost while the route formed)."""
    session = open_peer([endpoint])
    delays: list[float] = []
    last = [time.monotonic()]
    done = threading.Event()

    def on_sample(sample) -> None:
        delays.append((time.perf_counter_ns() - int.from_bytes(sample.payload.to_bytes()[:8], "little")) / 1e3)
        last[0] = time.monotonic()
        if len(delays) >= count:
            done.set()

    session.declare_subscriber(HOP_KEY, on_sample)
    ready = session.declare_publisher(HOP_KEY + "/ready")
    give_up = time.monotonic() + 90
    while not done.wait(0.2) and time.monotonic() < give_up:
        if delays and time.monotonic() - last[0] > 1.0:
            break
        ready.put(b"1")
    print(json.dumps(delays), flush=True)
    os._exit(0)   # skip zenoh's slow session teardown


def raw_hop(endpoint: str, count: int) -> list[float]:
    """One-way raw zenoh-python hops (express put -> callback in another process) at the trajectories' pace."""
    session = open_peer([endpoint])
    ready = threading.Event()
    child = subprocess.Popen([sys.executable, __file__, "--raw-hop-child", endpoint, str(count)],
                             stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        session.declare_subscriber(HOP_KEY + "/ready", lambda _sample: ready.set())
        if not ready.wait(60):
            raise RuntimeError("the raw hop's receiving process did not start within 60 s")
        publisher = session.declare_publisher(HOP_KEY, express=True)
        padding = bytes(120)   # about a one-point JointTrajectory's size
        for i in range(count + 20):   # a few spare: the receiver stops at `count`
            if child.poll() is not None:
                break
            publisher.put(time.perf_counter_ns().to_bytes(8, "little") + padding)
            time.sleep(0.03 + 0.01 * (i % 3) / 3)
        return json.loads(child.communicate(timeout=30)[0])[:count]
    finally:
        if child.poll() is None:
            child.kill()
        session.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=5000)
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--sensors", choices=("on", "off", "both"), default="on",
                        help="the humanoid's IMU and F/T sensors with their three broadcasters; both: off, then on")
    parser.add_argument("--composed", action="store_true",
                        help="the simulator and the controller manager in one container process")
    args = parser.parse_args()
    if args.sensors == "both":
        figures = {state: measure(state == "on", args) for state in ("off", "on")}
        print(json.dumps({f"{key}_sensors_{state}": value for state, row in figures.items()
                          for key, value in row.items()}))
        return 0
    measure(args.sensors == "on", args)
    return 0


def measure(sensors: bool, args: argparse.Namespace) -> dict[str, float]:
    """One measurement (update cost, then latency) with the sensors on or off; prints its table and JSON."""
    port = free_port()
    router = open_router(port)
    try:
        endpoint = loopback_endpoint(port)
        update = bench_update(endpoint, args.cycles, sensors)
        latency = bench_latency(endpoint, port, args.samples, sensors, args.composed)
    finally:
        router.close()
    print(f"sensors {'on' if sensors else 'off'}, simulator and controller manager "
          f"{'composed in one process' if args.composed else 'in separate processes'}")
    rows = [
        ("manager update (JSB + JTC, 22 joints), thread CPU time", update["p50"], update["p99"],
         "1000 budget, goal p99 < 200"),
        ("manager update, wall clock (includes preemption)", update["wall_p50"], update["wall_p99"], ""),
        ("manager cycle in the process (decode+update+publish)", latency["cycle_p50"], latency["cycle_p99"], ""),
        (f"JointTrajectory -> hardware/command ({latency['n']}/{latency['sent']})", latency["p50"], latency["p99"],
         "goal p50 < 1000, p99 < 3000"),
        ("  of it: publish -> the next hardware/state seen here", latency["wait_p50"], latency["wait_p99"],
         "the manager's next cycle; ~half a period"),
        ("  then: that state -> the command (taken by that cycle)", pct(latency["next_cycle"], 50),
         pct(latency["next_cycle"], 99), "the manager's cycle + one hop"),
        (f"  taken a period later: {latency['late']}/{latency['n']}", math.nan, math.nan,
         "reached the manager after that cycle had started"),
        (f"raw zenoh hop, same conditions ({latency['hop_n']})", latency["hop_p50"], latency["hop_p99"],
         "put -> callback in another process, the baseline"),
    ]
    print(f"{'measurement':<58} {'p50 µs':>9} {'p99 µs':>9}  note")
    for label, p50, p99, note in rows:
        figures = f"{p50:>9.1f} {p99:>9.1f}" if p50 == p50 else " " * 19
        print(f"{label:<58} {figures}  {note}")
    figures = {"update_p99_us": round(update["p99"], 1), "update_p50_us": round(update["p50"], 1),
                 "update_wall_p99_us": round(update["wall_p99"], 1),
                 "cycle_p99_us": round(latency["cycle_p99"], 1),
                 "command_latency_p50_us": round(latency["p50"], 1),
                 "command_latency_p99_us": round(latency["p99"], 1),
                 "wait_for_state_p50_us": round(latency["wait_p50"], 1),
                 "state_to_command_p50_us": round(pct(latency["next_cycle"], 50), 1),
                 "taken_a_period_later": round(latency["late"] / max(latency["n"], 1), 3),
                 "raw_hop_p50_us": round(latency["hop_p50"], 1), "composed": args.composed}
    print(json.dumps(figures))
    return figures


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--raw-hop-child":
        raw_hop_child(sys.argv[2], int(sys.argv[3]))
    sys.exit(main())
