"""The main job in lockstep against the in-process ceiling of the same robot, measured in the same run.

Each run:
  (a) in-process: the humanoid stepped by plain function calls in this process, through the simulator's
      own world code (floating base, ground contacts, joint springs; a slow squat commanded every step,
      as the controller manager does at 1 kHz): the ceiling of physics alone;
  (b) full stack: ``python -m launch humanoid.yaml mode:=lockstep gui:=false`` (simulator, controller
      manager with JSB + JTC on 22 joints, robot state publisher, joint commander) while a separate
      process that imports only zenoh and msgpack counts simulated time on ``sim/clock`` and watches the
      pelvis height on ``sim/model_states``.
  (a') plain dartpy: bench/sim_instructions.py's loop (a), the same humanoid, ground and gains stepped by
      dartpy alone (the squat as moving rest positions, none of this project's code): what the robot costs
      DART itself. (a) and (a') are measured before and after (b), alternating (a, a', b, a', a).
  (c) composed: (b) with ``composed:=true`` (the simulator and the controller manager in one container
      process, hardware frames handed over in-process), in every run beside (b), the two in alternating
      order; ``--composed off`` leaves it out.
``ratio`` = (b) / (a), ``ratio_to_plain`` = (b) / (a'), ``inprocess_to_plain`` = (a) / (a'),
``composed_ratio_to_plain`` = (c) / (a'). Prints a table,
then one JSON line with ``fullstack_steps_per_s``, ``inprocess_steps_per_s``, ``plain_steps_per_s`` and the
ratios (medians over the runs); each run also records what the launcher did with ``exclusive_cpu`` ("CPU 1",
"not reserved: why" when another lockstep launch holds the CPU, "off").

``--world NAME`` (repeatable) runs the full stack in each world in turn within every run (same ceiling, same
machine state), e.g. ``--world empty.world --world simple_lab.world``: the table and the JSON then add each
world's ratio, its load time (the simulator's ``loaded in`` line) and ``world_cost``, the last world's
full-stack rate against the first's.

    python bench/lockstep.py [--runs 3] [--seconds 8] [--physics-rate 1000] [--sensors on|off|both] [--world NAME ...]
                             [--composed on|off]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import Launch, free_port, loopback, print_table, spawn  # noqa: E402 - after the path is set

LEG_PITCH = {"hip_pitch": -0.5, "knee": 1.0, "ankle_pitch": -0.5}   # squat direction per unit depth

# The probe runs as its own process and imports nothing of this project (an outside client).
PROBE = r"""
import json, sys, time, threading
import msgpack, zenoh
endpoint, seconds, start_key = sys.argv[1], float(sys.argv[2]), sys.argv[3]
conf = zenoh.Config()
conf.insert_json5("mode", '"client"')
conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
conf.insert_json5("scouting/multicast/enabled", "false")
started = threading.Event()
clock = []            # (wall, sim)
pelvis = []
deadline = time.monotonic() + 60
while True:  # the launcher's router may not listen yet (a loaded machine starts it late)
    try:
        session = zenoh.open(conf)
        break
    except zenoh.ZError:
        if time.monotonic() > deadline:
            raise
        time.sleep(0.2)
with session as s:
    def on_clock(sample):
        c = msgpack.unpackb(sample.payload.to_bytes())["clock"]
        clock.append((time.perf_counter(), c["sec"] + c["nanosec"] * 1e-9))
    def on_models(sample):
        m = msgpack.unpackb(sample.payload.to_bytes())
        for name, pose in zip(m["name"], m["pose"]):
            if name.startswith("humanoid"):   # every robot: humanoid here, humanoid_0.. in bench/scale.py
                pelvis.append(pose["position"]["z"])
    def on_start(sample):
        started.set()
    subs = [s.declare_subscriber("sim/clock", on_clock), s.declare_subscriber("sim/model_states", on_models),
            s.declare_subscriber(start_key, on_start)]
    if not started.wait(120):
        print(json.dumps({"error": "the commander never sent a trajectory"})); sys.exit(1)
    time.sleep(1.0)                       # let the first command settle in
    clock.clear(); pelvis.clear()
    print(json.dumps({"measuring": True}), flush=True)
    time.sleep(seconds)
    for sub in subs:
        sub.undeclare()
    w0, t0 = clock[0]; w1, t1 = clock[-1]
    print(json.dumps({"sim_seconds": t1 - t0, "wall_seconds": w1 - w0, "clock_messages": len(clock),
                      "pelvis_min": min(pelvis), "pelvis_max": max(pelvis)}), flush=True)
