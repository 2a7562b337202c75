"""Controllers and the manager driven in-process against a toy plant (no Zenoh): JTC, forward, PID,
broadcaster, interface claiming, crash isolation, the tutorials' YAML."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

import msgs
from nodes.control.config import ConfigError, load_config_file, parse_config
from nodes.control.controller import Controller
from nodes.control.controllers import CONTROLLER_TYPES
from nodes.control.controllers.joint_trajectory_controller import (
    GOAL_TOLERANCE_VIOLATED,
    INVALID_GOAL,
    PATH_TOLERANCE_VIOLATED,
    SUCCESSFUL,
)
from nodes.control.manager import BEST_EFFORT, STRICT, ControllerManager, ManagerError
from tests.support.control import FakeContext, FirstOrderPlant, ListLogger, make_hardware

ROOT = Path(__file__).resolve().parents[2]
JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")
Float64MultiArray = msgs.get_type("std_msgs/msg/Float64MultiArray")
FJT = msgs.get_type("control_msgs/action/FollowJointTrajectory")
SUCCEEDED, CANCELED, ABORTED = 4, 5, 6

LAB_YAML = (ROOT / "config" / "controller_lab_controllers.yaml").read_text()


class Rig:
    """Manager + fake contexts + first-order plant, stepped on a simulated clock."""

    def __init__(self, config_text: str, joints: list[str], command_interfaces=("position",), rate: int = 100,
                 tau: float = 0.02, limits: dict | None = None) -> None:
        self.hw = make_hardware(joints, command_interfaces, limits)
        self.contexts: dict[str, FakeContext] = {}
        self.logger = ListLogger()
        self.manager = ControllerManager(self.hw, parse_config(yaml.safe_load(config_text)), rate,
                                         self._context, self.logger)
        self.plant = FirstOrderPlant(self.hw, tau=tau)
        self.dt = 1.0 / rate
        self.t = 0.0
        self.sent: list[tuple[list[str], list[str], list[float]]] = []
        self.plant.publish_state()

    def _context(self, name: str) -> FakeContext:
        ctx = FakeContext(name)
        ctx.logger = self.logger
        ctx.time = self.t
        self.contexts[name] = ctx
        return ctx

    def spawn(self, *names: str, activate: bool = True) -> None:
        for name in names:
            self.manager.load(name)
            self.manager.configure(name)
        if activate:
            ok, message = self.manager.switch(list(names), [], STRICT)
            assert ok, message

    def step(self, seconds: float) -> None:
        for _ in range(max(1, int(round(seconds / self.dt)))):
            self.plant.publish_state()
            for ctx in self.contexts.values():
                ctx.time = self.t
            self.manager.update(self.t, self.dt)
            command = self.manager.command()
            self.sent.append(command)
            self.plant.apply(*command, self.dt)
            self.t += self.dt

    def controller(self, name: str) -> Controller:
        return self.manager.controllers[name].controller

    def publish(self, topic: str, msg) -> None:
        for ctx in self.contexts.values():
            if topic in ctx.subscriptions:
                ctx.subscriptions[topic](msg)
                return
        raise KeyError(topic)

    def send_goal(self, controller: str, goal_dict: dict):
        server = self.contexts[controller].actions[f"{controller}/follow_joint_trajectory"]
        return server.send_goal(msgs.from_dict(FJT.Goal, goal_dict))


def trajectory(joints, points, stamp=None) -> dict:
    out = {"joint_names": joints, "points": [
        {"positions": p, "time_from_start": {"sec": int(t), "nanosec": int(round((t % 1) * 1e9))}} for t, p in points]}
    if stamp is not None:
        out["header"] = {"stamp": {"sec": int(stamp), "nanosec": int(round((stamp % 1) * 1e9))}}
    return out


def lab_rig(**kwargs) -> Rig:
    rig = Rig(LAB_YAML, ["joint1"], ("position", "velocity"), **kwargs)
    rig.spawn("joint_state_broadcaster", "joint_trajectory_controller")
    return rig


# --- configuration ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["controllers.yaml", "controller_lab_controllers.yaml", "lab_2_3_controllers.yaml",
                                  "atlas_controllers.yaml", "humanoid_simplified_controllers.yaml"])
def test_every_robot_config_loads_and_names_known_types(name):
    config = load_config_file(ROOT / "config" / name)
    assert config.update_rate and config.controllers
    for cfg in config.controllers.values():
        assert cfg.type in CONTROLLER_TYPES, cfg


def test_tutorial_yaml_loads_unchanged():
    # Seed 003's simple_robot_controllers.yaml, verbatim (comments included).
    text = """
