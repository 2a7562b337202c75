"""Zenoh alone: what declaring and undeclaring entities on ever new keys leaves in the other sessions.

    python bench/zenoh_churn.py [--rounds 3] [--keys 500] [--observer peer|client] [--churner peer|client|runtime]
                                [--kinds pub,sub,queryable,token,matching] [--observer-declares]
    python bench/zenoh_churn.py --sim [--rounds 3] [--keys 200] [--reuse]

One process hosts a router (as the launcher does), one *observer* session declares nothing (or, with
``--observer-declares``, a subscriber on ``**`` as a graph watcher would), and one *churner* session declares,
per round, ``--keys`` entities of each ``--kinds`` on keys never used before (``r<round>/e<i>/...``) and
undeclares them all (``--churner runtime``: through ``nodes.core`` endpoints, each with its graph token and
ROS 2 twin). After each round (settled 2 s) the RSS of every process is sampled. Prints a table, then a JSON
line. ``--sim``: the simulator alone instead, ``--keys`` spawn/delete pairs a round over the wire.
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
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return 0.0


def _maybe_trim() -> None:
    """``CHURN_TRIM=1``: glibc returns its free pages every second (tells a leak from fragmentation)."""
    if os.environ.get("CHURN_TRIM") != "1":
        return
    import ctypes
    import threading

    libc = ctypes.CDLL("libc.so.6")

    def loop() -> None:
        while True:
            time.sleep(1.0)
            libc.malloc_trim(0)

    threading.Thread(target=loop, daemon=True).start()


def _config(mode: str, port: int, listen: bool):
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("transport/shared_memory/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    if mode != "client":
        config.insert_json5("listen/endpoints", json.dumps(["tcp/127.0.0.1:0"] if listen else []))
    for item in os.environ.get("CHURN_ZENOH_EXTRA", "").split(";"):
        if item.strip():
            key, _, value = item.partition("=")
            config.insert_json5(key.strip(), value.strip())
    return config


def role_router(port: int) -> None:
    import zenoh

    from nodes.core.session import router_config

    with zenoh.open(router_config(port)):
        print("ready", flush=True)
        sys.stdin.readline()


def role_observer(mode: str, port: int, declares: bool) -> None:
    import zenoh

    with zenoh.open(_config(mode, port, listen=True)) as session:
        held = []
        if declares:
            held.append(session.declare_subscriber("**", lambda _s: None))
            held.append(session.liveliness().declare_subscriber("**", lambda _s: None, history=True))
        print("ready", flush=True)
        sys.stdin.readline()


def _round_keys(line: str, keys: int) -> list[str]:
    """The key prefixes of the round ``line`` names: new ones every round, or round 0's again (CHURN_REUSE=1)."""
    round_ = 0 if os.environ.get("CHURN_REUSE") == "1" else int(line)
    return [f"r{round_}/e{i}" for i in range(keys)]


def role_runtime_churner(port: int, keys: int, kinds: list[str]) -> None:
    """The same churn through our node runtime (``nodes.core``): each endpoint with its graph token and, unless
    ZENROID_ROS2=0, its ROS 2 twin."""
    import msgs
    from nodes.core import Node

    joint_state, trigger = msgs.get_type("sensor_msgs/msg/JointState"), msgs.get_type("std_srvs/srv/Trigger")
    node = Node("churner", connect=[f"tcp/127.0.0.1:{port}"])
    print("ready", flush=True)
    for line in sys.stdin:
        held = []
        for base in _round_keys(line, keys):
            if "pub" in kinds:
                held.append(node.create_publisher(joint_state, f"/{base}/pub"))
            if "sub" in kinds:
                held.append(node.create_subscription(joint_state, f"/{base}/sub", lambda _m: None))
            if "queryable" in kinds:
                held.append(node.create_service(trigger, f"/{base}/srv", lambda _r: trigger.Response()))
        time.sleep(0.5)
        for entity in held:
            node.destroy_entity(entity)
        held.clear()
        print("done", flush=True)
    node.destroy()


def role_churner(mode: str, port: int, keys: int, kinds: list[str]) -> None:
    import zenoh

    with zenoh.open(_config(mode, port, listen=True)) as session:
        print("ready", flush=True)
        for line in sys.stdin:
            held = []
            for base in _round_keys(line, keys):
                if "pub" in kinds:
                    held.append(session.declare_publisher(f"{base}/pub"))
                if "matching" in kinds:   # a publisher that follows its matching status (our ROS 2 twins)
                    pub = session.declare_publisher(f"{base}/mpub")
                    held.append(pub.declare_matching_listener(lambda _status: None))
                    held.append(pub)
                if "sub" in kinds:
                    held.append(session.declare_subscriber(f"{base}/sub", lambda _s: None))
                if "queryable" in kinds:
                    held.append(session.declare_queryable(f"{base}/srv", lambda _q: None, complete=True))
                if "token" in kinds:
                    held.append(session.liveliness().declare_token(f"@lv/{base}/token"))
            time.sleep(0.5)
            for entity in held:
                entity.undeclare()
            held.clear()
            print("done", flush=True)


def _start(*args: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, __file__, *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, env=env)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready", args
    return proc