"""


def start_probe(port: int, seconds: float, start_key: str) -> subprocess.Popen:
    """The outside probe on the router at ``port``; it measures from a second after ``start_key``."""
    return spawn([sys.executable, "-c", PROBE, loopback(port), str(seconds), start_key], stdout=subprocess.PIPE,
                 stderr=None, text=True, env=dict(os.environ, PYTHONPATH=""))


def wait_measuring(probe: subprocess.Popen) -> None:
    if not probe.stdout.readline():
        raise RuntimeError("probe ended before measuring")


def finish_probe(probe: subprocess.Popen, timeout: float) -> dict:
    """The probe's measurement (RuntimeError with its complaint if it has none)."""
    out, _ = probe.communicate(timeout=timeout)
    result = json.loads(out.strip().splitlines()[-1])
    if "error" in result:
        raise RuntimeError(result["error"])
    return result


def squat_targets(names: list[str], k: int, physics_rate: float) -> list[float]:
    """A slow squat (0.25 Hz, knees 0 .. 0.6 rad) for every joint in ``names`` (others held at zero)."""
    depth = 0.3 * (1.0 - math.cos(2 * math.pi * 0.25 * k / physics_rate))
    out = []
    for name in names:
        part = name.split("_", 1)[1] if name.startswith(("left_", "right_")) else ""
        out.append(LEG_PITCH.get(part, 0.0) * depth)
    return out


def inprocess_steps_per_s(steps: int, physics_rate: float) -> tuple[float, float]:
    """(steps per wall second, pelvis height at the end) for the humanoid stepped in this process."""
    from nodes.core.params import load_params_file
    from nodes.sim.config import DEFAULT_CONFIG, parse_gains
    from nodes.sim.entity import EntitySpec, Pose
    from nodes.sim.simulation import Simulation
    from nodes.sim.world import PhysicsWorld

    defaults = load_params_file(DEFAULT_CONFIG, "simulator")
    world = PhysicsWorld(physics_rate)
    world.add_ground()
    sim = Simulation(world, parse_gains(defaults["gains"]))
    entity = sim.spawn(EntitySpec("humanoid", (ROOT / "robots" / "humanoid.urdf").read_text(),
                                  pose=Pose.from_xyz_rpy(0, 0, 0.93)))
    hw = sim.hardware["humanoid"]
    names = list(hw.names)
    interfaces = ["position"] * len(names)
    for _ in range(300):                      # land on the ground first
        hw.apply_command(names, interfaces, squat_targets(names, 0, physics_rate))
        sim.step(1)
    start = time.perf_counter()
    for k in range(steps):
        hw.apply_command(names, interfaces, squat_targets(names, k, physics_rate))
        sim.step(1)
    elapsed = time.perf_counter() - start
    height = float(entity.world_pose().position[2])
    sim.clear()
    return steps / elapsed, height


def plain_steps_per_s(steps: int) -> float:
    """Steps per wall second of bench/sim_instructions.py's plain-dartpy loop (a'): the same humanoid squatting,
    none of this project's code (its squat assumes the default 1000 Hz physics rate)."""
    from bench.sim_instructions import PlainHumanoid, squat_depth

    plain = PlainHumanoid()
    plain.settle()
    depths = [squat_depth(k) for k in range(steps)]
    start = time.perf_counter()
    plain.squat(depths)
    return steps / (time.perf_counter() - start)


