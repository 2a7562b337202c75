"""The main job in lockstep, watched by a client that imports only zenoh and msgpack:

- two runs started paused (``paused:=true``) and unpaused once every controller is active give
  bit-identical joint trajectories, the joint commander's knee bends included, bit-identical IMU and
  foot force/torque readings (the shipped IMU's noise on), and byte-identical camera images, laser scans and
  lidar clouds (every frame rendered, range noise on), in the main job's world (``simple_lab.world``:
  static and dynamic models around the robot);
- every hot-path message (hardware frames, joint_states, tf, controller state, clock, model_states,
  humanoid_state), built by the generated packers, is a complete map of its schema: a third-party
  ``msgpack.unpackb`` sees exactly the fields of the ``.msg`` file, and the schema decoder accepts it;
- ``exclusive_cpu`` (on by default in lockstep): while it runs, the simulator's stepping thread is alone
  on the CPU the launcher kept, and no other thread of the launch may run there.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import msgpack
import psutil
import pytest
import zenoh

import msgs
from bench.common import Launch, free_port
from msgs.registry import get_spec

RECORD_UNTIL = 5.5   # sim s: the commander stands at 2.2 s and bends the knees from 4.2 s
HOT_KEYS = {
    "humanoid/hardware/state": "zenroid_msgs/msg/HardwareState",
    "humanoid/hardware/command": "zenroid_msgs/msg/HardwareCommand",
    "humanoid/joint_states": "sensor_msgs/msg/JointState",
    "humanoid/tf": "tf2_msgs/msg/TFMessage",
    "humanoid/joint_trajectory_controller/controller_state": "control_msgs/msg/JointTrajectoryControllerState",
    "humanoid/humanoid_state": "humanoid_msgs/msg/HumanoidState",
    "sim/clock": "rosgraph_msgs/msg/Clock",
    "sim/model_states": "gazebo_msgs/msg/ModelStates",
    "humanoid/imu_sensor_broadcaster/imu": "sensor_msgs/msg/Imu",
    "humanoid/left_foot_ft_broadcaster/wrench": "geometry_msgs/msg/WrenchStamped",
    "humanoid/right_foot_ft_broadcaster/wrench": "geometry_msgs/msg/WrenchStamped",
    "humanoid/camera/rgb": "sensor_msgs/msg/Image",
    "humanoid/scan": "sensor_msgs/msg/LaserScan",
    "humanoid/lidar/points": "sensor_msgs/msg/PointCloud2",
}
# the sensors compared run to run, with the fewest messages a run must have of each before RECORD_UNTIL
SENSOR_KEYS = {"humanoid/imu_sensor_broadcaster/imu": 5000, "humanoid/left_foot_ft_broadcaster/wrench": 5000,
               "humanoid/camera/rgb": int(30 * RECORD_UNTIL), "humanoid/scan": int(20 * RECORD_UNTIL),
               "humanoid/lidar/points": int(10 * RECORD_UNTIL)}
ACTIVE = ("joint_trajectory_controller", "joint_state_broadcaster", "imu_sensor_broadcaster",
          "left_foot_ft_broadcaster", "right_foot_ft_broadcaster")


def client_session(port: int) -> zenoh.Session:
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps("client"))
    config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(config)


def call(session: zenoh.Session, key: str, payload: dict, timeout: float = 5.0) -> dict | None:
    for reply in session.get(key, payload=msgpack.packb(payload), timeout=timeout):
        if reply.ok is not None:
            return msgpack.unpackb(reply.ok.payload.to_bytes())
    return None


def schema_fields(type_name: str, value: object, path: str = "") -> list[str]:
    """Where ``value`` (a plain unpacked map) differs from the field set of ``type_name``, recursively."""
    problems = []
    spec = get_spec(type_name)
    if not isinstance(value, dict):
        return [f"{path or type_name}: not a map"]
    expected = [f.name for f in spec.fields]
    if sorted(value) != sorted(expected):
        problems.append(f"{path or type_name}: fields {sorted(value)} != schema {sorted(expected)}")
    for f in spec.fields:
        if f.is_primitive or f.name not in value:
            continue
        items = value[f.name] if f.is_array else [value[f.name]]
        for i, item in enumerate(items[:3]):
            problems += schema_fields(f.base, item, f"{path}{f.name}[{i}]." if f.is_array else f"{path}{f.name}.")
    return problems


def thread_cpus(launcher_pid: int) -> list[tuple[str, int, int, set[int]]]:
    """(process name, pid, thread id, allowed CPUs) of every thread of the launch's process tree."""
    out = []
    for proc in [psutil.Process(launcher_pid), *psutil.Process(launcher_pid).children(recursive=True)]:
        try:
            cmd = proc.cmdline()
            name = cmd[cmd.index("--name") + 1] if "--name" in cmd else proc.name()
            for thread in proc.threads():
                out.append((name, proc.pid, thread.id, set(os.sched_getaffinity(thread.id))))
        except (psutil.Error, ProcessLookupError):
            continue   # a spawner that just ended
    return out


