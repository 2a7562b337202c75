"""Controller parameters: one schema per controller (nodes.core.param_schema), one coercion shared with node
parameters (nodes.core.params), the config/ YAML files loading unchanged, and the JTC parameters that change
behaviour (open_loop_control, state_interfaces)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pytest

import msgs
from nodes.control.config import load_config_file
from nodes.control.controllers import CONTROLLER_TYPES
from nodes.control.controllers.joint_trajectory_controller import JtcParameters
from nodes.control.controllers.pid_controller import PidParameters
from nodes.core.param_schema import ParameterError, describe, load_parameters, param, per_key
from nodes.core.params import ParameterDescriptor, coerce
from tests.unit.test_control_controllers import Rig, trajectory

ROOT = Path(__file__).resolve().parents[2]
JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")
CONFIGS = sorted(p.name for p in (ROOT / "config").glob("*controllers.yaml"))


@pytest.mark.parametrize("name", CONFIGS)
def test_every_controller_of_every_config_file_loads_its_schema_without_unknown_names(name):
    config = load_config_file(ROOT / "config" / name)
    for cfg in config.controllers.values():
        loaded = load_parameters(CONTROLLER_TYPES[cfg.type].Params, cfg.params, ignore=("type",))
        assert loaded.unknown == [], (name, cfg.name)


def test_a_schema_reads_nested_and_dotted_names_into_typed_values_with_per_joint_maps():
    given = {"joints": ["a", "b"], "command_interfaces": ["velocity"], "constraints.goal_time": 2,
             "constraints": {"a": {"goal": 0.05}, "stopped_velocity_tolerance": 0.1},
             "gains": {"a": {"p": 3, "i_clamp": 0.5}, "b": {"d": 1.0}}}
    params = load_parameters(JtcParameters, given).values
    assert params.joints == ["a", "b"] and params.command_interfaces == ["velocity"]
    assert params.constraints.goal_time == 2.0 and isinstance(params.constraints.goal_time, float)
    assert params.constraints.per_joint["a"].goal == 0.05 and params.constraints.per_joint["b"].goal == 0.0
    assert params.gains["a"].p == 3.0 and params.gains["b"].d == 1.0 and params.gains["b"].p == 0.0
    assert params.state_publish_rate == 50.0   # the default


@pytest.mark.parametrize("given, reason", [
    ({"joints": ["a"], "gains": {"a": {"p": -1.0}}}, "parameter 'gains.a.p': -1.0 is below the minimum 0.0"),
    ({"joints": ["a"], "constraints": {"a": {"goal": "tight"}}}, "parameter 'constraints.a.goal': expected float"),
    ({"joints": "a"}, "parameter 'joints': expected a list"),
    ({"joints": ["a", 3]}, r"parameter 'joints\[1\]': expected str"),
    ({"command_interfaces": ["torque"]}, "'torque' is not one of"),
    ({"max_trajectory_points": 1.5}, "parameter 'max_trajectory_points': expected int"),
    ({"allow_partial_joints_goal": "yes"}, "expected a bool"),
    ({"cmd_timeout": math.inf}, "parameter 'cmd_timeout': must be finite"),
])
def test_a_bad_value_is_refused_naming_the_dotted_parameter(given, reason):
    with pytest.raises(ParameterError, match=reason):
        load_parameters(JtcParameters, given)


def test_infinity_only_where_a_parameter_allows_it_nan_never():
    """One rule for node and controller parameters (they used to disagree): a clamp may be .inf ("none")."""
    gains = load_parameters(PidParameters, {"joints": ["a"], "gains": {"a": {"p": 1.0, "u_clamp_max": math.inf}}})
    assert gains.values.gains["a"].u_clamp_max == math.inf
    with pytest.raises(ParameterError, match="gains.a.u_clamp_max': must be finite"):
        load_parameters(PidParameters, {"joints": ["a"], "gains": {"a": {"u_clamp_max": math.nan}}})
    rate = ParameterDescriptor("rate", 1.0, float)
    with pytest.raises(ParameterError, match="must be finite"):
        coerce(rate, math.inf)
    assert coerce(ParameterDescriptor("limit", 1.0, float, allow_infinite=True), -math.inf) == -math.inf


def test_pid_integral_limits_default_to_the_symmetric_clamp():
    params = load_parameters(PidParameters, {"dof_names": ["a", "b"], "gains": {
        "a": {"p": 1.0, "i_clamp": 0.5}, "b": {"p": 1.0, "i_clamp": 0.5, "i_clamp_max": 0.2}}}).values
    a, b = params.gains["a"].pid(), params.gains["b"].pid()
    assert (a.i_min, a.i_max) == (-0.5, 0.5)
    assert (b.i_min, b.i_max) == (-0.5, 0.2)
    assert params.gains.keys() == {"a", "b"}   # keyed by dof_names when joints is empty


def test_unknown_names_are_reported_not_loaded():
    loaded = load_parameters(JtcParameters, {"joints": ["a"], "gains": {"a": {"pp": 1.0}}, "type": "x/Y",
                                             "open_loop": True}, ignore=("type",))
    assert loaded.unknown == ["gains.a.pp", "open_loop"]


def test_every_builtin_controller_parameter_is_described():
    for cls in CONTROLLER_TYPES.values():
        for desc in describe(cls.Params, keys={"joints": ["j"], "dof_names": ["j"]}):
            assert desc.description, f"{cls.type_name}: parameter '{desc.name}' has no description"


def test_a_schema_field_must_say_what_it_is():
    @dataclass
    class Bare:
        rate: float = 1.0

    with pytest.raises(TypeError, match="param"):
        load_parameters(Bare, {})

    @dataclass
    class Keyed:
        joints: list[str] = param([], description="x")
        gains: dict = per_key(Bare, keys="joints")

    assert load_parameters(Keyed, {"joints": []}).values.gains == {}


def test_an_unknown_parameter_is_warned_once_at_load():
    text = """