def ceilings(args: argparse.Namespace, after: bool = False) -> dict[str, float]:
    """(a) and (a') once each, in-process first (after the full stack: plain first, so the two bracket it
    alike); the in-process pelvis height at the end too."""
    out: dict[str, float] = {}
    for kind in (("plain", "inprocess") if after else ("inprocess", "plain")):
        if kind == "plain":
            out["plain"] = plain_steps_per_s(args.inprocess_steps)
        else:
            out["inprocess"], out["height"] = inprocess_steps_per_s(args.inprocess_steps, args.physics_rate)
    return out


def bracket(before: dict[str, float], after: dict[str, float]) -> tuple[float, float]:
    """The (a) and (a') ceilings of a run: the means of their measurements before and after the full stack."""
    return (statistics.mean([before["inprocess"], after["inprocess"]]),
            statistics.mean([before["plain"], after["plain"]]))


def process_tree_cpu(pid: int) -> dict[int, tuple[str, float]]:
    """CPU seconds used so far by each process under ``pid``: pid -> (its node name, seconds)."""
    import psutil

    out: dict[int, tuple[str, float]] = {}
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.Error:
        return out
    for proc in procs:
        try:
            cmd = proc.cmdline()
            times = proc.cpu_times()
        except psutil.Error:
            continue
        label = "launcher (+router)" if proc.pid == pid else _node_label(cmd)
        out[proc.pid] = (label, times.user + times.system)
    return out


def cpu_percent_between(before: dict[int, tuple[str, float]], after: dict[int, tuple[str, float]],
                        wall: float) -> dict[str, float]:
    """Percent of one core per node name, over the processes alive at both snapshots (a short-lived one,
    such as a spawner that ended in between, would otherwise count negative)."""
    used: dict[str, float] = {}
    for pid, (label, seconds) in before.items():
        if pid in after:
            used[label] = used.get(label, 0.0) + after[pid][1] - seconds
    return {label: round(100 * seconds / wall, 1) for label, seconds in used.items()}


def _node_label(cmd: list[str]) -> str:
    if "--name" in cmd:
        return cmd[cmd.index("--name") + 1]
    if "-m" in cmd:
        return cmd[cmd.index("-m") + 1]
    return Path(cmd[0]).name if cmd else "?"


def exclusive_cpu_of(launch_output: str) -> str:
    """What the launcher said about ``exclusive_cpu``: "CPU n", "not reserved: why" or "off"."""
    for line in launch_output.splitlines():
        if "kept for the stepping thread" in line:
            return line.split("[INFO] ", 1)[-1].split(" kept", 1)[0]
        if "exclusive_cpu of" in line and "not reserved" in line:
            return "not reserved: " + line.split(": ", 1)[-1].split(";", 1)[0]
    return "off"


def fullstack(seconds: float, physics_rate: float, launch_file: str = "humanoid.yaml",
              launch_args: tuple[str, ...] = ()) -> dict:
    port = free_port()
    log_dir = Path(os.environ.get("TMPDIR", "/tmp")) / f"bench-lockstep-{port}"
    # the launcher says in its output whether it kept a CPU for the physics
    launch = Launch(launch_file, "mode:=lockstep", *launch_args, log_dir=log_dir, port=port)
    try:
        time.sleep(0.5)
        probe = start_probe(launch.port, seconds, "humanoid/joint_trajectory_controller/joint_trajectory")
        wait_measuring(probe)
        cpu_before, wall_before = process_tree_cpu(launch.proc.pid), time.perf_counter()
        result = finish_probe(probe, seconds + 60)
        cpu_after, wall = process_tree_cpu(launch.proc.pid), time.perf_counter() - wall_before
    finally:
        launch.close()
    result["steps_per_s"] = result["sim_seconds"] * physics_rate / result["wall_seconds"]
    result["cpu_percent"] = cpu_percent_between(cpu_before, cpu_after, wall)
    launch_output = launch.output()
    result["exclusive_cpu"] = exclusive_cpu_of(launch_output)
    result["world_load_ms"] = world_load_ms(launch_output)
    return result