def run_main_job(port: int, log_dir: Path) -> tuple[dict[tuple[int, int], list[float]], list[str], dict[str, bytes],
                                                    str, list[tuple[str, int, int, set[int]]], dict[str, dict]]:
    """Launch paused, unpause when the controllers are active, record joint_states until RECORD_UNTIL (and the
    IMU's and a foot sensor's messages by stamp)."""
    launch = Launch("humanoid.yaml", "mode:=lockstep", "paused:=true", "world:=simple_lab.world", log_dir=log_dir,
                    port=port)
    session = None
    try:
        launch.wait_output(Launch.ROUTER_UP, 60)
        deadline = time.monotonic() + 60
        session = client_session(port)
        joint_states = session.declare_subscriber("humanoid/joint_states", zenoh.handlers.FifoChannel(100_000))
        samples: dict[str, bytes] = {}
        hot = [session.declare_subscriber(key, lambda s, k=key: samples.setdefault(k, s.payload.to_bytes()))
               for key in HOT_KEYS if key != "humanoid/joint_states" and key not in SENSOR_KEYS]
        # buffered, read after the run: a subscriber decoding 2 kHz in its callback falls behind on a loaded
        # machine, and in lockstep every message is delivered, so the controller manager would wait for it
        sensor_subs = {key: session.declare_subscriber(key, zenoh.handlers.FifoChannel(100_000))
                       for key in SENSOR_KEYS}
        # every controller active and the commander up before the first step
        while True:
            launch.check()
            assert time.monotonic() < deadline, launch.output()
            listed = call(session, "humanoid/controller_manager/list_controllers", {}, timeout=1.0)
            states = {c["name"]: c["state"] for c in (listed or {}).get("controller", [])}
            if (all(states.get(name) == "active" for name in ACTIVE)
                    and "Joint Commander initialized" in launch.output() and "sensors humanoid::camera" in
                    launch.output()):
                break
            time.sleep(0.2)
        assert call(session, "sim/unpause_physics", {}) is not None
        trajectory: dict[tuple[int, int], list[float]] = {}
        names: list[str] = []
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            raw = joint_states.recv().payload.to_bytes()
            samples.setdefault("humanoid/joint_states", raw)
            msg = msgpack.unpackb(raw)
            stamp = msg["header"]["stamp"]
            names = msg["name"]
            trajectory[(stamp["sec"], stamp["nanosec"])] = msg["position"]
            if stamp["sec"] + stamp["nanosec"] * 1e-9 >= RECORD_UNTIL:
                break
        assert names and len(names) == 22
        sensors: dict[str, dict] = {key: {} for key in SENSOR_KEYS}
        for key, sub in sensor_subs.items():
            # up to RECORD_UNTIL as joint_states: the sensors' last messages may still be on their way
            newest, until = 0.0, time.monotonic() + 30
            while newest < RECORD_UNTIL and time.monotonic() < until:
                sample = sub.try_recv()
                if sample is None:
                    time.sleep(0.01)
                    continue
                raw = sample.payload.to_bytes()
                samples.setdefault(key, raw)
                msg = msgpack.unpackb(raw)
                stamp = msg["header"]["stamp"]
                newest = stamp["sec"] + stamp["nanosec"] * 1e-9
                if newest <= RECORD_UNTIL:
                    sensors[key][(stamp["sec"], stamp["nanosec"])] = msg
            sub.undeclare()
        time.sleep(1.2)   # the simulator moves threads started after its claim off the CPU once a second
        threads = thread_cpus(launch.proc.pid)
        for sub in hot:
            sub.undeclare()
        joint_states.undeclare()
        return trajectory, names, samples, launch.output(), threads, sensors
    finally:
        if session is not None:
            session.close()
        launch.close()