controller_manager:
  ros__parameters:
    update_rate: 100 # Hz

    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster

    joint_trajectory_controller:
      type: joint_trajectory_controller/JointTrajectoryController

joint_trajectory_controller:
  ros__parameters:
    command_interfaces:
      - position
    state_interfaces:
      - position
      - velocity
    joints:
      - joint1
    state_publish_rate: 50.0
    action_monitor_rate: 20.0
    allow_partial_joints_goal: false
    constraints:
      stopped_velocity_tolerance: 0.01
      goal_time: 0.0
      joint1:
        trajectory: 0.05
        goal: 0.01
"""
    rig = Rig(text, ["joint1"], ("position", "velocity"))
    rig.spawn("joint_state_broadcaster", "joint_trajectory_controller")
    jtc = rig.controller("joint_trajectory_controller")
    assert jtc.params.constraints.per_joint["joint1"].goal == 0.01
    assert rig.manager.update_rate == 100


@pytest.mark.parametrize("text, reason", [
    ("controller_manager: {ros__parameters: {update_rate: -5}}", "update_rate"),
    ("controller_manager: {ros__parameters: {jtc: {type: 7}}}", "jtc.type"),
    ("- a\n- b", "top level"),
    ("jtc: {params: 1}", "ros__parameters"),
])
def test_bad_config_is_refused_naming_the_key(text, reason):
    with pytest.raises(ConfigError, match=reason.replace(".", r"\.")):
        parse_config(yaml.safe_load(text))


def test_bad_parameter_value_refuses_load_with_the_name():
    text = LAB_YAML.replace("state_publish_rate: 50.0", "state_publish_rate: fast")
    rig = Rig(text, ["joint1"], ("position", "velocity"))
    with pytest.raises(ManagerError, match="state_publish_rate"):
        rig.manager.load("joint_trajectory_controller")


def test_unknown_joint_refuses_configure():
    text = LAB_YAML.replace("      - joint1\n    state_publish_rate", "      - joint9\n    state_publish_rate")
    rig = Rig(text, ["joint1"], ("position", "velocity"))
    rig.manager.load("joint_trajectory_controller")
    with pytest.raises(ManagerError, match="joint9/position"):
        rig.manager.configure("joint_trajectory_controller")
    assert rig.manager.controllers["joint_trajectory_controller"].state == "unconfigured"


# --- JTC --------------------------------------------------------------------------------------------------
def test_jtc_holds_position_on_activation_and_goal_reaches_target():
    rig = lab_rig()
    rig.plant.pos["joint1"] = 0.3
    rig.step(0.05)
    assert rig.sent[-1] == (["joint1"], ["position"], [pytest.approx(0.3)])  # hold, no jump
    ok, reason, handle = rig.send_goal("joint_trajectory_controller",
                                       {"trajectory": trajectory(["joint1"], [(3.0, [1.57])])})
    assert ok, reason
    rig.step(3.5)
    assert handle.status == SUCCEEDED and handle.result.error_code == SUCCESSFUL
    assert abs(rig.plant.pos["joint1"] - 1.57) < 0.01
    assert handle.feedback and list(handle.feedback[-1].joint_names) == ["joint1"]
    # feedback at action_monitor_rate (20 Hz) over ~3 s of sim time
    assert 40 <= len(handle.feedback) <= 80
    assert handle.feedback[-1].error.positions[0] == pytest.approx(
        handle.feedback[-1].desired.positions[0] - handle.feedback[-1].actual.positions[0])
    # controller_state at state_publish_rate (50 Hz over 3.55 s), decodable as its type
    states = rig.contexts["joint_trajectory_controller"].publishers["joint_trajectory_controller/controller_state"]
    assert 170 <= len(states.messages) <= 180
    last = states.messages[-1]
    assert list(last.joint_names) == ["joint1"] and last.reference.positions[0] == pytest.approx(1.57)
    assert last.feedback.positions[0] == pytest.approx(rig.plant.pos["joint1"], abs=0.01)


def test_jtc_first_command_after_a_new_trajectory_continues_the_previous_one():
    rig = lab_rig()
    rig.publish("joint_trajectory_controller/joint_trajectory",
                msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(1.0, [1.0])])))
    rig.step(0.5)
    before = rig.sent[-1][2][0]
    rig.publish("joint_trajectory_controller/joint_trajectory",
                msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(1.0, [-1.0])])))
    rig.step(0.01)
    after = rig.sent[-1][2][0]
    assert abs(after - before) < 0.02  # continues from the last command, no step to -1


def test_jtc_goal_tolerance_violation_is_reported():
    rig = lab_rig(tau=0.5)  # a sluggish joint that cannot settle within 0.2 s
    ok, _, handle = rig.send_goal("joint_trajectory_controller", {
        "trajectory": trajectory(["joint1"], [(0.5, [1.0])]),
        "path_tolerance": [{"name": "joint1", "position": -1.0}],  # -1: path not checked
        "goal_tolerance": [{"name": "joint1", "position": 0.0001}],
        "goal_time_tolerance": {"sec": 0, "nanosec": 200_000_000}})
    assert ok
    rig.step(1.0)
    assert handle.status == ABORTED and handle.result.error_code == GOAL_TOLERANCE_VIOLATED
    assert "joint1" in handle.result.error_string


def test_jtc_path_tolerance_violation_aborts_and_holds():
    rig = lab_rig(tau=0.3)
    ok, _, handle = rig.send_goal("joint_trajectory_controller",
                                  {"trajectory": trajectory(["joint1"], [(0.2, [1.5])])})
    assert ok
    rig.step(0.3)
    assert handle.status == ABORTED and handle.result.error_code == PATH_TOLERANCE_VIOLATED
    held = rig.sent[-1][2][0]
    rig.step(0.2)
    assert rig.sent[-1][2][0] == pytest.approx(held)


def test_jtc_new_goal_preempts_and_cancel_holds_position():
    rig = lab_rig()
    _, _, first = rig.send_goal("joint_trajectory_controller", {"trajectory": trajectory(["joint1"], [(3.0, [1.0])])})
    rig.step(0.5)
    _, _, second = rig.send_goal("joint_trajectory_controller", {"trajectory": trajectory(["joint1"], [(3.0, [-1.0])])})
    rig.step(0.5)
    assert first.status == ABORTED and first.result.error_code == INVALID_GOAL
    assert "preempted" in first.result.error_string
    assert second.status == 2
    second.cancel()
    rig.step(0.02)
    assert second.status == CANCELED
    held = rig.sent[-1][2][0]
    rig.step(1.0)
    assert rig.sent[-1][2][0] == pytest.approx(held)
    assert abs(rig.plant.pos["joint1"] - held) < 0.01


@pytest.mark.parametrize("traj, reason", [
    (trajectory(["nope"], [(1.0, [1.0])]), "unknown joint 'nope'"),
    (trajectory(["joint1"], [(1.0, [1.0, 2.0])]), "expected 1"),
    (trajectory(["joint1"], [(1.0, [1.0]), (0.5, [2.0])]), "increase strictly"),
    (trajectory(["joint1"], [(1.0, [1.0])], stamp=1.0), "ends in the past"),
])
def test_jtc_rejects_invalid_goals_and_topics_and_keeps_the_previous_command(traj, reason):
    rig = lab_rig()
    rig.step(5.0)
    before = rig.sent[-1]
    ok, why, _ = rig.send_goal("joint_trajectory_controller", {"trajectory": traj})
    assert not ok and reason in why
    rig.publish("joint_trajectory_controller/joint_trajectory", msgs.from_dict(JointTrajectory, traj))
    assert reason in rig.logger.text("error")
    rig.step(0.1)
    assert rig.sent[-1] == before


def test_jtc_rejects_nan_positions():
    rig = lab_rig()
    traj = msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(1.0, [0.0])]))
    traj.points[0].positions = [math.nan]  # msgs refuses NaN on the wire; the controller checks too
    rig.publish("joint_trajectory_controller/joint_trajectory", traj)
    assert "not finite" in rig.logger.text("error")


def test_jtc_cmd_timeout_holds_position_after_a_stale_topic_command():
    text = LAB_YAML.replace("allow_partial_joints_goal: false", "allow_partial_joints_goal: false\n    cmd_timeout: 0.5")
    rig = Rig(text, ["joint1"], ("position", "velocity"), tau=0.5)
    rig.spawn("joint_trajectory_controller")
    rig.publish("joint_trajectory_controller/joint_trajectory",
                msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(0.1, [1.0])])))
    rig.step(0.3)
    assert rig.sent[-1][2][0] == pytest.approx(1.0)
    rig.step(0.5)
    assert rig.sent[-1][2][0] < 0.99  # stale: holding where the joint is, not the old target
    assert "timed out" in rig.logger.text("warn")


def test_jtc_sine_trajectory_is_tracked():
    rig = lab_rig(tau=0.01)
    points = [(i * 0.1, [1.57 * math.sin(2 * math.pi * 0.1 * i * 0.1)]) for i in range(100)]
    _, _, handle = rig.send_goal("joint_trajectory_controller", {"trajectory": trajectory(["joint1"], points)})
    errors = []
    for _ in range(1000):
        rig.step(0.01)
        desired = 1.57 * math.sin(2 * math.pi * 0.1 * (rig.t - 0.01))
        errors.append(rig.plant.pos["joint1"] - desired)
    rig.step(0.5)
    assert handle.status == SUCCEEDED, handle.result
    assert math.sqrt(sum(e * e for e in errors) / len(errors)) < 0.05


# --- forward command, PID, broadcaster --------------------------------------------------------------
def test_forward_position_controller_applies_commands_and_rejects_wrong_length():
    rig = Rig(LAB_YAML, ["joint1"], ("position", "velocity"))
    rig.spawn("joint_group_position_controller")
    rig.step(0.1)
    assert rig.sent[-1] == ([], [], [])  # nothing commanded yet: the hardware keeps its own
    rig.publish("joint_group_position_controller/commands", Float64MultiArray(data=[1.57]))
    rig.step(1.0)
    assert rig.plant.pos["joint1"] == pytest.approx(1.57, abs=1e-3)
    rig.publish("joint_group_position_controller/commands", Float64MultiArray(data=[0.0, 1.0]))
    assert "data has 2 values, expected 1" in rig.logger.text("error")
    rig.step(0.5)
    assert rig.plant.pos["joint1"] == pytest.approx(1.57, abs=1e-3)


def test_pid_reaches_target_without_overshoot_on_velocity_interface():
    rig = Rig(LAB_YAML, ["joint1"], ("position", "velocity"))
    rig.spawn("pid_controller")
    rig.publish("pid_controller/reference", Float64MultiArray(data=[1.57]))
    peak = 0.0
    for _ in range(60):
        rig.step(0.1)
        peak = max(peak, rig.plant.pos["joint1"])
    assert rig.sent[-1][1] == ["velocity"]
    assert abs(rig.plant.pos["joint1"] - 1.57) < 0.02 * 1.57
    assert peak < 1.57 * 1.10


def test_pid_antiwindup_limits_the_integral_while_saturated():
    from nodes.control.pid import Pid

    windup = Pid(p=1.0, i=5.0, d=0.0, i_min=-math.inf, i_max=math.inf, u_min=-0.1, u_max=0.1, antiwindup=False)
    guarded = Pid(p=1.0, i=5.0, d=0.0, i_min=-math.inf, i_max=math.inf, u_min=-0.1, u_max=0.1, antiwindup=True)
    for _ in range(100):
        windup.compute(1.0, 0.0, 0.01)
        guarded.compute(1.0, 0.0, 0.01)
    assert windup.i_term == pytest.approx(5.0)
    assert guarded.i_term < 0.2
    clamped = Pid(p=1.0, i=5.0, d=0.0, i_min=-0.3, i_max=0.3, u_min=-math.inf, u_max=math.inf, antiwindup=False)
    for _ in range(100):
        clamped.compute(1.0, 0.0, 0.01)
    assert clamped.i_term == pytest.approx(0.3)


def test_pid_on_several_joints_with_effort_output():
    text = """