def simulator_alone(rounds: int, entities: int, reuse: bool) -> None:
    """``--sim``: the simulator alone (this process hosts the router), ``entities`` spawned and deleted a round
    over the wire, each awaited (URDF robots and SDF models alternately, as bench/soak.py's churn)."""
    import msgpack
    import zenoh

    from bench.common import child_env, free_port, loopback, spawn, stop
    from bench.soak import churn_request
    from nodes.core.session import open_router

    port = free_port()
    router = open_router(port)
    sim = spawn([sys.executable, "-m", "nodes.sim", "--params-file", str(ROOT / "config" / "sim.yaml"),
                 "--param", "entities:=[]"], env=child_env({"ZENOH_CONNECT": loopback(port)}))
    session = zenoh.open(_config("client", port, listen=False))

    def call(key: str, request: dict, timeout: float = 30.0) -> dict | None:
        for reply in session.get(key, payload=msgpack.packb(request), timeout=timeout):
            if reply.ok is not None:
                return msgpack.unpackb(reply.ok.payload.to_bytes())
        return None

    def churn(first: int, count: int) -> None:
        for index in range(first, first + count):
            name, request = churn_request(index % 2 if reuse else index)
            if not (call("sim/spawn_entity", request) or {}).get("success"):
                print(f"spawn {name} failed", file=sys.stderr)
            call("sim/delete_entity", {"name": name})

    try:
        deadline = time.monotonic() + 60
        while call("sim/get_model_list", {}, 1.0) is None and time.monotonic() < deadline:
            time.sleep(0.5)
        churn(0, 20)   # warm-up
        time.sleep(3.0)
        rows = [_rss_mb(sim.pid)]
        for round_ in range(rounds):
            churn(20 + round_ * entities, entities)
            time.sleep(3.0)
            rows.append(_rss_mb(sim.pid))
            print(f"round {round_ + 1}: simulator {rows[-1]:.1f} MB", file=sys.stderr, flush=True)
    finally:
        session.close()
        stop(sim, 5)
        router.close()
    print(f"simulator alone, {entities} spawn/delete pairs a round, names {'reused' if reuse else 'unique'}: "
          + " -> ".join(f"{r:.1f}" for r in rows) + f" MB ({rows[-1] - rows[0]:+.1f})")
    print(json.dumps({"bench": "zenoh_churn", "simulator_alone": True, "entities": entities, "rounds": rounds,
                      "reuse": reuse, "rss_mb": [round(r, 1) for r in rows],
                      "growth_mb": round(rows[-1] - rows[0], 1)}))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--role", default="")
    parser.add_argument("--port", type=int, default=0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--keys", type=int, default=500)
    parser.add_argument("--observer", default="peer")
    parser.add_argument("--observer-declares", action="store_true")
    parser.add_argument("--churner", default="peer")
    parser.add_argument("--kinds", default="pub,sub,queryable,token")
    parser.add_argument("--sim", action="store_true", help="the simulator alone, spawning and deleting entities")
    parser.add_argument("--reuse", action="store_true", help="--sim: the same two names over and over")
    args = parser.parse_args()
    if args.sim:
        return simulator_alone(args.rounds, args.keys, args.reuse)
    kinds = args.kinds.split(",")
    _maybe_trim()
    if args.role == "router":
        return role_router(args.port)
    if args.role == "observer":
        return role_observer(args.observer, args.port, args.observer_declares)
    if args.role == "churner":
        if args.churner == "runtime":
            return role_runtime_churner(args.port, args.keys, kinds)
        return role_churner(args.churner, args.port, args.keys, kinds)

    from bench.common import free_port

    port = free_port()
    procs: dict[str, subprocess.Popen] = {}
    procs["router"] = _start("--role", "router", "--port", str(port))
    procs["observer"] = _start("--role", "observer", "--port", str(port), "--observer", args.observer,
                               *(["--observer-declares"] if args.observer_declares else []))
    procs["churner"] = _start("--role", "churner", "--port", str(port), "--churner", args.churner,
                              "--keys", str(args.keys), "--kinds", args.kinds)
    time.sleep(2.0)
    rows = [{name: _rss_mb(p.pid) for name, p in procs.items()}]
    churner = procs["churner"]
    for round_ in range(args.rounds):
        assert churner.stdin is not None and churner.stdout is not None
        churner.stdin.write(f"{round_}\n")
        churner.stdin.flush()
        churner.stdout.readline()
        time.sleep(2.0)
        rows.append({name: _rss_mb(p.pid) for name, p in procs.items()})
    for proc in procs.values():
        assert proc.stdin is not None
        proc.stdin.close()
    for proc in procs.values():
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
    names = list(procs)
    print(f"observer={args.observer} churner={args.churner} kinds={args.kinds} keys={args.keys}")
    print("| sample | " + " | ".join(names) + " |")
    for i, row in enumerate(rows):
        print(f"| {'start' if i == 0 else f'round {i}'} | " + " | ".join(f"{row[n]:.1f}" for n in names) + " |")
    growth = {n: round(rows[-1][n] - rows[0][n], 2) for n in names}
    per_key_kb = {n: round(g * 1024 / max(1, args.keys * args.rounds), 2) for n, g in growth.items()}
    print(json.dumps({"bench": "zenoh_churn", "observer": args.observer, "churner": args.churner,
                      "kinds": kinds, "keys": args.keys, "rounds": args.rounds, "growth_mb": growth,
                      "per_key_kb": per_key_kb, "rss_mb": rows}))


if __name__ == "__main__":
    main()
