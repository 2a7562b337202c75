"""The ``ros2`` command's spellings mapped onto ``zenroid``'s, ROS's ``--ros-args``, and the served
executables' argument mapping (nodes/tools/ros2.py, nodes/packages/ros_args.py, nodes/packages/serve.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from bench.common import child_env
from nodes.packages import serve
from nodes.packages.ros_args import RosArgsError, split
from nodes.tools.ros2 import Ros2UsageError, translate


@pytest.mark.parametrize(("ros2", "zenroid"), [
    ("topic pub --once /x std_msgs/msg/String {data: hi}", "topic pub --once /x std_msgs/msg/String {data: hi}"),
    ("topic pub -1 /x std_msgs/msg/String {} -w 1", "topic pub --once /x std_msgs/msg/String {}"),
    ("topic echo /joint_states sensor_msgs/msg/JointState --once", "topic echo /joint_states --once"),
    ("topic echo /joint_states --field name --no-arr", "topic echo /joint_states --field name"),
    ("topic hz /camera/rgb -w 10", "topic hz /camera/rgb --window 10"),
    ("topic info -v /x", "topic info -v /x"),
    ("topic list --no-daemon -t", "topic list -t"),
    ("control load_controller --set-state active jtc", "control load_controller --set-state active jtc --ns "),
    ("control load_controller --set_state start jtc", "control load_controller --set-state active jtc --ns "),
    ("control switch_controllers --start a --stop b", "control switch_controllers --activate a --deactivate b --ns "),
    ("control list_controllers --ns humanoid", "control list_controllers --ns humanoid"),
    ("lifecycle set /motor_controller configure", "lifecycle set /motor_controller configure"),
    ("bag record -d 30 /camera/rgb", "bag record -d 30 /camera/rgb"),
    ("run pkg exe --ros-args --log-level debug", "run pkg exe --ros-args --log-level debug"),
    ("launch pkg file.launch.py a:=b", "launch pkg file.launch.py a:=b"),
    ("service call /s std_srvs/srv/Empty -r 1", "service call /s std_srvs/srv/Empty"),
])
def test_ros2_spellings(ros2: str, zenroid: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ZENROID_NS", raising=False)
    assert translate(ros2.split(" ")) == zenroid.split(" ")


def test_ros2_refuses_what_it_does_not_serve() -> None:
    with pytest.raises(Ros2UsageError, match="no ros2 daemon"):
        translate(["daemon", "start"])
    with pytest.raises(Ros2UsageError, match="--csv is not served"):
        translate(["topic", "echo", "/x", "--csv"])


def test_ros_args_become_node_options() -> None:
    rest, ros = split(["a", "--ros-args", "-p", "rate:=5", "-r", "__ns:=/robot", "-r", "__node:=rsp",
                       "-r", "joint_states:=js", "--params-file", "/p.yaml", "--log-level", "DEBUG", "--", "b",
                       "--ros-args", "-r", "rsp:x:=y", "--disable-rosout-logs"])
    assert rest == ["a", "b"]
    assert ros.node_options() == ["--name", "rsp", "--ns", "robot", "--params-file", "/p.yaml", "--param", "rate:=5",
                                  "--remap", "joint_states:=js", "--remap", "x:=y", "--log-level", "debug"]
    with pytest.raises(RosArgsError, match="parameter 'rate' is not NAME:=VALUE"):
        split(["--ros-args", "-p", "rate"])
    with pytest.raises(RosArgsError, match="unknown argument '--bogus'"):
        split(["--ros-args", "--bogus", "x"])


def test_served_executables_map_ros_spellings(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    module, runs = serve.command("controller_manager", "spawner",
                                 ["jsb", "jtc", "--stopped", "-c", "/controller_manager", "--controller-manager-timeout",
                                  "30", "--ros-args", "-p", "use_sim_time:=true"])
    assert module == "nodes.tools"
    assert runs == [["control", "spawner", "jsb", "jtc", "--controller-manager-timeout", "30", "--inactive",
                     "-c", "controller_manager", "--ns", ""]]
    _, runs = serve.command("controller_manager", "spawner", ["jtc", "--ros-args", "-r", "__ns:=/robot"])
    assert runs[0][-4:] == ["-c", "controller_manager", "--ns", "robot"]
    _, runs = serve.command("controller_manager", "unspawner", ["jtc"])
    assert runs == [["control", "set_controller_state", "jtc", "inactive", "-c", "controller_manager", "--ns", ""],
                    ["control", "unload_controller", "jtc", "-c", "controller_manager", "--ns", ""]]
    _, runs = serve.command("gazebo_ros", "spawn_entity.py",
                            ["-entity", "cart", "-topic", "robot_description", "-x", "1", "-gazebo_namespace", "/g",
                             "-spawn_service_timeout", "5", "-package_to_model", "-unpause"])
    assert runs == [["spawn", "-entity", "cart", "-x", "1", "-unpause", "-timeout", "5", "-robot_namespace", "/",
                     "-topic", "robot_description"]]
    models = tmp_path / "models" / "table"
    models.mkdir(parents=True)
    monkeypatch.setenv("GAZEBO_MODEL_PATH", str(tmp_path / "models"))
    _, runs = serve.command("gazebo_ros", "spawn_entity.py", ["-entity", "t", "-database", "table"])
    assert runs == [["spawn", "-entity", "t", "-file", str(models / "model.sdf"), "-robot_namespace", "/"]]
    _, runs = serve.command("ros_gz_sim", "create", ["-name", "cart", "-topic", "robot_description", "-z", "0.5",
                                                     "-world", "empty"])
    assert runs == [["spawn", "-entity", "cart", "-topic", "robot_description", "-z", "0.5", "-robot_namespace", "/"]]
    _, runs = serve.command("robot_state_publisher", "robot_state_publisher",
                            ["--ros-args", "-p", "robot_description:=<robot/>", "-r", "__ns:=/r"])
    assert runs == [["--ns", "r", "--param", "robot_description:=<robot/>"]]
    _, runs = serve.command("controller_manager", "spawner", ["jtc", "-t", "x/Y", "--load-only", "-u"])
    assert runs == [["control", "spawner", "jtc", "-t", "x/Y", "--load-only", "-c", "controller_manager", "--ns", ""]]


def _ros2(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nodes.tools.ros2", *args], env=child_env(), capture_output=True,
                          text=True, timeout=120, cwd=cwd)


def test_ros2_doctor_says_which_ros2_this_is() -> None:
    out = _ros2("doctor", "--report")
    assert out.stdout.startswith("ros2: zenroid's ros2 (")
    assert "no ROS 2 install behind it" in out.stdout


def test_ros2_interface_and_pkg() -> None:
    shown = _ros2("interface", "show", "std_srvs/srv/SetBool")
    assert shown.returncode == 0 and "bool data" in shown.stdout and "---" in shown.stdout
    listed = _ros2("interface", "list", "-s")
    assert "Services:" in listed.stdout and "Messages:" not in listed.stdout
    assert "std_srvs/srv/Trigger" in _ros2("interface", "package", "std_srvs").stdout
    unknown = _ros2("interface", "show", "nope_msgs/msg/Nope")
    assert unknown.returncode == 1 and "nope_msgs/msg/Nope" in unknown.stderr
    assert "controller_manager spawner" in _ros2("pkg", "executables", "controller_manager").stdout
    bad = _ros2("pkg", "prefix", "no_pkg_here")
    assert bad.returncode == 1 and bad.stderr.startswith("ros2 pkg: package 'no_pkg_here' not found")


def test_ros2_run_a_served_executable_and_errors(tmp_path: Path) -> None:
    out = _ros2("run", "xacro", "xacro", "robots/simple_robot.urdf.xacro", "--ros-args", "-p", "use_sim_time:=true",
                cwd=Path(__file__).resolve().parents[2])
    assert out.returncode == 0, out.stderr
    assert "<robot" in out.stdout
    missing = _ros2("run", "xacro", "xacrox")
    assert missing.returncode == 1 and "no executable 'xacrox'" in missing.stderr and "it has: xacro" in missing.stderr
    nopkg = _ros2("run", "your_package", "joint_commander.py")
    assert nopkg.returncode == 1 and "package 'your_package' not found" in nopkg.stderr
    assert "served by zenroid: " in nopkg.stderr


RVIZ = """Panels:
  - Class: rviz_common/Displays