controller_manager: {ros__parameters: {update_rate: 1000, pid: {type: pid_controller/PidController}}}
pid:
  ros__parameters:
    joints: [a, b]
    command_interface: effort
    gains:
      a: {p: 20.0, i: 1.0, d: 2.0, i_clamp: 0.5}
      b: {p: 20.0, i: 1.0, d: 2.0, i_clamp: 0.5}
"""
    rig = Rig(text, ["a", "b"], ("effort",), rate=1000)
    rig.spawn("pid")
    rig.publish("pid/reference", Float64MultiArray(data=[0.5, -0.5]))
    rig.step(3.0)
    assert rig.plant.pos["a"] == pytest.approx(0.5, abs=0.01)
    assert rig.plant.pos["b"] == pytest.approx(-0.5, abs=0.01)


def test_joint_state_broadcaster_publishes_every_joint_in_order():
    rig = lab_rig()
    rig.plant.pos["joint1"] = 0.25
    rig.step(0.05)
    pub = rig.contexts["joint_state_broadcaster"].publishers["joint_states"]
    msg = pub.messages[-1]
    assert list(msg.name) == ["joint1"] and msg.position[0] == pytest.approx(0.25)
    assert len(msg.velocity) == 1 and len(msg.effort) == 1
    assert msg.header.stamp.sec == 0 and msg.header.stamp.nanosec > 0


# --- manager ---------------------------------------------------------------------------------------------
def test_interface_conflict_is_refused_with_the_reason():
    rig = lab_rig()
    rig.spawn("joint_group_position_controller", activate=False)
    ok, message = rig.manager.switch(["joint_group_position_controller"], [], STRICT)
    assert not ok and "joint1/position" in message and "joint_trajectory_controller" in message
    ok, message = rig.manager.switch(["joint_group_position_controller"], [], BEST_EFFORT)
    assert not ok and "conflict" in message
    assert rig.manager.controllers["joint_group_position_controller"].state == "inactive"
    # Swapping in one switch is fine.
    ok, message = rig.manager.switch(["joint_group_position_controller"], ["joint_trajectory_controller"], STRICT)
    assert ok, message
    assert rig.manager.claims["joint1/position"] == "joint_group_position_controller"


def test_two_controllers_cannot_command_one_joint_through_different_interfaces():
    """ros2_control's mode-switch check: joint1 commanded by position AND velocity is refused, owner named."""
    rig = lab_rig()  # the JTC holds joint1/position
    rig.spawn("pid_controller", activate=False)  # velocity out on joint1
    for strictness in (STRICT, BEST_EFFORT):
        ok, message = rig.manager.switch(["pid_controller"], [], strictness)
        assert not ok, message
        assert "joint1/velocity" in message and "joint1/position" in message
        assert "'joint_trajectory_controller'" in message
    assert rig.manager.controllers["pid_controller"].state == "inactive"
    assert rig.manager.claims == {"joint1/position": "joint_trajectory_controller"}
    assert "interface conflict" in rig.logger.text("warn")
    rig.step(0.1)
    assert rig.sent[-1][1] == ["position"]  # the velocity controller never reached the hardware
    # Handing the joint over in one switch is allowed, as in ros2_control.
    ok, message = rig.manager.switch(["pid_controller"], ["joint_trajectory_controller"], STRICT)
    assert ok, message
    assert rig.manager.claims == {"joint1/velocity": "pid_controller"}