def world_load_ms(launch_output: str) -> float | None:
    """The simulator's ``... loaded in N ms`` (parse and build of the world file), None without a world."""
    for line in launch_output.splitlines():
        if "[simulator]" in line and "; loaded in " in line:
            return float(line.rsplit("; loaded in ", 1)[1].split(" ms", 1)[0])
    return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=8.0, help="wall seconds measured per full-stack run")
    parser.add_argument("--inprocess-steps", type=int, default=4000)
    parser.add_argument("--physics-rate", type=float, default=1000.0, help="must match config/sim.yaml")
    parser.add_argument("--launch", default="humanoid.yaml", help="launch file of the full stack (experiments)")
    parser.add_argument("--world", action="append", default=[],
                        help="world:= of the full stack; repeat to compare worlds in the same run")
    parser.add_argument("--sensors", choices=("on", "off", "both"), default="on",
                        help="the robot's IMU and force/torque sensors (sensors:=); both: each in turn every run")
    parser.add_argument("--composed", choices=("on", "off"), default="on",
                        help="also run the full stack with composed:=true (c) in every run")
    parser.add_argument("launch_args", nargs="*", metavar="NAME:=VALUE",
                        help="extra launch arguments, e.g. commander:=none (experiments)")
    args = parser.parse_args(argv)
    if args.world:
        return compare_worlds(args)
    if args.sensors == "both":
        return compare_sensors(args)
    args.launch_args = [*args.launch_args, f"sensors:={'true' if args.sensors == 'on' else 'false'}"]

    load_before = os.getloadavg()[0]
    rows = []
    for run in range(args.runs):
        before = ceilings(args)
        # separate and composed in alternating order, so neither always meets the machine warmer
        kinds = ("separate", "composed") if args.composed == "on" else ("separate",)
        runs = {kind: fullstack(args.seconds, args.physics_rate, args.launch,
                                (*args.launch_args, *(("composed:=true",) if kind == "composed" else ())))
                for kind in (kinds if run % 2 == 0 else kinds[::-1])}
        full = runs["separate"]
        ceiling, plain = bracket(before, ceilings(args, after=True))   # bracket the full-stack runs
        row = {"inprocess": ceiling, "fullstack": full["steps_per_s"], "ratio": full["steps_per_s"] / ceiling,
               "pelvis_min": full["pelvis_min"], "cpu": full["cpu_percent"], "inprocess_height": before["height"],
               "exclusive_cpu": full["exclusive_cpu"], "plain": plain,
               "ratio_to_plain": full["steps_per_s"] / plain, "inprocess_to_plain": ceiling / plain}
        composed = runs.get("composed")
        if composed is not None:
            row.update({"composed": composed["steps_per_s"], "composed_ratio": composed["steps_per_s"] / ceiling,
                        "composed_ratio_to_plain": composed["steps_per_s"] / plain,
                        "composed_pelvis_min": composed["pelvis_min"], "composed_cpu": composed["cpu_percent"],
                        "composed_exclusive_cpu": composed["exclusive_cpu"]})
        rows.append(row)
        print(f"run {run + 1}: in-process {ceiling:,.0f} steps/s, plain dartpy {plain:,.0f}, full stack "
              f"{full['steps_per_s']:,.0f} steps/s, ratio {full['steps_per_s'] / ceiling:.2f} (to plain "
              f"{full['steps_per_s'] / plain:.2f}), pelvis min {full['pelvis_min']:.3f} m"
              + (f"; composed {composed['steps_per_s']:,.0f} steps/s (to plain {composed['steps_per_s'] / plain:.2f}), "
                 f"pelvis min {composed['pelvis_min']:.3f} m" if composed is not None else ""), file=sys.stderr)

    keys = ["inprocess", "fullstack", "ratio", "plain", "ratio_to_plain", "inprocess_to_plain"]
    if args.composed == "on":
        keys += ["composed", "composed_ratio", "composed_ratio_to_plain"]
    med = {k: statistics.median(r[k] for r in rows) for k in keys}
    pelvis_min = min(min(r["pelvis_min"], r.get("composed_pelvis_min", math.inf)) for r in rows)
    cpu_keys = sorted({k for r in rows for k in r["cpu"]})
    cpu = {k: statistics.median(r["cpu"].get(k, 0.0) for r in rows) for k in cpu_keys}
    table = [
        ("(a) in-process humanoid, simulator world code", f"{med['inprocess']:,.0f} steps/s", "the ceiling"),
        ("(b) humanoid.yaml mode:=lockstep (sim/clock, outside probe)", f"{med['fullstack']:,.0f} steps/s",
         f"{med['fullstack'] / args.physics_rate:.2f}x real time"),
        ("ratio (b)/(a)", f"{med['ratio']:.2f}", "goal >= 0.5, stretch 0.7"),
        ("(a') plain dartpy, the same humanoid (sim_instructions (a))", f"{med['plain']:,.0f} steps/s",
         "DART alone: no project code"),
        ("ratio (b)/(a'): full stack / plain dartpy", f"{med['ratio_to_plain']:.2f}", ""),
        ("ratio (a)/(a'): in-process simulator / plain dartpy", f"{med['inprocess_to_plain']:.2f}",
         "1.0: the simulator's own Python costs nothing"),
        ("pelvis height, lowest seen", f"{pelvis_min:.3f} m", "standing: > 0.75 m"),
        ("exclusive_cpu (the launcher's choice)", ", ".join(sorted({r["exclusive_cpu"] for r in rows})),
         "a CPU of its own for the physics thread"),
    ]
    table += [(f"  CPU of {k}", f"{v:.0f} %", "of one core, median") for k, v in cpu.items()]
    if args.composed == "on":
        composed_keys = sorted({k for r in rows for k in r["composed_cpu"]})
        composed_cpu = {k: statistics.median(r["composed_cpu"].get(k, 0.0) for r in rows) for k in composed_keys}
        table += [
            ("(c) composed:=true: simulator + controller manager in one process", f"{med['composed']:,.0f} steps/s",
             f"{med['composed'] / args.physics_rate:.2f}x real time"),
            ("ratio (c)/(a'): composed / plain dartpy", f"{med['composed_ratio_to_plain']:.2f}", "goal >= 0.85"),
            ("ratio (c)/(b): composed / separate", f"{med['composed'] / med['fullstack']:.2f}", ""),
        ]
        table += [(f"  CPU of {k} (composed)", f"{v:.0f} %", "of one core, median") for k, v in composed_cpu.items()]
    print_table(table, load_before)
    print(json.dumps({
        "fullstack_steps_per_s": round(med["fullstack"], 1), "inprocess_steps_per_s": round(med["inprocess"], 1),
        "ratio": round(med["ratio"], 4), "runs": [{k: (round(v, 3) if isinstance(v, float) else v)
                                                   for k, v in r.items()} for r in rows],
        "plain_steps_per_s": round(med["plain"], 1), "ratio_to_plain": round(med["ratio_to_plain"], 4),
        "inprocess_to_plain": round(med["inprocess_to_plain"], 4),
        "pelvis_min": round(pelvis_min, 4), "cpu_percent": cpu, "load_average": round(load_before, 2),
        **({"composed_steps_per_s": round(med["composed"], 1), "composed_ratio": round(med["composed_ratio"], 4),
            "composed_ratio_to_plain": round(med["composed_ratio_to_plain"], 4)} if args.composed == "on" else {}),
    }))
    return 0


