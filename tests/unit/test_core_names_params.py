"""Name resolution, remapping and typed parameters (no Zenoh needed)."""

from __future__ import annotations

import pytest

from nodes.core.names import NameError_, apply_remap, parse_assignment, resolve
from nodes.core.params import ParameterDescriptor, ParameterError, coerce, load_params_file, parse_value


def test_resolve() -> None:
    assert resolve("joint_states", "humanoid", "jsb") == "humanoid/joint_states"
    assert resolve("/sim/clock", "humanoid", "jsb") == "sim/clock"
    assert resolve("~/commands", "humanoid", "fwd") == "humanoid/fwd/commands"
    assert resolve("joint_states", "", "n") == "joint_states"
    for bad in ("", "a b", "x/*", "a//b", "k$"):
        with pytest.raises(NameError_):
            resolve(bad, "ns", "n")


def test_remap() -> None:
    rules = {"joint_states": "/robot/joint_states", "~/out": "joint_states"}
    assert apply_remap("humanoid/joint_states", rules, "humanoid", "n") == "robot/joint_states"
    assert apply_remap("humanoid/n/out", rules, "humanoid", "n") == "humanoid/joint_states"
    assert apply_remap("humanoid/other", rules, "humanoid", "n") == "humanoid/other"
    assert parse_assignment("a:=b:=c") == ("a", "b:=c")
    with pytest.raises(ValueError):
        parse_assignment("novalue")


def test_parameter_types_and_ranges() -> None:
    rate = ParameterDescriptor("rate", 50.0, float, min_value=1.0, max_value=1000.0)
    assert coerce(rate, 100) == 100.0
    for bad, reason in ((0.5, "below the minimum"), (2000.0, "above the maximum"), ("fast", "expected float"),
                        (float("nan"), "finite")):
        with pytest.raises(ParameterError, match=reason) as info:
            coerce(rate, bad)
        assert "'rate'" in str(info.value)
    joints = ParameterDescriptor("joints", ["a"], list)
    assert coerce(joints, ["x", "y"]) == ["x", "y"]
    with pytest.raises(ParameterError, match=r"joints\[1\]"):
        coerce(joints, ["x", 3])
    mode = ParameterDescriptor("mode", "lockstep", str, choices=("lockstep", "realtime"))
    with pytest.raises(ParameterError, match="not one of"):
        coerce(mode, "warp")
    flag = ParameterDescriptor("flag", False, bool)
    with pytest.raises(ParameterError, match="expected a bool"):
        coerce(flag, "yes please")
    assert parse_value("[1, 2]") == [1, 2] and parse_value("true") is True and parse_value("a: [") == "a: ["


def test_params_file_ros_format(tmp_path) -> None:
    f = tmp_path / "p.yaml"
    f.write_text(
        "/**:\n  ros__parameters:\n    use_sim_time: true\n"
        "controller_manager:\n  ros__parameters:\n    update_rate: 1000\n"
        "    joint_state_broadcaster:\n      type: joint_state_broadcaster/JointStateBroadcaster\n"
        "other:\n  ros__parameters:\n    x: 1\n")
    params = load_params_file(f, "controller_manager", "humanoid")
    assert params["use_sim_time"] is True and params["update_rate"] == 1000
    assert params["joint_state_broadcaster.type"] == "joint_state_broadcaster/JointStateBroadcaster"
    assert "x" not in params
    flat = tmp_path / "flat.yaml"
    flat.write_text("rate: 5\n")
    assert load_params_file(flat, "n") == {"rate": 5}
    broken = tmp_path / "broken.yaml"
    broken.write_text("a: [\n")
    with pytest.raises(ParameterError, match="invalid YAML"):
        load_params_file(broken, "n")


def test_wildcards_only_for_subscriptions() -> None:
    assert resolve("/*/joint_states", "ns", "n", wildcards=True) == "*/joint_states"
    assert resolve("sim/**", "", "n", wildcards=True) == "sim/**"
    with pytest.raises(NameError_):
        resolve("/*/joint_states", "ns", "n")
    with pytest.raises(NameError_):
        resolve("/a*/x", "ns", "n", wildcards=True)