def test_crashing_controller_is_deactivated_while_others_keep_running():
    class Crashing(Controller):
        type_name = "test/Crashing"

        def command_interface_configuration(self):
            return ["b/position"]

        def update(self, time, period):
            if time > 0.1:
                raise RuntimeError("boom")

    CONTROLLER_TYPES[Crashing.type_name] = Crashing
    try:
        text = """
controller_manager: {ros__parameters: {update_rate: 100, bad: {type: test/Crashing}, jtc: {type: joint_trajectory_controller/JointTrajectoryController}}}
jtc: {ros__parameters: {joints: [a]}}
"""
        rig = Rig(text, ["a", "b"])
        rig.spawn("bad", "jtc")
        rig.publish("jtc/joint_trajectory", msgs.from_dict(JointTrajectory, trajectory(["a"], [(0.5, [1.0])])))
        rig.step(1.0)
        states = {c["name"]: c for c in rig.manager.list_controllers()}
        assert states["bad"]["state"] == "inactive" and "boom" in states["bad"]["last_error"]
        assert states["jtc"]["state"] == "active"
        assert rig.plant.pos["a"] == pytest.approx(1.0, abs=0.01)
        assert "b/position" not in rig.manager.claims
        assert "controller 'bad' deactivated" in rig.logger.text("error")
    finally:
        del CONTROLLER_TYPES[Crashing.type_name]


