"""Semantic and size limits on requests, checked without processes: every physical quantity in a plausible
range, every name and list bounded, every refusal naming the field, nothing long echoed back."""

from __future__ import annotations

import math

import pytest

import msgs
from nodes.control.node import MAX_SWITCH_CONTROLLERS, _switch_request_problem
from nodes.sim.services import physics_request_problem

SetPhysics = msgs.get_type("zenroid_sim_msgs/srv/SetPhysicsProperties")
SwitchController = msgs.get_type("controller_manager_msgs/srv/SwitchController")
Vector3 = msgs.get_type("geometry_msgs/msg/Vector3")


def physics(**fields) -> object:
    return SetPhysics.Request(**fields)


@pytest.mark.parametrize("request_fields, field", [
    ({"set_gravity": True, "gravity": Vector3(z=1e308)}, "gravity.z"),
    ({"set_gravity": True, "gravity": Vector3(z=1e6)}, "gravity.z"),
    ({"set_gravity": True, "gravity": Vector3(x=-101.0)}, "gravity.x"),
    ({"set_gravity": True, "gravity": Vector3(y=math.inf)}, "gravity.y"),
    ({"set_gravity": True, "gravity": Vector3(y=math.nan)}, "gravity.y"),
    ({"time_step": 5e-324}, "time_step"),
    ({"time_step": -0.001}, "time_step"),
    ({"time_step": 0.5}, "time_step"),
    ({"time_step": math.nan}, "time_step"),
    ({"real_time_factor": 1e9}, "real_time_factor"),
    ({"real_time_factor": -1.0}, "real_time_factor"),
    ({"mode": "x" * 100_000}, "mode"),
    ({"add_ground": True, "remove_ground": True}, "add_ground"),
])
def test_physics_requests_out_of_range_are_refused_naming_the_field(request_fields, field) -> None:
    problem = physics_request_problem(physics(**request_fields))
    assert problem and problem.startswith(field), problem
    assert len(problem) < 500   # a 100,000-character mode is not echoed back


@pytest.mark.parametrize("request_fields", [
    {}, {"set_gravity": True, "gravity": Vector3(z=-9.81)}, {"set_gravity": True}, {"time_step": 0.001},
    {"time_step": 1e-5}, {"time_step": 0.01}, {"real_time_factor": 2.0}, {"mode": "kinematic"},
    {"set_gravity": True, "gravity": Vector3(x=100.0, y=-100.0, z=-1.62)},
])
def test_plausible_physics_requests_pass(request_fields) -> None:
    assert physics_request_problem(physics(**request_fields)) is None


def switch(**fields) -> object:
    return SwitchController.Request(**{"strictness": 2, **fields})


@pytest.mark.parametrize("request_fields, field", [
    ({"strictness": 99}, "strictness"),
    ({"strictness": -1}, "strictness"),
    ({"strictness": 3}, "strictness"),
    ({"activate_controllers": [f"c{i}" for i in range(1_000_000)]}, "activate_controllers"),
    ({"deactivate_controllers": ["x"] * (MAX_SWITCH_CONTROLLERS + 1)}, "deactivate_controllers"),
    ({"activate_controllers": ["ok", "n" * 10_000_000]}, "activate_controllers[1]"),
])
def test_switch_requests_beyond_limits_are_refused_naming_the_field(request_fields, field) -> None:
    problem = _switch_request_problem(switch(**request_fields))
    assert problem.startswith(field), problem
    assert len(problem) < 500


@pytest.mark.parametrize("strictness", [0, 1, 2])
def test_switch_strictness_values_ros2_control_accepts(strictness) -> None:
    assert _switch_request_problem(switch(strictness=strictness, activate_controllers=["a"])) == ""


def test_single_sender_keeps_the_first_source_until_it_falls_silent() -> None:
    from nodes.core.endpoints import SingleSender, source_label

    guard = SingleSender(takeover_after=0.5)
    sim, forger, respawned = b"s" * 16, b"f" * 16, b"r" * 16
    assert guard.admit(sim, 10.0)
    assert not guard.admit(forger, 10.1) and not guard.admit(None, 10.2)
    assert guard.admit(sim, 10.3) and guard.refused == 2
    assert guard.admit(respawned, 10.9)          # the owner was silent for 0.6 s: a respawned sender takes over
    assert not guard.admit(sim, 11.0) and guard.owner == respawned
    assert source_label(sim) == f"source {sim[:6].hex()}" and "without" in source_label(None)


@pytest.mark.parametrize("text, reason", [
    ("a: &a [*a]", "aliases"),                                    # a cycle
    ("a: &x [1, 2]\nb: [*x, *x, *x]", "aliases"),                 # the billion-laughs construction
    ("a: " + "[" * 100 + "]" * 100, "deeper than 32"),
])
def test_yaml_from_requests_refuses_aliases_and_deep_nesting(text: str, reason: str) -> None:
    from nodes.control.config import ConfigError, parse_controller_yaml
    from nodes.core.params import parse_value

    with pytest.raises(ConfigError, match=reason):
        parse_controller_yaml(text)
    assert parse_value(text) == text   # a node parameter value: kept as the plain string, never built


def test_configured_controllers_are_bounded() -> None:
    import yaml

    from nodes.control.config import parse_config
    from nodes.control.manager import MAX_CONFIGURED, ControllerManager, ManagerError
    from tests.support.control import ListLogger, make_hardware

    manager = ControllerManager(make_hardware(["a"], ("position",)), parse_config(yaml.safe_load("{}")), 100,
                                lambda name: None, ListLogger())
    with pytest.raises(ManagerError, match="package/Class"):
        manager.set_controller_params("evil", {"type": "this:Nope"})
    assert "evil" not in manager.config.controllers
    for i in range(MAX_CONFIGURED):
        manager.set_controller_params(f"c{i}", {"joints": ["a"]})
    with pytest.raises(ManagerError, match="the limit"):
        manager.set_controller_params("one_more", {})
    manager.set_controller_params("c0", {"joints": []})   # an existing one can still change


def test_an_array_over_the_network_limit_is_refused_before_it_is_built_naming_the_field() -> None:
    import msgpack

    from nodes.core.endpoints import MAX_ARRAY_LENGTH, decode_limits

    trajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")
    payload = msgpack.packb({"joint_names": ["a"], "points": [{"positions": [0]}] * (MAX_ARRAY_LENGTH + 1)})
    with pytest.raises(msgs.DecodeError) as info:
        msgs.decode(trajectory, payload, decode_limits())
    assert info.value.path == "points" and "exceeds max_array_len" in info.value.reason
