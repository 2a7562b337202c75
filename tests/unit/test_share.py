"""One resolver for the shared files (robots/, config/): what ``$(robot)``, ``$(config)``, the simulator,
``zenroid spawn`` and the viewer all use; and ``zenroid launch`` beside a ROS 2 ``launch`` package."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from launch._yaml_substitutions import SubstitutionContext, substitute
from launch.yaml_source import LaunchError, Source
from nodes import share
from nodes.sim.robot_files import ConfigError, resolve_robot_file
from tests.conftest import ROOT


def test_shared_folders_are_the_top_level_ones_in_a_checkout() -> None:
    assert share.ROBOTS_DIR == (ROOT / "robots").resolve()
    assert share.CONFIG_DIR == (ROOT / "config").resolve()
    assert share.WORLDS_DIR == (ROOT / "worlds").resolve()
    assert share.world_file("simple_lab") == share.world_file("simple_lab.world") == share.WORLDS_DIR / "simple_lab.world"
    assert "humanoid.urdf" in share.robot_names()


def test_robot_names_paths_and_errors(tmp_path: Path) -> None:
    assert share.robot_file("humanoid") == share.ROBOTS_DIR / "humanoid.urdf"
    assert share.robot_file("humanoid_20dof") == share.ROBOTS_DIR / "humanoid_20dof.urdf.xacro"
    assert share.robot_file("lab_robot.urdf") == share.ROBOTS_DIR / "lab_robot.urdf"
    own = tmp_path / "mine.urdf"
    own.write_text("<robot name='mine'/>")
    assert share.robot_file(str(own)) == own.resolve()
    with pytest.raises(FileNotFoundError, match=r"robot 'no_such_bot' not found .*robots"):
        share.robot_file("no_such_bot")
    # the simulator's entry point is the same lookup, with its own error type
    assert resolve_robot_file("humanoid") == share.robot_file("humanoid")
    with pytest.raises(ConfigError, match="no_such_bot"):
        resolve_robot_file("no_such_bot")


def test_config_files() -> None:
    assert share.config_file("controllers") == share.CONFIG_DIR / "controllers.yaml"
    assert share.config_file("sim.yaml") == share.CONFIG_DIR / "sim.yaml"
    with pytest.raises(FileNotFoundError, match="config file 'nope'"):
        share.config_file("nope")


def test_config_substitution() -> None:
    ctx = SubstitutionContext(variables={"c": "controllers"}, current_file=Path("/x/f.yaml"))
    src = Source(Path("f.yaml"), 7)
    assert substitute("$(config $(var c).yaml)", ctx, src) == str(share.CONFIG_DIR / "controllers.yaml")
    with pytest.raises(LaunchError, match=r"\$\(config nope\)") as error:
        substitute("$(config nope)", ctx, src)
    assert error.value.source.line == 7
    with pytest.raises(LaunchError, match="takes one file name"):
        substitute("$(config a b)", ctx, src)


def test_zenroid_launch_runs_ours_when_a_ros2_launch_package_comes_first(tmp_path: Path) -> None:
    ros = tmp_path / "ros" / "launch"
    ros.mkdir(parents=True)
    (ros / "__init__.py").write_text("ROS = True\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ros.parent), str(ROOT)]))
    env.pop("ZENOH_CONNECT", None)
    env.pop("ZENOH_CONFIG", None)
    result = subprocess.run([sys.executable, "-m", "nodes.tools", "launch", "humanoid.yaml", "--print"], cwd=tmp_path,
                            env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "nodes.sim" in result.stdout and str(share.CONFIG_DIR / "controllers.yaml") in result.stdout
