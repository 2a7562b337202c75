"""A real robot against our humanoid in the main job, in the same run: lockstep steps/s and startup.

Each run, alternating the robots so both see the same machine load:
  (a) lockstep: ``python -m launch humanoid.yaml mode:=lockstep world:=empty.world sensors:=false`` with
      ``robot_file:=`` the robot (bench/lockstep.py's full-stack measurement: simulated seconds on
      ``sim/clock`` per wall second, from a second after the commander's first trajectory);
  (b) startup: the same launch in realtime, from the launcher's start to the first ``humanoid/joint_states``.

``ratio`` = G1's steps/s over the humanoid's (goal >= 0.5); ``startup_difference_s`` = G1's startup minus the
humanoid's. Needs example-robot-data (``pip install -e '.[robots]'``).

    python bench/robots.py [--runs 3] [--seconds 8] [--robot g1]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.common import Launch, plain_peer  # noqa: E402 - after the path is set
from bench.lockstep import fullstack  # noqa: E402
from bench.startup import listening  # noqa: E402

QUICK = ("world:=empty.world", "sensors:=false")


def startup_s(launch_args: tuple[str, ...], timeout_s: float = 120.0) -> float:
    first = threading.Event()
    with tempfile.TemporaryDirectory() as logs:
        start = time.monotonic()
        launch = Launch("humanoid.yaml", "mode:=realtime", *QUICK, *launch_args, log_dir=Path(logs))
        try:
            session = None
            while time.monotonic() - start < timeout_s:
                if session is None and listening(launch.port):
                    session = plain_peer(launch.port)
                    launch.sessions.append(session)
                    session.declare_subscriber("humanoid/joint_states", lambda _s: first.set())
                if first.is_set():
                    return time.monotonic() - start
                launch.check()
                time.sleep(0.02)
            raise RuntimeError(f"no humanoid/joint_states within {timeout_s:g} s")
        finally:
            launch.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=8.0, help="wall seconds measured per lockstep run")
    parser.add_argument("--robot", default="g1", help="a robot name ($(robot NAME): g1, talos, ...)")
    args = parser.parse_args(argv)
    from nodes.share import robot_file

    robots = {"humanoid": (), args.robot: (f"robot_file:={robot_file(args.robot)}",)}
    steps: dict[str, list[float]] = {name: [] for name in robots}
    starts: dict[str, list[float]] = {name: [] for name in robots}
    for run in range(args.runs):
        order = list(robots) if run % 2 == 0 else list(reversed(robots))
        for name in order:
            steps[name].append(fullstack(args.seconds, 1000.0, "humanoid.yaml", QUICK + robots[name])["steps_per_s"])
            starts[name].append(startup_s(robots[name]))
    median = {name: statistics.median(values) for name, values in steps.items()}
    start_median = {name: statistics.median(values) for name, values in starts.items()}
    print(f"{'robot':<12} {'lockstep steps/s':>17} {'startup s':>10}")
    for name in robots:
        print(f"{name:<12} {median[name]:>17.0f} {start_median[name]:>10.2f}")
    print(json.dumps({"robot": args.robot, "steps_per_s": median, "startup_s": start_median,
                      "ratio": median[args.robot] / median["humanoid"],
                      "startup_difference_s": start_median[args.robot] - start_median["humanoid"],
                      "runs": {"steps_per_s": steps, "startup_s": starts}}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