def test_lifecycle_errors_are_clear():
    rig = lab_rig()
    with pytest.raises(ManagerError, match="already loaded"):
        rig.manager.load("joint_trajectory_controller")
    with pytest.raises(ManagerError, match="has no type"):
        rig.manager.load("ghost")
    with pytest.raises(ManagerError, match="deactivate it before unloading"):
        rig.manager.unload("joint_trajectory_controller")
    rig.manager.load("pid_controller")
    ok, message = rig.manager.switch(["pid_controller"], [], STRICT)
    assert not ok and "unconfigured" in message
    ok, message = rig.manager.switch([], ["joint_trajectory_controller"], STRICT)
    assert ok, message
    rig.manager.unload("joint_trajectory_controller")
    assert "joint_trajectory_controller" not in rig.manager.controllers
    assert rig.contexts["joint_trajectory_controller"].destroyed >= 1
    commands, _ = rig.manager.list_interfaces()
    assert {c["name"]: c["is_claimed"] for c in commands} == {"joint1/position": False, "joint1/velocity": False}


def test_jtc_position_and_velocity_interfaces_and_velocity_only_with_gains():
    both = """
controller_manager: {ros__parameters: {update_rate: 100, jtc: {type: joint_trajectory_controller/JointTrajectoryController}}}
jtc: {ros__parameters: {joints: [joint1], command_interfaces: [position, velocity]}}
"""
    rig = Rig(both, ["joint1"], ("position", "velocity"))
    rig.spawn("jtc")
    rig.publish("jtc/joint_trajectory", msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(2.0, [1.0])])))
    rig.step(1.0)
    names, kinds, values = rig.sent[-1]
    command = dict(zip(kinds, values, strict=True))
    assert command["velocity"] == pytest.approx(0.5)  # linear segment: 1 rad over 2 s
    assert 0.4 < command["position"] < 0.6

    velocity_only = both.replace("[position, velocity]", "[velocity]") .replace(
        "command_interfaces: [velocity]}", "command_interfaces: [velocity], gains: {joint1: {p: 5.0}}}")
    rig = Rig(velocity_only, ["joint1"], ("position", "velocity"))
    rig.spawn("jtc")
    rig.publish("jtc/joint_trajectory", msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(1.0, [0.8])])))
    rig.step(3.0)
    assert rig.sent[-1][1] == ["velocity"]
    assert rig.plant.pos["joint1"] == pytest.approx(0.8, abs=0.01)