def compare_sensors(args: argparse.Namespace) -> int:
    """The full stack with the sensors on and off, alternating within every run, against the same ceiling."""
    load_before = os.getloadavg()[0]
    rows: dict[str, list[float]] = {"on": [], "off": []}
    to_plain: dict[str, list[float]] = {"on": [], "off": []}
    for run in range(args.runs):
        before = ceilings(args)
        order = ("on", "off") if run % 2 == 0 else ("off", "on")
        fulls = {state: fullstack(args.seconds, args.physics_rate, args.launch,
                                  (*args.launch_args, f"sensors:={'true' if state == 'on' else 'false'}"))
                 for state in order}
        ceiling, plain = bracket(before, ceilings(args, after=True))
        for state, full in fulls.items():
            rows[state].append(full["steps_per_s"] / ceiling)
            to_plain[state].append(full["steps_per_s"] / plain)
            print(f"run {run + 1} sensors {state}: full stack {full['steps_per_s']:,.0f} steps/s, ratio "
                  f"{full['steps_per_s'] / ceiling:.3f} (to plain dartpy {full['steps_per_s'] / plain:.3f})",
                  file=sys.stderr)
    ratio = {state: statistics.median(values) for state, values in rows.items()}
    plain_ratio = {state: statistics.median(values) for state, values in to_plain.items()}
    print_table([(f"ratio (b)/(a), sensors {state}", f"{value:.3f}", f"{args.runs} runs, median; to plain dartpy "
                  f"(a') {plain_ratio[state]:.3f}") for state, value in ratio.items()] +
                [("sensors on / off", f"{ratio['on'] / ratio['off']:.3f}", "1.0: they cost nothing")], load_before)
    print(json.dumps({"ratio_sensors_on": round(ratio["on"], 4), "ratio_sensors_off": round(ratio["off"], 4),
                      "runs": rows, "load_average": round(load_before, 2),
                      "ratio_to_plain_sensors_on": round(plain_ratio["on"], 4),
                      "ratio_to_plain_sensors_off": round(plain_ratio["off"], 4), "runs_to_plain": to_plain}))
    return 0


