"""The simulator's physics step in CPU instructions (callgrind), against plain dartpy stepping the same robot.

Wall-clock timings on this shared machine swing 2x; instruction counts do not. Each loop runs in its own
``valgrind --tool=callgrind`` process; callgrind dumps its counts when the loop calls ``getppid`` (the marker,
``--dump-before=getppid``), once after start-up (imports, URDF loading, 300 steps of landing on the ground) and
once after the measured steps, so the second dump holds exactly those steps: per-step instructions = its total /
steps (the same as running two step counts and taking the difference, in one run). DART's share is
``dart::simulation::World::step`` from ``callgrind_annotate --inclusive=yes`` on that dump.

  (a) plain: robots/humanoid.urdf loaded with dartpy's DartLoader, a ground box, the joints' limits enforced
      and implicit joint springs at the simulator's gains (config/sim.yaml), a slow squat commanded by moving
      the six leg-pitch rest positions every step. None of this project's code.
      plain-force: the same, the rest positions left at 0 and the squat given as joint forces kp * target in
      one ``setForces`` call (DART's spring force is linear in the rest position: the same physics, to
      rounding). ``setRestPosition`` bumps the skeleton's version, and DART's collision group then re-registers
      the skeleton's collision objects in the next step: World::step itself costs ~0.23 M more a step.
  (b) ours: ``Simulation.step`` + ``HardwareInterface.apply_command`` with the same squat (all 22 joints
      commanded, as the controller manager does; bench/lockstep.py's in-process loop), sensors off, and sensors
      on (then ``Simulation.sample_sensors`` every step too, as the simulator does every control period): all
      the body sensors (ours-on: the pelvis IMU and the ankle force/torque sensors at 1 kHz, the foot contact
      sensors at 100 Hz), or the IMU and force/torque sensors alone (ours-imu-ft: the contact sensors taken out
      of the URDF; issue 28's goal is <= 5 % over sensors off).
      ours-lab: ours-off in ``worlds/simple_lab.world`` (loaded as the simulator loads it, its resting models put
      to sleep by the simulator's RestKeeper): what a furnished world costs a step (issue 25's goal: within 5 %),
      in steady state: it settles WORLD_SETTLE_STEPS, so its resting models are asleep before the squat.

Every loop takes its commands from a table built before the first marker: what is counted is the stepping, not
the bench making up a squat.

``overhead`` = (all instructions per step - World::step's) / World::step's: what runs outside DART's step (for
the plain loops: the loop and the dartpy calls, the floor of any Python driver). The goal of issue 28 is ours
sensors off <= 10 %. Prints a table, then one JSON line.

    python bench/sim_instructions.py [--steps 1000] [--jobs 2] [--loops plain,ours-off] [--keep DIR]
    python bench/sim_instructions.py --loop ours-off --steps 1000    # one loop, no valgrind (for profilers)
"""

from __future__ import annotations

import argparse
import concurrent.futures
import fnmatch
import gc
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

URDF = ROOT / "robots" / "humanoid.urdf"
PHYSICS_RATE = 1000.0
SPAWN_Z = 0.93
SETTLE_STEPS = 300            # landing on the ground, holding zero, before the squat starts
WORLD_SETTLE_STEPS = 1500     # ours-lab: also the world's free models landing and lying still 0.5 s (asleep)
LOOPS = ("plain", "plain-force", "ours-off", "ours-on", "ours-imu-ft", "ours-lab")
LEG_PITCH = {"hip_pitch": -0.5, "knee": 1.0, "ankle_pitch": -0.5}   # bench/lockstep.py's squat direction
WORLD_STEP = "dart::simulation::World::step"


def squat_depth(k: int) -> float:
    """bench/lockstep.py's slow squat (0.25 Hz, knees 0 .. 0.6 rad) at step ``k``."""
    return 0.3 * (1.0 - math.cos(2 * math.pi * 0.25 * k / PHYSICS_RATE))


def pitch_of(name: str) -> float:
    part = name.split("_", 1)[1] if name.startswith(("left_", "right_")) else ""
    return LEG_PITCH.get(part, 0.0)


def sim_gains() -> dict[str, dict[str, float]]:
    import yaml

    return yaml.safe_load((ROOT / "config" / "sim.yaml").read_text())["simulator"]["ros__parameters"]["gains"]


# ------------------------------------------------------------------------------------------ the loops
def collect_as_the_simulator_does() -> None:
    """The simulator's garbage collector settings once it steps (``nodes/sim/node.py``, ``spin``): what exists
    is frozen, and young objects are collected every 50,000 allocations instead of 700."""
    gc.collect()
    gc.freeze()
    gc.set_threshold(50_000, 20, 100)


