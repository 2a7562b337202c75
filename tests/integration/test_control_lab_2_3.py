"""Lab 2.3: four trajectory controllers of one type side by side on lab_robot, spawned by the spawner with
``--param-file`` into a controller manager that started without any controller YAML."""

from __future__ import annotations

import subprocess
import sys
import threading

import pytest

import msgs
from nodes.core import Node
from nodes.core.delivery import Inline
from tests.conftest import ROOT, wait_until

pytestmark = pytest.mark.slow

JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")
JointState = msgs.get_type("sensor_msgs/msg/JointState")
TARGETS = {"left_arm_controller": ("left_arm_joint", 1.0), "right_arm_controller": ("right_arm_joint", -1.0),
           "left_leg_controller": ("left_leg_joint", 0.5), "right_leg_controller": ("right_leg_joint", -0.5)}


def test_four_limb_controllers_side_by_side(processes, router):
    processes.start("-m", "nodes.sim", "--params-file", "config/sim.yaml",
                    "--param", "entities:=[{name: lab_robot, file: lab_robot, fixed: true}]", name="sim")
    manager = processes.start("-m", "nodes.control", "--ns", "lab_robot", name="controller_manager")
    names = ["joint_state_broadcaster", *TARGETS]
    spawner = subprocess.run(
        [sys.executable, "-m", "nodes.tools.cli", "control", "spawner", *names, "--ns", "lab_robot",
         "--param-file", "config/lab_2_3_controllers.yaml", "--controller-manager-timeout", "90"],
        capture_output=True, text=True, env=processes.env(), cwd=ROOT, timeout=180)
    assert spawner.returncode == 0, spawner.stderr + processes.output(manager)
    node = Node("lab_2_3_test_client", connect=[router])
    latest: dict[str, float] = {}
    lock = threading.Lock()

    def on_state(msg) -> None:
        with lock:
            latest.update(zip(msg.name, msg.position, strict=True))

    try:
        node.create_subscription(JointState, "/lab_robot/joint_states", on_state, delivery=Inline())
        wait_until(lambda: len(latest) == 4, timeout=30, message="joint_states of the four limbs")
        pubs = {c: node.create_publisher(JointTrajectory, f"/lab_robot/{c}/joint_trajectory") for c in TARGETS}

        def reached() -> bool:
            for controller, (joint, target) in TARGETS.items():
                pubs[controller].publish(msgs.from_dict(JointTrajectory, {"joint_names": [joint], "points": [
                    {"positions": [target], "time_from_start": {"sec": 1, "nanosec": 0}}]}))
            with lock:
                return all(abs(latest[j] - t) < 0.02 for j, t in TARGETS.values())

        try:
            wait_until(reached, timeout=90, interval=0.5, message="every limb at its own target")
        except BaseException:   # say where each limb was (pytest.fail raises an exception outside Exception)
            with lock:
                where = {j: round(latest[j], 3) for j, _ in TARGETS.values()}
            print(f"limbs at {where}, targets {dict(TARGETS.values())}\n" + processes.output(manager)[-3000:])
            raise
        # A controller only accepts its own joint.
        pubs["left_arm_controller"].publish(msgs.from_dict(JointTrajectory, {"joint_names": ["right_arm_joint"],
                                            "points": [{"positions": [0.0], "time_from_start": {"sec": 1}}]}))
        wait_until(lambda: "unknown joint 'right_arm_joint'" in processes.output(manager), timeout=20,
                   message="cross-limb trajectory rejected")
    finally:
        node.destroy()