def test_restart_after_hardware_reset_holds_the_new_pose_and_aborts_goals():
    rig = lab_rig()
    _, _, handle = rig.send_goal("joint_trajectory_controller", {"trajectory": trajectory(["joint1"], [(5.0, [1.5])])})
    rig.step(1.0)
    rig.plant.pos["joint1"] = -0.4  # a new simulation, somewhere else
    rig.plant.publish_state()
    rig.manager.restart_active("hardware reset")
    rig.step(0.1)
    assert handle.status == ABORTED
    assert rig.sent[-1][2][0] == pytest.approx(-0.4, abs=0.01)
    assert rig.manager.controllers["joint_trajectory_controller"].state == "active"


@pytest.mark.parametrize("update_rate, state_interval, states, expected_updates", [
    (100, 0.001, 100, 10),   # the simulator steps 1 kHz for another robot: update every 10th state
    (100, 0.01, 10, 10),     # states at the update rate: every state
    (300, 0.003, 30, 30),    # 3 ms states for a 3.33 ms period: still every state, not every other
])
def test_manager_runs_update_at_its_own_rate_on_sim_time(update_rate, state_interval, states, expected_updates):
    periods: list[float] = []

    class Counting(Controller):
        type_name = "test/Counting"

        def update(self, time, period):
            periods.append(period)

    CONTROLLER_TYPES[Counting.type_name] = Counting
    try:
        text = f"controller_manager: {{ros__parameters: {{update_rate: {update_rate}, c: {{type: test/Counting}}}}}}"
        rig = Rig(text, ["a"], rate=update_rate)
        rig.spawn("c")
        ran = [rig.manager.tick(round(1.0 + i * state_interval, 9)) for i in range(states)]
        assert sum(ran) == expected_updates
        assert periods[1:] == pytest.approx([1.0 / update_rate] * (expected_updates - 1), abs=state_interval)
        rig.manager.reset_clock()  # a reset simulation starts again at t = 0
        assert rig.manager.tick(0.0)
    finally:
        del CONTROLLER_TYPES[Counting.type_name]


