"""The tutorials' rclpy programs (../shared/seed-code, copied unchanged into tests/data/seeds) run against a
live job laid out as the tutorials expect: the robot at the root namespace (``/joint_states``,
``/joint_trajectory_controller/...``), simulator and controller manager as real processes over real Zenoh.

Where a listing fails on a real ROS 2 too (seed-code/README.md), it fails here the same way, with the same
exception type; then it runs with the one-line fix a user would make."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import pytest

import msgs
from nodes.core import Node
from nodes.core.delivery import Inline
from tests.conftest import ROOT, wait_until
from tests.support.ros_shim import shim_env

pytestmark = pytest.mark.slow

SEEDS = ROOT / "tests" / "data" / "seeds"
JointState = msgs.get_type("sensor_msgs/msg/JointState")
GoalStatusArray = msgs.get_type("action_msgs/msg/GoalStatusArray")


@pytest.fixture
def ros_env(tmp_path: Path) -> dict[str, str]:
    from bench.common import child_env

    return shim_env(tmp_path / "shim", child_env()["PYTHONPATH"])


def start_robot(processes, robot: str, namespace: str, controllers_yaml: str, controllers: list[str]) -> None:
    """``robot`` spawned with its namespace (``/``: the root), its controller manager there, ``controllers``
    loaded and activated by the spawner from ``controllers_yaml``."""
    processes.start("-m", "nodes.sim", "--params-file", "config/sim.yaml", "--param", "sensors:=false",
                    "--param", f"entities:=[{{name: {robot}, file: {robot}, namespace: '{namespace}', fixed: "
                    f"{'false' if robot == 'humanoid' else 'true'}}}]", name="sim")
    ns = namespace.strip("/")
    manager = processes.start("-m", "nodes.control", *(["--ns", ns] if ns else []), name="controller_manager")
    spawner = subprocess.run(
        [sys.executable, "-m", "nodes.tools.cli", "control", "spawner", *controllers, "--ns", ns,
         "--param-file", controllers_yaml, "--controller-manager-timeout", "90"],
        capture_output=True, text=True, env=processes.env(), cwd=ROOT, timeout=180)
    assert spawner.returncode == 0, spawner.stderr + processes.output(manager)[-3000:]


class Positions:
    """The latest joint positions on a joint_states topic."""

    def __init__(self, router: str, topic: str = "/joint_states") -> None:
        self.latest: dict[str, float] = {}
        self.lock = threading.Lock()
        self.node = Node("seed_test_watcher", connect=[router])
        self.node.create_subscription(JointState, topic, self._on, delivery=Inline())

    def _on(self, msg) -> None:
        with self.lock:
            self.latest.update(zip(msg.name, msg.position, strict=True))

    def get(self, joint: str) -> float | None:
        with self.lock:
            return self.latest.get(joint)

    def close(self) -> None:
        self.node.destroy()


def run_program(processes, path: Path, *args: str, env: dict[str, str], name: str):
    return processes.start(str(path), *args, name=name, env=env)


def one_line_fix(tmp_path: Path, source: Path, old: str, new: str) -> Path:
    text = source.read_text()
    assert text.count(old) >= 1, f"{old!r} not in {source}"
    fixed = tmp_path / source.name
    fixed.write_text(text.replace(old, new))
    return fixed


def test_000_joint_commander_bends_the_knees(processes, router, ros_env) -> None:
    start_robot(processes, "humanoid", "/", "config/controllers.yaml",
                ["joint_state_broadcaster", "joint_trajectory_controller"])
    positions = Positions(router)
    try:
        # use_sim_time, as every node beside a simulator runs: the commander's stamps are then sim time
        commander = run_program(processes, SEEDS / "000_joint_commander.py", "--ros-args", "-p",
                                "use_sim_time:=true", env=ros_env, name="joint_commander")
        wait_until(lambda: all((positions.get(k) or 0.0) > 0.3 for k in ("left_knee", "right_knee")), timeout=90,
                   interval=0.1, message="the knee bend (0.4 rad) reaching the robot\n"
                   + processes.output(commander)[-2000:])
        assert "Sent command (pose 1)" in processes.output(commander)
    finally:
        positions.close()


def test_001_fails_as_on_ros2_then_drives_the_four_limbs(processes, router, ros_env, tmp_path) -> None:
    # as written: rclpy.node is used after only `import rclpy` -> AttributeError, as on ROS 2
    for program in ("001_wave_controller.py", "001_robot_monitor.py"):
        done = subprocess.run([sys.executable, str(SEEDS / program)], capture_output=True, text=True,
                              env=processes.env(ros_env), timeout=60)
        assert done.returncode == 1, done.stdout + done.stderr
        assert "AttributeError: module 'rclpy' has no attribute 'node'" in done.stderr, done.stderr
    start_robot(processes, "lab_robot", "/", "config/lab_2_3_controllers.yaml",
                ["joint_state_broadcaster", "left_arm_controller", "right_arm_controller", "left_leg_controller",
                 "right_leg_controller"])
    positions = Positions(router)
    try:
        fix = ("import rclpy\n", "import rclpy\nimport rclpy.node\n")   # the user's one-line fix
        wave = run_program(processes, one_line_fix(tmp_path, SEEDS / "001_wave_controller.py", *fix),
                           env=ros_env, name="wave")
        monitor = run_program(processes, one_line_fix(tmp_path, SEEDS / "001_robot_monitor.py", *fix),
                              env=ros_env, name="monitor")
        moved: dict[str, float] = {}

        def every_limb_moved() -> bool:
            for joint in ("left_arm_joint", "right_arm_joint", "left_leg_joint", "right_leg_joint"):
                value = positions.get(joint)
                if value is not None:
                    moved[joint] = max(moved.get(joint, 0.0), abs(value))
            return len(moved) == 4 and all(v > 0.2 for v in moved.values())

        wait_until(every_limb_moved, timeout=90, interval=0.1,
                   message=f"the four limbs waving (max |q| {moved})\n" + processes.output(wave)[-2000:])
        wait_until(lambda: "left_arm_joint: pos=" in processes.output(monitor), timeout=30,
                   message="the monitor logging /joint_states\n" + processes.output(monitor)[-2000:])
        wait_until(lambda: "Left arm: " in processes.output(wave), timeout=30,
                   message="the wave controller logging the left arm")
    finally:
        positions.close()


def test_002_managed_motor_controller_walked_by_zenroid_lifecycle(processes, ros_env) -> None:
    # the listing is a class only: started the way a user would, with the usual three lines of main
    node = processes.start("-c", "import runpy, rclpy; rclpy.init(); "
                           f"cls = runpy.run_path({str(SEEDS / '002_managed_motor_controller.py')!r})"
                           "['ManagedMotorController']; rclpy.spin(cls())", name="motor_controller", env=ros_env)

    def lifecycle(*args: str) -> str:
        done = subprocess.run([sys.executable, "-m", "nodes.tools.cli", "lifecycle", *args], capture_output=True,
                              text=True, env=processes.env(), cwd=ROOT, timeout=60)
        assert done.returncode == 0, done.stdout + done.stderr + processes.output(node)[-2000:]
        return done.stdout

    wait_until(lambda: "/motor_controller" in subprocess.run(
        [sys.executable, "-m", "nodes.tools.cli", "lifecycle", "nodes"], capture_output=True, text=True,
        env=processes.env(), cwd=ROOT, timeout=60).stdout, timeout=30, message="the managed node listed")
    assert "unconfigured" in lifecycle("get", "/motor_controller")
    for transition, line in (("configure", "Configuring..."), ("activate", "Activating..."),
                             ("deactivate", "Deactivating..."), ("cleanup", "Cleaning up..."),
                             ("shutdown", "Shutting down...")):
        lifecycle("set", "/motor_controller", transition)   # exits 2 unless the transition succeeded
        assert line in processes.output(node)
    assert "finalized" in lifecycle("get", "/motor_controller")


def test_003_position_and_pid_controllers_run(processes, router, ros_env) -> None:
    start_robot(processes, "simple_robot", "simple_robot", "config/controller_lab_controllers.yaml",
                ["joint_state_broadcaster", "joint_group_position_controller"])
    positions = Positions(router, "/simple_robot/joint_states")
    try:
        position = run_program(processes, SEEDS / "003_position_controller.py", env=ros_env, name="position")
        wait_until(lambda: (positions.get("joint1") or 0.0) > 1.5, timeout=90, interval=0.1,
                   message="joint1 at the position controller's 1.57 rad\n" + processes.output(position)[-2000:])
        # the program logs the position once its subscription has a joint state, which on a loaded machine
        # can come after its commands moved the arm
        wait_until(lambda: "Published commands: [1.57], Current pos: joint1: " in processes.output(position),
                   timeout=30, message="the position controller's log of joint1\n" + processes.output(position)[-2000:])
        pid = run_program(processes, SEEDS / "003_pid_controller.py", env=ros_env, name="pid")
        wait_until(lambda: "Joint1: Target=1.570, Current=" in processes.output(pid), timeout=60,
                   message="the PID node's control loop\n" + processes.output(pid)[-2000:])
    finally:
        positions.close()


def _rosidl_setters() -> bool:
    """Do the message classes check field types on assignment, as rosidl_python's do (AssertionError)?"""
    done = subprocess.run([sys.executable, "-c", "import sys, msgs\ntry:\n    msgs.get_type("
                           "'builtin_interfaces/msg/Duration')(sec=1, nanosec=0.0)\nexcept AssertionError:\n"
                           "    sys.exit(3)"], capture_output=True, env=_child_env(), timeout=60)
    return done.returncode == 3


