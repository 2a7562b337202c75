"""ROS name rules (nodes/core/names.py), as rcl_validate_topic_name and rmw's namespace and node name checks
apply them, and the plugin and sensor declarations that carry names."""

from __future__ import annotations

import pytest

from nodes.core import names
from nodes.urdf.sensors import plugin_name_problems


@pytest.mark.parametrize("name", ["scan", "/humanoid/scan", "~/out", "~", "camera/rgb", "a_1/b2", "_x"])
def test_valid_topic_names(name: str) -> None:
    assert names.topic_problem(name) is None


@pytest.mark.parametrize("name, reason", [
    ("", "is empty"),
    ("**", "'*': wildcards"),
    ("$*", "'$': wildcards"),
    ("a//b", "empty token"),
    ("a/*/b", "'*': wildcards"),
    ("7up", "starts with a digit"),
    ("a/7up", "starts with a digit"),
    ("a/", "ends with '/'"),
    ("~x", "only a leading '~/'"),
    ("a/~/b", "only a leading '~/'"),
    ("/~/b", "only a leading '~/'"),
    ("a-b", "'-'"),
    ("a b", "' '"),
    ("{ns}/x", "'{'"),
    ("x" * 248, "248 characters, over the limit of 247"),
])
def test_invalid_topic_names(name: str, reason: str) -> None:
    problem = names.topic_problem(name)
    assert problem is not None and reason in problem, problem


def test_the_length_limits_are_rmws() -> None:
    assert names.topic_problem("/" + "x" * 246) is None
    assert names.namespace_problem("x" * 245) is None and "over the limit of 245" in names.namespace_problem("x" * 246)
    assert names.node_name_problem("x" * 255) is None and "over the limit of 255" in names.node_name_problem("x" * 256)


@pytest.mark.parametrize("namespace, ok", [("", True), ("/", True), ("/robot", True), ("robot/", True),
                                           ("tools/box", True), ("~/x", False), ("a//b", False), ("**", False),
                                           ("//", False), ("1robot", False)])
def test_namespaces(namespace: str, ok: bool) -> None:
    assert (names.namespace_problem(namespace) is None) == ok, names.namespace_problem(namespace)


@pytest.mark.parametrize("frame, ok", [("base_link", True), ("camera-link.1", True), ("a/b", True),
                                       ("base*", False), ("a//b", False), ("/a", False), ("", False),
                                       ("x" * 256, False)])
def test_frames(frame: str, ok: bool) -> None:
    assert (names.frame_problem(frame) is None) == ok


def test_check_names_the_field_and_shortens_the_value() -> None:
    with pytest.raises(names.NameError_) as caught:
        names.check(names.namespace_problem("n" * 100_000), "robot_namespace", "n" * 100_000)
    message = str(caught.value)
    assert message.startswith("robot_namespace 'nnn") and "(100000 characters)" in message and len(message) < 250


def test_resolve_refuses_a_key_over_the_topic_limit() -> None:
    with pytest.raises(names.NameError_, match="over rmw's limit of 247"):
        names.resolve("x" * 300)
    assert names.resolve("scan", "robot") == "robot/scan"


def test_a_plugin_s_names_are_each_checked() -> None:
    problems = plugin_name_problems("sensor 'cam'", "cam_controller", "**", {"~/out": "**", "a//b": "ok"},
                                    "base*")
    text = "\n".join(problems)
    assert "<ros><namespace> '**': has '*'" in text
    assert "<remapping> '~/out:=**': to '**' has '*'" in text
    assert "<remapping> 'a//b:=ok': from 'a//b' has an empty token" in text
    assert "<frame_name> 'base*'" in text
    assert plugin_name_problems("s", "imu_plugin", "/robot", {"~/out": "imu"}, "imu_link") == []