@pytest.mark.slow
def test_lockstep_main_job_is_bit_identical_and_hot_paths_follow_the_schema(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first, names, samples, log, threads, first_sensors = run_main_job(free_port(), tmp_path / "a")

    # exclusive_cpu: the stepping thread (the simulator's main thread) alone on the kept CPU
    if len(os.sched_getaffinity(0)) >= 2:
        assert "another launch on this machine keeps a CPU" not in log, \
            "another lockstep launch was running on this machine (it held the CPU reservation): stop it and rerun"
        stepping = [cpus for name, pid, tid, cpus in threads if name == "simulator" and tid == pid]
        assert len(stepping) == 1 and len(stepping[0]) == 1, f"simulator's stepping thread: {threads}"
        (cpu,) = stepping[0]
        assert f"CPU {cpu} kept for the stepping thread of 'simulator'" in log
        intruders = [(name, tid) for name, pid, tid, cpus in threads
                     if cpu in cpus and not (name == "simulator" and tid == pid)]
        assert not intruders, f"threads allowed on the simulator's CPU {cpu}: {intruders}"
        assert len(threads) > 40, threads   # the whole tree was seen (router, nodes, their Zenoh threads)
    else:
        assert "only one CPU available; not reserved" in log

    # the hot paths: complete schema maps for a third-party unpackb, accepted by the schema decoder
    assert sorted(samples) == sorted(HOT_KEYS), f"no message on {set(HOT_KEYS) - set(samples)}"
    for key, type_name in HOT_KEYS.items():
        assert not schema_fields(type_name, msgpack.unpackb(samples[key])), (key, schema_fields(
            type_name, msgpack.unpackb(samples[key])))
        msgs.decode(msgs.get_type(type_name), samples[key])

    # the run did something: the knee bend of the commander, sent at 4.0 s and stamped to start at 4.2 s
    assert "Sent command (pose 1)" in log
    stamps = sorted(first)
    knee = names.index("left_knee")
    late = [first[s][knee] for s in stamps if s[0] + s[1] * 1e-9 > 5.0]
    assert late and max(late) > 0.3, f"the knees did not bend: {late[-3:]}"
    assert len(stamps) > 5000, f"only {len(stamps)} joint_states in {RECORD_UNTIL} sim s"

    second, _, _, second_log, _, second_sensors = run_main_job(free_port(), tmp_path / "b")
    common = sorted(set(first) & set(second))
    assert len(common) > 0.99 * len(first), "the two runs published different stamps"
    differing = [s for s in common if first[s] != second[s]]
    holds = [line for line in (log + second_log).splitlines() if "no hardware/command" in line]
    assert not differing, (f"{len(differing)} of {len(common)} joint states differ, first at {differing[0]}; "
                           f"simulator holds: {holds[:3]}")
    # the sensors too, noise and all: the same readings at the same stamps
    for key, fewest in SENSOR_KEYS.items():
        stamps = sorted(set(first_sensors[key]) & set(second_sensors[key]))
        assert len(stamps) > 0.99 * len(first_sensors[key]) >= 0.99 * fewest, (key, len(stamps),
                                                                               len(first_sensors[key]))
        differing = [s for s in stamps if first_sensors[key][s] != second_sensors[key][s]]
        assert not differing, f"{key}: {len(differing)} of {len(stamps)} readings differ, first at {differing[0]}"
    imu = first_sensors["humanoid/imu_sensor_broadcaster/imu"]
    assert len({m["angular_velocity"]["x"] for m in imu.values()}) > 1000   # noisy, not a constant
