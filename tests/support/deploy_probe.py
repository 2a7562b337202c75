"""Programs the deployment tests run on their hosts (network namespaces), printing one JSON line.

``watch SECONDS [--until-signal]``: waits for ``humanoid/joint_states`` (at most 120 s), then records, for
SECONDS of sim time (at most 120 s of wall time; with ``--until-signal``: then until SIGINT), what a user on
that host sees. Sim time, not wall time: a loaded machine that runs the simulation slower than real time
still shows the same motion. Recorded: joint_states, the left knee's range (the joint commander bends it
every 2 s), the pelvis height (sim/model_states), sim time, and every sample on the robot's command keys
whose attachment marks it as the rogue's. It prints ``watching`` when it starts recording.

``rogue``: what a stranger holding only the read-only ``guest`` account tries: read joint_states, then
drive the robot (hardware commands, trajectories, wildcard puts), call the simulator's and the controller
manager's services, answer a simulator service in its place. It prints ``spoofing`` once its fake service
is up and keeps it up until SIGINT (at most 60 s), so a caller can show that it is never asked.

``call KEY``: one service call with an empty request; prints the replies (ok/error).

Connects like a node (``ZENOH_CONNECT``, ``ZENOH_CONFIG`` for its identity); ``RUST_LOG=warn`` logs why
Zenoh refused a connection.
"""

from __future__ import annotations

import json
import signal
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import msgpack

from nodes.core.session import init_zenoh_log, is_connected, open_peer

ROGUE = b"rogue"
COMMAND_KEYS = ("humanoid/hardware/**", "humanoid/*/joint_trajectory")
KNEE = "left_knee"
STOP = threading.Event()   # set by SIGINT / SIGTERM


def _stamp(sample) -> bytes:
    attachment = sample.attachment
    return attachment.to_bytes() if attachment is not None else b""


def watch(seconds: float, until_signal: bool = False) -> dict:
    session = open_peer()
    lock = threading.Lock()
    knees: list[float] = []
    pelvis: list[float] = []
    clock: list[float] = []
    rogue_seen: list[str] = []
    first = threading.Event()

    def on_joint_states(sample) -> None:
        msg = msgpack.unpackb(sample.payload.to_bytes())
        with lock:
            if KNEE in msg["name"]:
                knees.append(msg["position"][msg["name"].index(KNEE)])
        first.set()

    def on_model_states(sample) -> None:
        msg = msgpack.unpackb(sample.payload.to_bytes())
        if "humanoid" in msg["name"]:
            with lock:
                pelvis.append(msg["pose"][msg["name"].index("humanoid")]["position"]["z"])

    def on_clock(sample) -> None:
        msg = msgpack.unpackb(sample.payload.to_bytes())["clock"]
        with lock:
            clock.append(msg["sec"] + msg["nanosec"] * 1e-9)

    def on_command(sample) -> None:
        if _stamp(sample).startswith(ROGUE):
            with lock:
                rogue_seen.append(str(sample.key_expr))

    subs = [session.declare_subscriber("humanoid/joint_states", on_joint_states),
            session.declare_subscriber("sim/model_states", on_model_states),
            session.declare_subscriber("sim/clock", on_clock)]
    subs += [session.declare_subscriber(key, on_command) for key in COMMAND_KEYS]
    try:
        if not first.wait(120):
            return {"error": "no joint_states in 120 s"}
        with lock:
            knees.clear(), pelvis.clear(), clock.clear()
        print("watching", flush=True)
        deadline = time.monotonic() + 120

        def sim_seconds_watched() -> float:
            with lock:
                return clock[-1] - clock[0] if clock else 0.0

        while sim_seconds_watched() < seconds and time.monotonic() < deadline:
            time.sleep(0.1)
        if until_signal:
            STOP.wait(max(0.0, deadline - time.monotonic()))
        with lock:
            return {"joint_states": len(knees), "knee_min": min(knees, default=None),
                    "knee_max": max(knees, default=None), "pelvis_min": min(pelvis, default=None),
                    "sim_time": [clock[0], clock[-1]] if clock else None, "rogue_seen": rogue_seen}
    finally:
        for sub in subs:
            sub.undeclare()
        session.close()


def _replies(session, key: str, payload: dict, timeout: float = 2.0) -> list[str]:
    """What answered a call: "ok" / "err" per reply, leaving out our own fake service's answers."""
    out = []
    for reply in session.get(key, payload=msgpack.packb(payload), timeout=timeout):
        if reply.ok is None:
            out.append("err")
        elif _stamp(reply.ok) != ROGUE:
            out.append("ok")
    return out