def mark() -> None:
    """Where callgrind dumps its counts (--dump-before=getppid): nothing else in the loops calls getppid."""
    os.getppid()


class PlainHumanoid:
    """(a): the humanoid in plain dartpy, none of this project's code: a world with a ground box, the URDF from
    DartLoader, limits enforced, implicit joint springs at the simulator's gains (config/sim.yaml)."""

    def __init__(self) -> None:
        import dartpy as dart
        import numpy as np

        world = dart.simulation.World()
        world.setTimeStep(1.0 / PHYSICS_RATE)
        world.getConstraintSolver().setCollisionDetector(dart.collision.FCLCollisionDetector())
        world.setGravity([0.0, 0.0, -9.81])
        ground = dart.dynamics.Skeleton("ground_plane")
        _, body = ground.createWeldJointAndBodyNodePair()
        node = body.createShapeNode(dart.dynamics.BoxShape([50.0, 50.0, 0.1]))
        node.createVisualAspect()
        node.createCollisionAspect()
        node.createDynamicsAspect().setFrictionCoeff(1.0)
        offset = dart.math.Isometry3()
        offset.set_translation([0.0, 0.0, -0.05])   # top face at z = 0
        body.getParentJoint().setTransformFromParentBodyNode(offset)
        world.addSkeleton(ground)

        robot = dart.utils.DartLoader().parseSkeleton(str(URDF))
        robot.setPosition(5, SPAWN_Z)                # FreeJoint: rx ry rz x y z
        gains = self.gains(robot)
        self.squatting = []                          # (joint, pitch): the leg joints the squat moves
        self.force_per_depth = np.zeros(robot.getNumDofs())   # kp * pitch per DOF: the squat as joint forces
        for i in range(robot.getNumJoints()):
            joint = robot.getJoint(i)
            if joint.getNumDofs() != 1:
                continue
            name = joint.getName()
            gain = gains[name]
            joint.setLimitEnforcement(True)          # the humanoid has no continuous joint
            joint.setSpringStiffness(0, float(gain["p"]))
            joint.setDampingCoefficient(0, float(gain["d"]))
            joint.setRestPosition(0, 0.0)
            if pitch_of(name):
                self.squatting.append((joint, pitch_of(name)))
                self.force_per_depth[joint.getIndexInSkeleton(0)] = float(gain["p"]) * pitch_of(name)
        world.addSkeleton(robot)
        self.world, self.robot = world, robot

    @staticmethod
    def gains(robot) -> dict[str, dict[str, float]]:
        """The simulator's gains for each joint: config/sim.yaml's patterns, else the physics' (computed once
        here, as the simulator computes them once at spawn: nothing of ours runs while the loop steps)."""
        from nodes.sim.servo_gains import physics_gains

        names = [robot.getJoint(i).getName() for i in range(robot.getNumJoints())
                 if robot.getJoint(i).getNumDofs() == 1]
        patterns = sim_gains() or {}
        physics = physics_gains(robot, names, floating=True)
        return {name: next((g for pattern, g in patterns.items() if fnmatch.fnmatchcase(name, pattern)),
                           {"p": physics[name].kp, "d": physics[name].kd}) for name in names}

    def settle(self, steps: int = SETTLE_STEPS) -> None:
        for _ in range(steps):
            self.world.step()

    def squat(self, depths: list[float]) -> None:
        """One step per depth, the squat commanded by moving the rest positions (a controller's way)."""
        world_step, squatting = self.world.step, self.squatting
        for depth in depths:
            for joint, pitch in squatting:
                joint.setRestPosition(0, pitch * depth)
            world_step()

    def squat_by_force(self, forces: list) -> None:
        """One step per force vector (``force_per_depth * depth``), the rest positions left at 0."""
        set_forces, world_step = self.robot.setForces, self.world.step
        for force in forces:
            set_forces(force)
            world_step()

    def pelvis_height(self) -> float:
        return float(self.robot.getBodyNode(0).getWorldTransform().translation()[2])


def plain_loop(steps: int, as_force: bool = False) -> float:
    """(a) under the markers. Returns the pelvis height at the end."""
    plain = PlainHumanoid()
    depths = [squat_depth(k) for k in range(steps)]
    forces = [plain.force_per_depth * depth for depth in depths]
    plain.settle()
    collect_as_the_simulator_does()
    mark()
    if as_force:
        plain.squat_by_force(forces)
    else:
        plain.squat(depths)
    mark()
    return plain.pelvis_height()


