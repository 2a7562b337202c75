"""How long a spawn over the wire stops the simulator: a robot with meshes not in the mesh cache yet (cold)
sent to ``sim/spawn_entity`` of a realtime simulator, while this script asks ``sim/get_physics_properties``
every 50 ms and counts ``sim/clock`` messages.

The robot is example-robot-data's Unitree G1 (51 STL meshes; ``pip install example-robot-data``). Reported:
the spawn's reply time, the longest wait of another request during it (how long the stepping thread was
busy at once) and the sim time that passed during it (clock messages, 100 per simulated second).

    python bench/spawn_pause.py [--runs 2]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.common import child_env, free_port, loopback, print_table, spawn, stop  # noqa: E402
from bench.meshes import g1  # noqa: E402


def run_once(robot: Path) -> dict:
    import msgs
    from nodes.core import Inline, Node, Raw
    from nodes.core.endpoints import ServiceError
    from nodes.core.session import open_router
    from nodes.sim.interfaces import GetPhysicsProperties, SpawnEntity

    port = free_port()
    router = open_router(port)
    cache = tempfile.mkdtemp(prefix="spawn_pause_cache_")
    env = child_env({"ZENROID_MESH_CACHE": cache, "ZENOH_CONNECT": loopback(port)})
    sim = spawn([sys.executable, "-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml"),
                 "--param", "world:=empty.world", "--param", "mode:=realtime"], env=env)
    node = Node("spawn_pause_bench", connect=[loopback(port)])
    try:
        physics = node.create_client(GetPhysicsProperties, "/sim/get_physics_properties")
        deadline = time.monotonic() + 120
        while True:
            try:
                physics.call(GetPhysicsProperties.Request(), timeout=1.0)
                break
            except ServiceError:
                if time.monotonic() > deadline:
                    raise
        clock: list[float] = []
        node.create_subscription(None, "/sim/clock", lambda _p: clock.append(time.monotonic()), delivery=Inline(),
                                 message=Raw())
        time.sleep(1.0)
        done: list[tuple[float, float, bool]] = []

        def request() -> None:
            started = time.monotonic()
            reply = node.create_client(SpawnEntity, "/sim/spawn_entity").call(msgs.from_dict(SpawnEntity.Request, {
                "name": "g1", "xml": robot.read_text(), "robot_namespace": "g1",
                "initial_pose": {"position": {"z": 1.0}}}), timeout=300)
            done.append((started, time.monotonic(), reply.success))
        spawning = threading.Thread(target=request)
        spawning.start()
        waits = []
        while spawning.is_alive():
            asked = time.monotonic()
            physics.call(GetPhysicsProperties.Request(), timeout=300)
            waits.append(time.monotonic() - asked)
            time.sleep(0.05)
        spawning.join()
        started, ended, success = done[0]
        return {"success": success, "spawn_s": ended - started, "longest_wait_s": max(waits),
                "sim_time_during_spawn_s": sum(started <= t <= ended for t in clock) / 100.0}
    finally:
        node.destroy()
        stop(sim)
        router.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=2)
    args = parser.parse_args()
    robot = g1()
    if robot is None:
        print("example-robot-data is not installed (pip install example-robot-data)", file=sys.stderr)
        return 2
    load_before = os.getloadavg()[0]
    runs = [run_once(robot) for _ in range(args.runs)]
    result = {key: statistics.median(r[key] for r in runs) for key in ("spawn_s", "longest_wait_s",
                                                                     "sim_time_during_spawn_s")}
    print(json.dumps({"bench": "spawn_pause", "robot": "g1", "runs": args.runs, **result,
                      "all_succeeded": all(r["success"] for r in runs)}))
    print_table([("cold G1 spawn, reply after", f"{result['spawn_s']:.2f} s", "median"),
                 ("longest wait of another request", f"{result['longest_wait_s']:.2f} s",
                  "the stepping thread busy at once"),
                 ("sim time passed during the spawn", f"{result['sim_time_during_spawn_s']:.2f} s",
                  "realtime mode")], load_before)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