Visualization Manager:
  Class: ""
  Displays:
    - Class: rviz_default_plugins/Grid
      Enabled: true
      Name: Grid
    - Class: rviz_default_plugins/RobotModel
      Description Source: Topic
      Description Topic:
        Value: /humanoid/robot_description
      Enabled: true
      Name: RobotModel
    - Class: rviz_default_plugins/TF
      Enabled: true
      Name: TF
    - Class: rviz_common/Group
      Displays:
        - Class: rviz_default_plugins/MarkerArray
          Enabled: true
          Name: Plan
          Topic:
            Value: /planned_path
        - Class: rviz_default_plugins/Map
          Enabled: true
          Name: Map
          Topic:
            Value: /map
      Enabled: true
      Name: Planning
    - Class: rviz_default_plugins/Image
      Enabled: true
      Name: Camera image
      Topic:
        Value: /camera/image_raw
    - Class: rviz_default_plugins/Odometry
      Enabled: false
      Name: Odom
  Global Options:
    Fixed Frame: odom
"""


def test_rviz_config_maps_onto_the_viewer(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from nodes.viz.rviz_config import RvizConfigError, read_rviz

    config = tmp_path / "humanoid.rviz"
    config.write_text(RVIZ)
    mapping = read_rviz(config)
    assert mapping.fixed_frame == "odom" and mapping.robots == ["humanoid"]
    assert mapping.marker_topics == [("planned_path", "MarkerArray")]
    assert mapping.not_mapped == ["Map (Map, /map)"]   # the disabled Odometry is not mentioned
    assert mapping.viewer_params() == ["world_frames:=[odom, world, map]", "robots:=[humanoid]"]
    _, runs = serve.command("rviz2", "rviz2", ["-d", str(config), "--ros-args", "-r", "__node:=rviz"])
    assert runs == [["--param", "world_frames:=[odom, world, map]", "--param", "robots:=[humanoid]",
                     "--name", "rviz"]]
    printed = capsys.readouterr().out
    assert "shown: fixed frame 'odom', Grid, RobotModel (/humanoid/robot_description), TF, Plan (/planned_path)" \
        in printed
    assert "not shown by our viewer: Map (Map, /map)" in printed
    with pytest.raises(RvizConfigError, match="no 'Visualization Manager'"):
        (tmp_path / "bad.rviz").write_text("a: 1\n")
        read_rviz(tmp_path / "bad.rviz")
    _, runs = serve.command("rviz2", "rviz2", ["-d", str(tmp_path / "missing.rviz"), "-f", "map"])
    assert runs == [["--param", "world_frames:=[map, world, odom]"]]
    assert "missing.rviz: cannot read it" in capsys.readouterr().err