def test_jtc_effort_interface_closes_the_loop_with_its_gains():
    text = """
controller_manager: {ros__parameters: {update_rate: 1000, jtc: {type: joint_trajectory_controller/JointTrajectoryController}}}
jtc: {ros__parameters: {joints: [a], command_interfaces: [effort], gains: {a: {p: 20.0, d: 2.0, i: 1.0, i_clamp: 0.5}}}}
"""
    rig = Rig(text, ["a"], ("effort",), rate=1000)
    rig.spawn("jtc")
    rig.publish("jtc/joint_trajectory", msgs.from_dict(JointTrajectory, trajectory(["a"], [(1.0, [0.6])])))
    rig.step(3.0)
    assert rig.sent[-1][1] == ["effort"]
    assert rig.plant.pos["a"] == pytest.approx(0.6, abs=0.01)
    no_gains = text.replace(", gains: {a: {p: 20.0, d: 2.0, i: 1.0, i_clamp: 0.5}}", "")
    rig = Rig(no_gains, ["a"], ("effort",), rate=1000)
    rig.manager.load("jtc")
    with pytest.raises(ManagerError, match="need gains"):
        rig.manager.configure("jtc")


# --- joint limits (from the hardware: URDF + <ros2_control>) -------------------------------------------
JOINT1_LIMITS = {"joint1": {"min_position": -1.0, "max_position": 1.0, "max_velocity": 2.0, "max_effort": 50.0}}


def limited_rig(**kwargs) -> Rig:
    rig = Rig(LAB_YAML, ["joint1"], ("position", "velocity"), limits=JOINT1_LIMITS, **kwargs)
    rig.spawn("joint_state_broadcaster", "joint_trajectory_controller")
    return rig