def compare_worlds(args: argparse.Namespace) -> int:
    """The full stack in each ``--world`` in turn, every run, against the same in-process ceiling."""
    load_before = os.getloadavg()[0]
    rows: dict[str, list[dict]] = {world: [] for world in args.world}
    for run in range(args.runs):
        before = ceilings(args)
        fulls = {world: fullstack(args.seconds, args.physics_rate, args.launch,
                                  (*args.launch_args, f"world:={world}")) for world in args.world}
        ceiling, plain = bracket(before, ceilings(args, after=True))
        for world, full in fulls.items():
            rows[world].append({"inprocess": ceiling, "fullstack": full["steps_per_s"],
                                "ratio": full["steps_per_s"] / ceiling, "pelvis_min": full["pelvis_min"],
                                "load_ms": full["world_load_ms"], "exclusive_cpu": full["exclusive_cpu"],
                                "plain": plain, "ratio_to_plain": full["steps_per_s"] / plain})
            print(f"run {run + 1} {world}: full stack {full['steps_per_s']:,.0f} steps/s, ratio "
                  f"{full['steps_per_s'] / ceiling:.3f}, world loaded in {full['world_load_ms']} ms", file=sys.stderr)
    summary = {}
    for world, runs in rows.items():
        loads = [r["load_ms"] for r in runs if r["load_ms"] is not None]
        summary[world] = {"fullstack_steps_per_s": round(statistics.median(r["fullstack"] for r in runs), 1),
                          "ratio": round(statistics.median(r["ratio"] for r in runs), 4),
                          "ratio_to_plain": round(statistics.median(r["ratio_to_plain"] for r in runs), 4),
                          "pelvis_min": round(min(r["pelvis_min"] for r in runs), 4),
                          "load_ms": round(statistics.median(loads), 1) if loads else None}
    first, last = args.world[0], args.world[-1]
    # per run, then the median: both worlds of a run met the same machine state
    cost = statistics.median(b["fullstack"] / a["fullstack"] for a, b in zip(rows[first], rows[last]))
    table = [(f"{world}: ratio (b)/(a)", f"{v['ratio']:.3f}",
              f"{v['fullstack_steps_per_s']:,.0f} steps/s, loaded in {v['load_ms']} ms, pelvis min "
              f"{v['pelvis_min']:.3f} m") for world, v in summary.items()]
    table.append((f"world_cost: {last} / {first}", f"{cost:.3f}", "full-stack rate, same runs (goal >= 0.95)"))
    table.append(("load average (1 min) before / after", f"{load_before:.1f} / {os.getloadavg()[0]:.1f}",
                  f"{os.cpu_count()} cores"))
    width = max(len(r[0]) for r in table)
    print(f"{'measurement':<{width}}  {'result':>8}  note")
    for name, value, note in table:
        print(f"{name:<{width}}  {value:>8}  {note}")
    print(json.dumps({"worlds": summary, "world_cost": round(cost, 4), "runs": args.runs,
                      "load_average": round(load_before, 2)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
