"""The humanoid under the controller manager (real simulator, real Zenoh): joint_state_broadcaster + JTC on
all 22 joints, the tutorial's stand <-> knee-bend commands every 2 s keep it standing, and the commanded
positions never step (the first command holds the measured pose, each trajectory continues the last)."""

from __future__ import annotations

import threading

import msgpack
import pytest

import msgs
from nodes.core import Node, cpu, realtime
from nodes.core.delivery import Inline, Raw
from tests.conftest import wait_until

pytestmark = pytest.mark.slow

JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")
JointState = msgs.get_type("sensor_msgs/msg/JointState")
ModelStates = msgs.get_type("gazebo_msgs/msg/ModelStates")
LEGS = ["left_hip_yaw", "left_hip_roll", "left_hip_pitch", "left_knee", "left_ankle_pitch", "left_ankle_roll",
        "right_hip_yaw", "right_hip_roll", "right_hip_pitch", "right_knee", "right_ankle_pitch", "right_ankle_roll"]
STAND = [0.0] * 12
BEND = [0.0, 0.0, -0.2, 0.4, -0.2, 0.0, 0.0, 0.0, -0.2, 0.4, -0.2, 0.0]  # the tutorial's knee bend


def test_stand_knee_bend_cycle_keeps_the_humanoid_standing_with_smooth_commands(processes, router):
    processes.start("-m", "nodes.sim", "--params-file", "config/sim.yaml",
                    "--param", "entities:=[{name: humanoid, file: humanoid, z: 0.93}]", name="sim")
    manager = processes.start("-m", "nodes.control", "--ns", "humanoid", "--params-file", "config/controllers.yaml",
                              "--param", "activate:=[joint_state_broadcaster, joint_trajectory_controller]",
                              name="controller_manager")
    node = Node("humanoid_test_client", connect=[router])
    lock = threading.Lock()
    commands: list[dict[str, float]] = []
    heights: list[float] = []
    states: list[tuple[float, dict[str, float]]] = []

    def on_command(payload: bytes) -> None:
        frame = msgpack.unpackb(payload)
        with lock:
            commands.append({n: v for n, k, v in zip(frame["name"], frame["interface"], frame["value"], strict=True)
                             if k == "position"})

    def on_models(msg) -> None:
        if "humanoid" in msg.name:
            with lock:
                heights.append(msg.pose[msg.name.index("humanoid")].position.z)

    def on_state(msg) -> None:
        with lock:
            states.append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, dict(zip(msg.name, msg.position,
                                                                                             strict=True))))

    try:
        node.create_subscription(None, "/humanoid/hardware/command", on_command,
                                 delivery=Inline(), message=Raw())
        node.create_subscription(ModelStates, "/sim/model_states", on_models, delivery=Inline())
        node.create_subscription(JointState, "/humanoid/joint_states", on_state, delivery=Inline())
        pub = node.create_publisher(JointTrajectory, "/humanoid/joint_trajectory_controller/joint_trajectory")

        def sim_time() -> float:
            with lock:
                return states[-1][0] if states else 0.0

        def run_until(t: float) -> None:
            wait_until(lambda: sim_time() >= t, timeout=180, interval=0.05, message=f"sim time {t:.1f} s")

        wait_until(lambda: states and heights, timeout=90, message="joint_states and model_states")
        wait_until(lambda: "controller manager ready" in processes.output(manager), timeout=30,
                   message="controller manager ready")
        t0 = sim_time()
        run_until(t0 + 1.0)  # settle on the feet
        with lock:
            standing = sorted(heights[-20:])[len(heights[-20:]) // 2]
            first_command = next(c for c in commands if c)
        assert standing > 0.8, standing
        # The first JTC command holds the pose the robot had: no jump at activation.
        assert all(abs(v) < 0.05 for v in first_command.values()), first_command

        for i in range(4):  # the tutorial's joint_commander: alternate poses every 2 s
            positions = BEND if i % 2 == 0 else STAND
            pub.publish(msgs.from_dict(JointTrajectory, {"joint_names": LEGS, "points": [
                {"positions": positions, "time_from_start": {"sec": 1, "nanosec": 0}}]}))
            run_until(t0 + 1.0 + 2.0 * (i + 1))
            if i == 0:
                with lock:
                    knee = states[-1][1]["left_knee"]
                assert abs(knee - 0.4) < 0.05, knee  # the knee bend really happened
        with lock:
            lowest = min(heights[len(heights) // 10:])
            history = list(commands)
        assert lowest > 0.9 * standing, (lowest, standing)
        # Per-cycle change of every commanded position: a 0.4 rad move over 1 s is 0.0004 rad per 1 ms cycle.
        worst = 0.0
        for before, after in zip(history, history[1:], strict=False):
            for joint, value in after.items():
                if joint in before:
                    worst = max(worst, abs(value - before[joint]))
        assert worst < 0.005, worst
        assert len(history) > 5000
    finally:
        node.destroy()


@pytest.mark.parametrize("mode, params, policy", [("realtime", None, ("fifo", 50)), ("lockstep", None, ("other", 0)),
                                                  ("realtime", "thread_priority: 0", ("other", 0))])
def test_thread_priority_raises_every_manager_thread_against_realtime_hardware(processes, tmp_path, mode, params,
                                                                                policy):
    """ros2_control's thread_priority (default 50): against realtime hardware every thread of the manager,
    Zenoh's included and those started with the controllers after start-up, runs at SCHED_FIFO 50.
    Lockstep keeps the manager busy as long as the physics runs: at FIFO it would starve the processes
    sharing its CPU, so it keeps normal priority; thread_priority: 0 from a params file switches it off."""
    argv = ["--params-file", "config/controllers.yaml"]
    if params:
        (tmp_path / "cm.yaml").write_text(f"controller_manager:\n  ros__parameters:\n    {params}\n")
        argv += ["--params-file", str(tmp_path / "cm.yaml")]
    processes.start("-m", "nodes.sim", "--params-file", "config/sim.yaml", "--param", f"mode:={mode}",
                    "--param", "entities:=[{name: humanoid, file: humanoid, z: 0.93}]", name="sim")
    manager = processes.start("-m", "nodes.control", "--ns", "humanoid", *argv, name="controller_manager")
    wait_until(lambda: "controller manager ready" in processes.output(manager), timeout=60,
               message="controller manager ready")
    assert {realtime.policy_of(tid) for tid in cpu.thread_ids(manager.pid)} == {policy}
    output = processes.output(manager)
    assert ("threads at SCHED_FIFO priority 50 (thread_priority)" in output) == (policy[0] == "fifo")
    assert ("lockstep hardware: threads at normal priority" in output) == (mode == "lockstep")
