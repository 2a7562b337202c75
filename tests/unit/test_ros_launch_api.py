"""The ROS launch API's substitutions, conditions and frontend text, performed as ROS performs them."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from launch._yaml_substitutions import SubstitutionContext, substitute
from launch.conditions import (
    IfCondition,
    LaunchConfigurationEquals,
    LaunchConfigurationNotEquals,
    UnlessCondition,
)
from launch.context import LaunchContext
from launch.substitutions import (
    AndSubstitution,
    Command,
    EnvironmentVariable,
    EqualsSubstitution,
    FindExecutable,
    LaunchConfiguration,
    NotSubstitution,
    OrSubstitution,
    PathJoinSubstitution,
    PythonExpression,
    SubstitutionFailure,
    TextSubstitution,
    ThisLaunchFileDir,
)
from launch.yaml_source import LaunchError, Source


@pytest.fixture
def context(tmp_path: Path) -> LaunchContext:
    return LaunchContext({"robot": "atlas", "flag": "true", "n": "3"}, current_file=tmp_path / "x.launch.py",
                         environment={"HOME_X": "/h", "PATH": os.environ.get("PATH", "")})


def test_substitutions_perform(context: LaunchContext, tmp_path: Path) -> None:
    assert LaunchConfiguration("robot").perform(context) == "atlas"
    assert LaunchConfiguration("missing", default=["a", TextSubstitution(text="b")]).perform(context) == "ab"
    with pytest.raises(SubstitutionFailure, match="'missing' does not exist"):
        LaunchConfiguration("missing").perform(context)
    assert EnvironmentVariable("HOME_X").perform(context) == "/h"
    assert EnvironmentVariable("NOPE_X", default_value="d").perform(context) == "d"
    with pytest.raises(SubstitutionFailure, match="NOPE_X"):
        EnvironmentVariable("NOPE_X").perform(context)
    assert ThisLaunchFileDir().perform(context) == str(tmp_path)
    joined = PathJoinSubstitution([ThisLaunchFileDir(), "urdf", [LaunchConfiguration("robot"), ".urdf"]])
    assert joined.perform(context) == f"{tmp_path}/urdf/atlas.urdf"
    assert (ThisLaunchFileDir() / "a" / "b").perform(context) == f"{tmp_path}/a/b"


def test_logic_and_python_expression(context: LaunchContext) -> None:
    flag = LaunchConfiguration("flag")
    assert AndSubstitution(flag, "1").perform(context) == "true"
    assert OrSubstitution("false", "0").perform(context) == "false"
    assert NotSubstitution(flag).perform(context) == "false"
    assert EqualsSubstitution("1.0", "1").perform(context) == "true"      # numbers compare as numbers
    assert EqualsSubstitution("True", "true").perform(context) == "true"  # booleans as booleans
    assert EqualsSubstitution(LaunchConfiguration("robot"), "atlas").perform(context) == "true"
    with pytest.raises(SubstitutionFailure, match="not a boolean"):
        AndSubstitution("maybe", "true").perform(context)
    assert PythonExpression([LaunchConfiguration("n"), " * 2 + floor(pi)"]).perform(context) == "9"
    with pytest.raises(SubstitutionFailure, match="ZeroDivisionError"):
        PythonExpression("1 / 0").perform(context)


def test_command_and_find_executable(context: LaunchContext) -> None:
    assert Command(["echo ", LaunchConfiguration("robot"), " 'two words'"]).perform(context) == "atlas two words\n"
    with pytest.raises(SubstitutionFailure, match="not found"):
        Command("no-such-program-zr --x").perform(context)
    with pytest.raises(SubstitutionFailure, match="status 1"):
        Command("false").perform(context)
    assert FindExecutable(name="echo").perform(context).endswith("/echo")


def test_conditions(context: LaunchContext) -> None:
    assert IfCondition(LaunchConfiguration("flag")).evaluate(context)
    assert not UnlessCondition("1").evaluate(context)
    assert LaunchConfigurationEquals("robot", "atlas").evaluate(context)
    assert LaunchConfigurationNotEquals("robot", "g1").evaluate(context)
    with pytest.raises(SubstitutionFailure, match="not one of true, false"):
        IfCondition("yes please").evaluate(context)


def test_frontend_text_substitutions(tmp_path: Path) -> None:
    ctx = SubstitutionContext(variables={"a": "2", "name": "bot"}, current_file=tmp_path / "f.launch.xml")
    at = Source(tmp_path / "f.launch.xml", 3)
    assert substitute("$(eval '$(var a) * 21')", ctx, at) == "42"
    assert substitute("$(eval \"'$(var name)' == 'bot'\")", ctx, at) == "True"
    assert substitute("$(command 'echo (x) $(var name)')", ctx, at) == "(x) bot\n"   # ')' inside quotes
    assert substitute("$(and true $(not false))", ctx, at) == "true"
    assert substitute("$(equals $(var a) 2.0)", ctx, at) == "true"
    assert substitute("$(filename)", ctx, at) == str(tmp_path / "f.launch.xml")
    assert substitute("x$(dirname)", ctx, at) == f"x{tmp_path}"
    with pytest.raises(LaunchError, match=r"f.launch.xml:3: \$\(find-pkg-share\)"):
        substitute("$(find-pkg-share no_such_pkg_zr)", ctx, at)
    with pytest.raises(LaunchError, match="unknown substitution"):
        substitute("$(nope 1)", ctx, at)


@pytest.mark.parametrize("name, text", [
    ("p.launch.xml", '<launch><node pkg="robot_state_publisher" exec="robot_state_publisher" name="rsp">'
                     '<param name="joints" value="a;b;c" value-sep=";"/><param name="gains" value="1, 2.5, true" '
                     'value-sep=", "/><param name="plain" value="1,2"/></node></launch>'),
    ("p.launch.yaml", "launch:\n- node:\n    pkg: robot_state_publisher\n    exec: robot_state_publisher\n"
                      "    name: rsp\n    param:\n    - {name: joints, value: 'a;b;c', value-sep: ';'}\n"
                      "    - {name: gains, value: '1, 2.5, true', value-sep: ', '}\n    - {name: plain, value: '1,2'}\n"
                      "    - {name: listed, value: [x, '$(var n)']}\n"),
])
def test_value_sep_makes_a_list_parameter(tmp_path: Path, name: str, text: str) -> None:
    """launch_xml's ``value-sep``: the value split into a list, each item typed as a parameter value is."""
    from launch.resolve import resolve

    (tmp_path / name).write_text(text)
    node = next(n for n in resolve(tmp_path / name, {"n": "7"}).nodes if n.name == "rsp")
    assert node.params["joints"] == ["a", "b", "c"]
    assert node.params["gains"] == [1, 2.5, True]
    assert node.params["plain"] == "1,2"
    if name.endswith(".yaml"):   # a YAML list stays a list, its text items performed one by one
        assert node.params["listed"] == ["x", 7]
    (tmp_path / name).write_text(text.replace('value-sep=";"', 'value-sep=""').replace("value-sep: ';'", "value-sep: ''"))
    with pytest.raises(LaunchError, match="'value-sep' needs a text 'value' and a separator"):
        resolve(tmp_path / name, {})