def without_contact_sensors(urdf: str) -> str:
    """The URDF without its contact sensors' ``<gazebo>`` blocks (the bumpers under the feet)."""
    return re.sub(r'<gazebo reference="[^"]*">\s*<sensor name="[^"]*" type="contact">.*?</sensor>\s*</gazebo>', "",
                  urdf, flags=re.S)


def ours_loop(steps: int, sensors: bool, contact_sensors: bool = True, world_file: str | None = None) -> float:
    """(b): the simulator's Simulation + HardwareInterface, as bench/lockstep.py's in-process loop."""
    from nodes.core.params import load_params_file
    from nodes.sim.config import DEFAULT_CONFIG, parse_gains
    from nodes.sim.entity import EntitySpec, Pose
    from nodes.sim.sdf import load_world
    from nodes.sim.simulation import Simulation
    from nodes.sim.world import PhysicsWorld

    defaults = load_params_file(DEFAULT_CONFIG, "simulator")
    world = PhysicsWorld(PHYSICS_RATE)
    world.add_ground()
    sim = Simulation(world, parse_gains(defaults["gains"]), sensors_enabled=sensors)
    if world_file is not None:
        sim.load_world(load_world(world_file), defaults["ground_size"], defaults["ground_friction"])
    urdf = URDF.read_text() if contact_sensors else without_contact_sensors(URDF.read_text())
    entity = sim.spawn(EntitySpec("humanoid", urdf, pose=Pose.from_xyz_rpy(0, 0, SPAWN_Z)))
    hw = sim.hardware["humanoid"]
    names = list(hw.names)
    interfaces = ["position"] * len(names)
    pitches = [pitch_of(name) for name in names]
    commands = [[p * squat_depth(k) for p in pitches] for k in range(steps)]
    zeros = [0.0] * len(names)
    for _ in range(SETTLE_STEPS if world_file is None else WORLD_SETTLE_STEPS):
        if sensors:
            sim.sample_sensors()
        hw.apply_command(names, interfaces, zeros)
        sim.step(1)
    apply_command, step, sample_sensors = hw.apply_command, sim.step, sim.sample_sensors
    collect_as_the_simulator_does()
    mark()
    if sensors:
        for command in commands:
            sample_sensors()
            apply_command(names, interfaces, command)
            step(1)
    else:
        for command in commands:
            apply_command(names, interfaces, command)
            step(1)
    mark()
    height = float(entity.world_pose().position[2])
    sim.clear()
    return height


def run_loop(loop: str, steps: int) -> float:
    if loop.startswith("plain"):
        return plain_loop(steps, as_force=loop == "plain-force")
    return ours_loop(steps, sensors=loop in ("ours-on", "ours-imu-ft"), contact_sensors=loop != "ours-imu-ft",
                     world_file="simple_lab.world" if loop == "ours-lab" else None)


# ------------------------------------------------------------------------------------------ callgrind
def callgrind(loop: str, steps: int, out_dir: Path) -> dict:
    """Instructions per step, in all and in World::step (inclusive), of one loop under callgrind."""
    out = out_dir / f"callgrind.{loop}.out"
    # the same hashes, and no OpenBLAS worker threads (numpy starts them at import: their spinning, counted
    # too, depends on the scheduler and made runs differ by 2 %)
    env = dict(os.environ, PYTHONHASHSEED="0", PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    started = time.perf_counter()
    proc = subprocess.run(["valgrind", "--tool=callgrind", "--dump-before=getppid", f"--callgrind-out-file={out}",
                           sys.executable, str(Path(__file__).resolve()), "--loop", loop, "--steps", str(steps)],
                          capture_output=True, text=True, env=env, cwd=ROOT)
    if proc.returncode != 0:
        raise RuntimeError(f"callgrind of {loop} failed:\n{proc.stderr[-3000:]}")
    measured = out.with_name(out.name + ".2")     # dump 1: start-up; dump 2: the measured steps
    if not measured.exists() or out.with_name(out.name + ".3").exists():
        raise RuntimeError(f"{loop}: expected exactly two marker dumps next to {out}")
    total = None
    for line in measured.read_text(errors="replace").splitlines():
        if line.startswith(("summary:", "totals:")):
            total = int(line.split()[1])
    annotate = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(measured)],
                              capture_output=True, text=True, check=True).stdout
    world_step = max((int(m.group(1).replace(",", "")) for m in
                      re.finditer(r"^\s*([\d,]+)\s.*" + re.escape(WORLD_STEP) + r"\(", annotate, re.M)),
                     default=None)
    if total is None or world_step is None:
        raise RuntimeError(f"no totals or no {WORLD_STEP} in {measured}")
    height = float(proc.stdout.strip().splitlines()[-1].split()[-1])
    return {"total": total / steps, "world_step": world_step / steps, "outside": (total - world_step) / steps,
            "overhead_percent": 100.0 * (total - world_step) / world_step, "height": height,
            "seconds": time.perf_counter() - started}