def test_jtc_refuses_a_position_outside_the_joint_limits_naming_joint_value_and_limit():
    rig = limited_rig()
    rig.step(0.1)
    before = rig.sent[-1]
    ok, why, _ = rig.send_goal("joint_trajectory_controller",
                               {"trajectory": trajectory(["joint1"], [(1.0, [0.5]), (2.0, [1.5])])})
    assert not ok
    assert "joint 'joint1' 1.5 rad is outside its upper limit 1" in why and "points[1]" in why
    rig.publish("joint_trajectory_controller/joint_trajectory",
                msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(1.0, [-1.2])])))
    assert "joint 'joint1' -1.2 rad is outside its lower limit -1" in rig.logger.text("error")
    rig.step(0.5)
    assert rig.sent[-1] == before                     # nothing was sent for either


@pytest.mark.parametrize("traj, reason", [
    (trajectory(["joint1"], [(2**31 - 1, [0.5])]), "longer than the 3600 s allowed"),
    (trajectory(["joint1"], [(1.0, [0.5])], stamp=68 * 365 * 86400.0), "starts more than 3600 s after now"),
    ({**trajectory(["joint1"], [(1.0, [0.5])]), "header": {"stamp": {"sec": -5, "nanosec": 0}}},
     "header.stamp is negative"),
])
def test_jtc_refuses_absurd_durations_and_stamps(traj, reason):
    rig = limited_rig()
    rig.step(0.1)
    ok, why, _ = rig.send_goal("joint_trajectory_controller", {"trajectory": traj})
    assert not ok and reason in why


def test_jtc_refuses_too_many_points_before_looking_at_them():
    rig = limited_rig()
    rig.controller("joint_trajectory_controller").max_points = 1000
    ok, why, _ = rig.send_goal("joint_trajectory_controller",
                               {"trajectory": trajectory(["joint1"], [(0.01 * (i + 1), [0.0]) for i in range(1001)])})
    assert not ok and "1001 points, more than the 1000 allowed" in why
    from nodes.control.trajectory import validate_trajectory
    junk = [{"positions": ["not even a number"]}] * 100_001      # refused on the count, never inspected
    with pytest.raises(ValueError, match="100001 points, more than the 100000 allowed"):
        validate_trajectory({"joint_names": ["joint1"], "points": junk}, ["joint1"], now=0.0)


def test_jtc_slows_a_too_fast_trajectory_down_to_the_velocity_limit():
    rig = limited_rig(tau=0.005)
    rig.step(0.1)
    ok, why, handle = rig.send_goal("joint_trajectory_controller",
                                    {"trajectory": trajectory(["joint1"], [(0.1, [0.8])])})   # 8 rad/s asked
    assert ok, why
    rig.step(0.2)
    assert "slowed down 4x: joint 'joint1' would need 8 rad/s, its velocity limit is 2 rad/s" in rig.logger.text("warn")
    rig.step(0.5)
    assert handle.status == SUCCEEDED
    commands = [c[2][0] for c in rig.sent if c[0]]
    steps = [abs(b - a) / rig.dt for a, b in zip(commands, commands[1:])]
    assert max(steps) <= 2.0 + 1e-9                   # never commanded faster than the limit
    assert commands[-1] == pytest.approx(0.8)


def test_jtc_output_limiter_slows_a_jump_that_no_timing_can_slow():
    rig = limited_rig(tau=0.005)
    rig.step(0.1)
    # a first point at time 0 is a jump: the limiter moves the command at the velocity limit instead
    rig.publish("joint_trajectory_controller/joint_trajectory",
                msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(0.0, [0.6])])))
    rig.step(0.15)
    commands = [c[2][0] for c in rig.sent if c[0]]
    assert max(abs(b - a) / rig.dt for a, b in zip(commands, commands[1:])) <= 2.0 + 1e-9
    assert commands[-1] == pytest.approx(0.3, abs=0.03)
    rig.step(0.3)
    assert rig.sent[-1][2][0] == pytest.approx(0.6)