def rogue() -> dict:
    try:
        session = open_peer()
    except Exception as exc:  # noqa: BLE001 - report the refusal, whatever zenoh calls it
        return {"connected": False, "error": str(exc)[:300]}
    deadline = time.monotonic() + 5
    while not is_connected(session) and time.monotonic() < deadline:
        time.sleep(0.1)
    if not is_connected(session):
        session.close()
        return {"connected": False, "error": "no router or peer accepted the session"}
    report: dict = {"connected": True}
    got = threading.Event()
    states: list[int] = []

    def on_joint_states(sample) -> None:
        states.append(len(msgpack.unpackb(sample.payload.to_bytes())["name"]))
        got.set()

    sub = session.declare_subscriber("humanoid/joint_states", on_joint_states)
    report["read_joint_states"] = got.wait(30)
    report["joints"] = states[0] if states else 0
    # A real hardware frame bending every leg joint hard: if one reached the simulator, the robot would fall.
    legs = [f"{side}_{joint}" for side in ("left", "right")
            for joint in ("hip_pitch", "knee", "ankle_pitch")]
    frame = msgpack.packb({"step": 0, "update_rate": 1000, "name": legs, "interface": ["position"] * len(legs),
                           "value": [1.5] * len(legs)})
    trajectory = msgpack.packb({"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}, "joint_names": legs,
                                "points": [{"positions": [1.5] * len(legs), "velocities": [], "accelerations": [],
                                            "effort": [], "time_from_start": {"sec": 0, "nanosec": 200_000_000}}]})
    spoof = session.declare_queryable("sim/get_physics_properties",
                                      lambda query: query.reply(query.key_expr, msgpack.packb({"success": True}),
                                                                attachment=ROGUE))
    print("spoofing", flush=True)
    puts = {"humanoid/hardware/command": frame, "humanoid/hardware/*": frame, "humanoid/**": frame, "**": frame,
            "humanoid/hardware/state": frame,
            "humanoid/joint_trajectory_controller/joint_trajectory": trajectory}
    deadline = time.monotonic() + 4.0
    sent = 0
    while time.monotonic() < deadline:
        for key, payload in puts.items():
            session.put(key, payload, attachment=ROGUE)
            sent += 1
        time.sleep(0.01)
    report["puts"] = sent
    calls = {
        "sim/pause_physics": {},
        "sim/reset_world": {},
        "sim/set_physics_properties": {"gravity": {"x": 0.0, "y": 0.0, "z": 9.81}, "set_gravity": True},
        "sim/**": {},
        "**": {},
        "simulator/set_parameters": {"parameters": []},
        "humanoid/controller_manager/switch_controller": {
            "activate_controllers": [], "deactivate_controllers": ["joint_trajectory_controller"],
            "strictness": 1, "activate_asap": False, "timeout": {"sec": 0, "nanosec": 0}},
    }
    with ThreadPoolExecutor(len(calls)) as pool:   # each refused call waits out its timeout: all at once
        replies = pool.map(lambda item: _replies(session, *item), calls.items())
        report["replies"] = dict(zip(calls, replies, strict=True))
    STOP.wait(60)
    spoof.undeclare()
    sub.undeclare()
    session.close()
    return report


def call(key: str) -> dict:
    session = open_peer()
    try:
        deadline = time.monotonic() + 30
        while True:  # the service may still be coming up
            replies = []
            for reply in session.get(key, payload=msgpack.packb({}), timeout=3.0):
                if reply.ok is not None:
                    replies.append({"ok": msgpack.unpackb(reply.ok.payload.to_bytes()),
                                    "attachment": _stamp(reply.ok).decode(errors="replace")})
                else:
                    replies.append({"err": reply.err.payload.to_bytes().decode(errors="replace")})
            if replies or time.monotonic() > deadline:
                return {"replies": replies}
            time.sleep(0.5)
    finally:
        session.close()


def main(argv: list[str]) -> int:
    init_zenoh_log()  # zenoh's own reasons on stderr at RUST_LOG's level (why a handshake was refused)
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: STOP.set())
    verb = argv[0]
    if verb == "watch":
        result = watch(float(argv[1]), until_signal="--until-signal" in argv[2:])
    elif verb == "rogue":
        result = rogue()
    elif verb == "call":
        result = call(argv[1])
    else:
        raise SystemExit(f"unknown verb {verb!r}")
    print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