def sensor_cost(results: dict, loop: str) -> float:
    """What ``loop`` adds to a step (its sensors, or its world), in % of ours-off's instructions."""
    return 100.0 * (results[loop]["total"] - results["ours-off"]["total"]) / results["ours-off"]["total"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=1000, help="measured steps per loop (after 300 settling)")
    parser.add_argument("--loop", choices=LOOPS, help="run one loop in this process (no valgrind) and exit")
    parser.add_argument("--loops", default=",".join(LOOPS), help="which loops to measure (comma-separated)")
    parser.add_argument("--jobs", type=int, default=2, help="callgrind processes at a time")
    parser.add_argument("--keep", type=Path, help="keep the callgrind files in this directory")
    args = parser.parse_args(argv)
    if args.loop:
        print(f"pelvis height {run_loop(args.loop, args.steps):.4f}")
        return 0
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        print("valgrind and callgrind_annotate are needed (apt-get install valgrind)", file=sys.stderr)
        return 2
    loops = [loop for loop in args.loops.split(",") if loop]
    load_before = os.getloadavg()[0]
    out_dir = args.keep or Path(tempfile.mkdtemp(prefix="sim-instructions-"))
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {loop: pool.submit(callgrind, loop, args.steps, out_dir) for loop in loops}
        results = {loop: future.result() for loop, future in futures.items()}
    if args.keep is None:
        shutil.rmtree(out_dir, ignore_errors=True)

    from bench.common import print_table

    rows = []
    for loop, r in results.items():
        rows.append((f"{loop}: instructions per step", f"{r['total'] / 1e6:.3f} M",
                     f"World::step {r['world_step'] / 1e6:.3f} M, outside it {r['outside'] / 1e3:.0f} k "
                     f"({r['overhead_percent']:.1f} % of World::step)"))
    if "ours-off" in results and "ours-lab" in results:
        rows.append(("ours-lab: the world's cost", f"{sensor_cost(results, 'ours-lab'):.1f} %",
                     "simple_lab.world over empty, per step (goal <= 5 %)"))
    for loop in ("ours-off", "ours-on", "ours-imu-ft"):
        for base in ("plain", "plain-force"):
            if base in results and loop in results:
                rows.append((f"{loop} / {base}, per step", f"{results[loop]['total'] / results[base]['total']:.3f}",
                             "1.0: no cost beyond plain dartpy"))
    if "ours-off" in results:
        rows.append(("ours-off: outside World::step", f"{results['ours-off']['overhead_percent']:.1f} %",
                     "of World::step (goal <= 10 %)"))
        for loop in ("ours-on", "ours-imu-ft"):
            if loop in results:
                rows.append((f"{loop}: the sensors' cost", f"{sensor_cost(results, loop):.1f} %",
                             "over ours-off, per step" + (" (goal <= 5 %)" if loop == "ours-imu-ft" else "")))
    rows.append(("callgrind runs", f"{time.perf_counter() - started:.0f} s",
                 f"{args.steps} steps after {SETTLE_STEPS} settling; pelvis at the end "
                 + ", ".join(f"{loop} {r['height']:.3f} m" for loop, r in results.items())))
    print_table(rows, load_before)
    summary: dict = {"steps": args.steps, "settle_steps": SETTLE_STEPS, "load_average": round(load_before, 2)}
    for loop, r in results.items():
        key = loop.replace("-", "_")
        summary[f"{key}_per_step"] = round(r["total"])
        summary[f"{key}_world_step_per_step"] = round(r["world_step"])
        summary[f"{key}_overhead_percent"] = round(r["overhead_percent"], 2)
    if "ours-off" in results and "ours-lab" in results:
        summary["ours_lab_world_cost_percent"] = round(sensor_cost(results, "ours-lab"), 2)
    for loop in ("ours-on", "ours-imu-ft"):
        if "ours-off" in results and loop in results:
            summary[f"{loop.replace('-', '_')}_sensor_cost_percent"] = round(sensor_cost(results, loop), 2)
    for loop in ("ours-off", "ours-on", "ours-imu-ft"):
        for base in ("plain", "plain-force"):
            if base in results and loop in results:
                key = f"ratio_{loop.replace('-', '_')}_to_{base.replace('-', '_')}"
                summary[key] = round(results[loop]["total"] / results[base]["total"], 4)
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