controller_manager: {ros__parameters: {update_rate: 100, jtc: {type: joint_trajectory_controller/JointTrajectoryController}}}
jtc: {ros__parameters: {joints: [joint1], allow_integration_in_goal_trajectories: true}}
"""
    rig = Rig(text, ["joint1"], ("position", "velocity"))
    rig.spawn("jtc")
    assert "jtc: ignoring unknown parameters ['allow_integration_in_goal_trajectories']" in rig.logger.text("warn")


# ------------------------------------------------------------------------------------------ JTC behaviour
VELOCITY_JTC = """
controller_manager: {ros__parameters: {update_rate: 100, jtc: {type: joint_trajectory_controller/JointTrajectoryController}}}
jtc: {ros__parameters: {joints: [joint1], command_interfaces: [velocity], gains: {joint1: {p: 5.0}}}}
"""


def _first_velocity_commands(text: str) -> list[float]:
    rig = Rig(text, ["joint1"], ("position", "velocity"))
    rig.spawn("jtc")
    rig.step(0.05)
    rig.publish("jtc/joint_trajectory", msgs.from_dict(JointTrajectory, trajectory(["joint1"], [(2.0, [1.0])])))
    rig.step(1.0)
    return [values[0] for _, kinds, values in rig.sent[-50:] if kinds == ["velocity"]]


def test_jtc_open_loop_control_sends_the_desired_velocity_without_the_pid():
    """ros2_controllers: with a velocity-only command interface the JTC closes the loop with gains unless
    ``open_loop_control`` is set; then the command is the trajectory's velocity (1 rad over 2 s: 0.5 rad/s
    in the middle of the linear segment), whatever the position error."""
    closed = _first_velocity_commands(VELOCITY_JTC.replace("p: 5.0", "p: 0.0, ff_velocity_scale: 0.0"))
    open_loop = _first_velocity_commands(VELOCITY_JTC.replace("command_interfaces: [velocity]",
                                                              "command_interfaces: [velocity], open_loop_control: true"))
    assert closed and all(v == 0.0 for v in closed)   # no gains, no feed-forward: the PID commands nothing
    assert open_loop and open_loop[-1] == pytest.approx(0.5)


def _goal_status_with_state_interfaces(kinds: str) -> tuple[list[str], int, float]:
    text = f"""
controller_manager: {{ros__parameters: {{update_rate: 100, jtc: {{type: joint_trajectory_controller/JointTrajectoryController}}}}}}
jtc: {{ros__parameters: {{joints: [joint1], state_interfaces: {kinds}}}}}
"""
    rig = Rig(text, ["joint1"], ("position", "velocity"), tau=0.2)
    rig.spawn("jtc")
    claimed = next(r for r in rig.manager.list_controllers() if r["name"] == "jtc")["required_state_interfaces"]
    _, _, goal = rig.send_goal("jtc", {"trajectory": trajectory(["joint1"], [(0.5, [0.3])]),
                                       "goal_tolerance": [{"name": "joint1", "position": 0.05, "velocity": 1e-6}]})
    rig.step(1.0)
    return claimed, goal.status, rig.plant.pos["joint1"]


def test_jtc_claims_the_state_interfaces_its_parameter_names():
    """Without a velocity state interface the JTC does not measure velocity: a goal velocity tolerance is not
    held against anything (ros2_controllers checks velocities only with a velocity state interface)."""
    claimed, status, position = _goal_status_with_state_interfaces("[position]")
    assert claimed == ["joint1/position"]
    assert status == 4 and position == pytest.approx(0.3, abs=0.05)
    claimed, status, _ = _goal_status_with_state_interfaces("[position, velocity]")
    assert claimed == ["joint1/position", "joint1/velocity"]
    assert status == 2, "the slow plant still moves faster than 1e-6 rad/s: the goal is still executing"