def _child_env() -> dict[str, str]:
    from bench.common import child_env

    return child_env()


# Runs a listing as __main__ and reports the exception that ended it with its classes (rclpy's own
# AssertionError comes from rosidl's setters; ours may be a subclass that also names the field).
_REPORT = ("import runpy, sys, rclpy.action\n"
           "rclpy.action.ActionClient.wait_for_server = lambda self, timeout_sec=None: True\n"
           "try:\n    runpy.run_path(sys.argv[1], run_name='__main__')\n"
           "except BaseException as e:\n"
           "    print('ENDED', [c.__name__ for c in type(e).__mro__], e)\n    sys.exit(1)\n")


@pytest.mark.skipif(not _rosidl_setters(), reason="the message classes do not yet check types on assignment")
def test_003_float_nanosec_fails_as_on_ros2(processes, ros_env) -> None:
    # as written: Duration(nanosec=<float>) -> AssertionError from the message's setter, as on ROS 2
    for program in ("003_trajectory_sender.py", "003_trajectory_controller.py"):
        done = subprocess.run([sys.executable, "-c", _REPORT, str(SEEDS / program)], capture_output=True,
                              text=True, env=processes.env(ros_env), timeout=60)
        assert done.returncode == 1, done.stdout + done.stderr
        ended = [line for line in done.stdout.splitlines() if line.startswith("ENDED")]
        assert ended and "'AssertionError'" in ended[-1] and "nanosec" in ended[-1], done.stdout + done.stderr


def test_003_trajectory_sender_goal_succeeds_with_the_fix(processes, router, ros_env, tmp_path) -> None:
    start_robot(processes, "simple_robot", "/", "config/controller_lab_controllers.yaml",
                ["joint_state_broadcaster", "joint_trajectory_controller"])
    statuses: list[int] = []
    watcher = Node("seed_status_watcher", connect=[router])
    watcher.create_subscription(
        GoalStatusArray, "/joint_trajectory_controller/follow_joint_trajectory/status",
        lambda m: statuses.extend(s.status for s in m.status_list), delivery=Inline())
    try:
        fixed = one_line_fix(tmp_path, SEEDS / "003_trajectory_sender.py", "nanosec=(t % 1) * 1e9",
                             "nanosec=int((t % 1) * 1e9)")
        sender = run_program(processes, fixed, env=ros_env, name="sender_fixed")
        wait_until(lambda: 4 in statuses, timeout=120, interval=0.2,
                   message=f"the goal SUCCEEDED (statuses {sorted(set(statuses))})\n"
                   + processes.output(sender)[-2000:])
        assert "Sending sine trajectory with 100 points" in processes.output(sender)
    finally:
        watcher.destroy()
