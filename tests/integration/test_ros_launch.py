"""ROS launch files (Python, XML, ROS YAML) run by our launcher as real processes on a free port: the seeds'
files, event handlers, conditions, timers, namespaces, and the errors bad files get."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import msgpack
import pytest

from bench.common import ROOT, Launch, child_env

SEEDS = Path("/work/shared/seed-code")
needs_seeds = pytest.mark.skipif(not SEEDS.is_dir(), reason="the seed listings are not on this machine")

SMALL_URDF = """<?xml version="1.0"?>
<robot name="tiny">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>
  </inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def launch_cli(*argv: str, env: dict[str, str] | None = None, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "launch", *argv], capture_output=True, text=True, timeout=timeout,
                          env=child_env(env), cwd=ROOT)


def wait_output(launch: Launch, pattern: str, timeout: float = 60.0) -> re.Match[str]:
    return launch.wait_match(pattern, timeout)


def node_list(port: int) -> str:
    done = subprocess.run([sys.executable, "-m", "nodes.tools", "node", "list", "--zenoh-port", str(port)],
                          capture_output=True, text=True, timeout=30, env=child_env(), cwd=ROOT)
    return done.stdout


# -- the Python front end: handlers, timers, conditions, groups ---------------------------------------------
CHAIN = """
import sys
from launch import LaunchDescription
from launch.actions import (DeclareLaunchArgument, ExecuteProcess, GroupAction, LogInfo, OpaqueFunction,
                            RegisterEventHandler, SetLaunchConfiguration, TimerAction)
from launch.conditions import IfCondition, UnlessCondition, LaunchConfigurationEquals
from launch.event_handlers import OnProcessExit, OnProcessStart, OnProcessIO, OnShutdown
from launch.substitutions import (AndSubstitution, EqualsSubstitution, LaunchConfiguration, NotSubstitution,
                                  PathJoinSubstitution, PythonExpression, TextSubstitution, ThisLaunchFileDir)
from launch_ros.actions import Node, PushRosNamespace

def late(context):
    return [LogInfo(msg='opaque: word=' + context.launch_configurations['word'])]

def generate_launch_description():
    first = ExecuteProcess(cmd=[sys.executable, '-c', 'print("first says " + __import__("sys").argv[1])',
                                LaunchConfiguration('word')], name='first', output='screen')
    second = ExecuteProcess(cmd=['python3', '-c', 'print("second ran")'], name='second', output='screen')
    return LaunchDescription([
        DeclareLaunchArgument('word', default_value='hello'),
        DeclareLaunchArgument('flag', default_value='true'),
        SetLaunchConfiguration('double', PythonExpression(['2 * ', '21'])),
        LogInfo(msg=['double is ', LaunchConfiguration('double')]),
        LogInfo(msg='if ok', condition=IfCondition(AndSubstitution(LaunchConfiguration('flag'), 'true'))),
        LogInfo(msg='unless shown', condition=UnlessCondition(NotSubstitution(LaunchConfiguration('flag')))),
        LogInfo(msg='never shown', condition=IfCondition(EqualsSubstitution(LaunchConfiguration('word'), 'nope'))),
        LogInfo(msg='equals ok', condition=LaunchConfigurationEquals('word', 'chained')),
        LogInfo(msg=PathJoinSubstitution([ThisLaunchFileDir(), 'x', TextSubstitution(text='y')])),
        OpaqueFunction(function=late),
        GroupAction([
            PushRosNamespace('team'),
            SetLaunchConfiguration('word', 'inner'),
            Node(package='robot_state_publisher', executable='robot_state_publisher', name='rsp',
                 parameters=[{'robot_description': open(__file__.replace('chain.launch.py', 'tiny.urdf')).read()}]),
        ]),
        LogInfo(msg=['after group word=', LaunchConfiguration('word')]),
        RegisterEventHandler(OnProcessStart(target_action=first, on_start=[LogInfo(msg='first started')])),
        RegisterEventHandler(OnProcessIO(target_action=first,
                                         on_stdout=lambda event: [LogInfo(msg='io saw ' + event.text.decode().strip())])),
        RegisterEventHandler(OnProcessExit(target_action=first, on_exit=[LogInfo(msg='first exited'), second])),
        RegisterEventHandler(OnProcessExit(target_action=second,
                                           on_exit=lambda event, context: [LogInfo(msg=f'second status {event.returncode}')])),
        TimerAction(period=1.0, actions=[LogInfo(msg='timer fired')]),
        RegisterEventHandler(OnShutdown(on_shutdown=[LogInfo(msg='goodbye from OnShutdown')])),
        first,
    ])
"""


def test_python_launch_handlers_timer_group_namespace(tmp_path: Path, zenoh_port: int) -> None:
    (tmp_path / "chain.launch.py").write_text(CHAIN)
    (tmp_path / "tiny.urdf").write_text(SMALL_URDF)
    launch = Launch(str(tmp_path / "chain.launch.py"), "word:=chained", log_dir=tmp_path / "run", port=zenoh_port)
    try:
        wait_output(launch, r"second status 0")
        wait_output(launch, r"timer fired")
        launch.wait(lambda: "/team/rsp" in node_list(zenoh_port), 30, "/team/rsp on the graph")
    finally:
        launch.close()
    out = launch.output()
    for line in ("double is 42", "if ok", "unless shown", "equals ok", "opaque: word=chained", f"{tmp_path}/x/y",
                 "after group word=chained", "first started", "io saw first says chained", "first exited",
                 "[second] second ran", "goodbye from OnShutdown"):
        assert line in out, f"{line!r} missing from:\n{out}"
    assert "never shown" not in out
    order = [out.index(s) for s in ("first started", "first exited", "[second] second ran", "second status 0")]
    assert order == sorted(order), out


# -- the ROS XML and YAML front ends ------------------------------------------------------------------------
XML = """<?xml version="1.0"?>
<launch>
  <arg name="ns" default="xmlbot"/>
  <let name="greeting" value="hi $(var ns)"/>
  <log message="$(var greeting) from $(dirname)"/>
  <group>
    <push_ros_namespace namespace="$(var ns)"/>
    <node pkg="robot_state_publisher" exec="robot_state_publisher" name="rsp">
      <param name="robot_description" value="$(command 'cat $(dirname)/tiny.urdf')"/>
      <remap from="joint_states" to="js"/>
    </node>
  </group>
  <executable cmd="python3 -c 'print(40 + 2)'" name="calc" output="screen" if="$(eval '1 + 1 == 2')"/>
  <executable cmd="python3 -c 'print(13)'" name="never" unless="true"/>
</launch>
"""

ROS_YAML = """launch:
- arg: {name: ns, default: yamlbot}
- let: {name: greeting, value: "hello $(var ns)"}
- log: {message: "$(var greeting)"}
- group:
  - push_ros_namespace: {namespace: "$(var ns)"}
  - node:
      pkg: robot_state_publisher
      exec: robot_state_publisher
      name: rsp
      param:
      - {name: robot_description, value: "$(command 'cat $(dirname)/tiny.urdf')"}
- executable: {cmd: "python3 -c 'print(6 * 7)'", name: calc, output: screen}
"""


@pytest.mark.parametrize("name, text, ns", [("bot.launch.xml", XML, "xmlbot"), ("bot.launch.yaml", ROS_YAML, "yamlbot")])
def test_ros_xml_and_yaml_launch_files(tmp_path: Path, zenoh_port: int, name: str, text: str, ns: str) -> None:
    (tmp_path / name).write_text(text)
    (tmp_path / "tiny.urdf").write_text(SMALL_URDF)
    launch = Launch(str(tmp_path / name), log_dir=tmp_path / "run", port=zenoh_port)
    try:
        wait_output(launch, r"\[calc\] 42")
        launch.wait(lambda: f"/{ns}/rsp" in node_list(zenoh_port), 30, f"/{ns}/rsp on the graph")
    finally:
        launch.close()
    out = launch.output()
    assert f"hi {ns}" in out or f"hello {ns}" in out
    assert "[never]" not in out


# -- the launcher's own arguments with every format; errors ---------------------------------------------
def test_launcher_arguments_accepted_undeclared(tmp_path: Path) -> None:
    (tmp_path / "bot.launch.xml").write_text(XML)
    (tmp_path / "tiny.urdf").write_text(SMALL_URDF)
    done = launch_cli(str(tmp_path / "bot.launch.xml"), "zenoh_port:=7999", "gui:=false", "mode:=lockstep", "--print")
    assert done.returncode == 0, done.stderr
    assert "tcp/127.0.0.1:7999" in done.stdout and "xmlbot" in done.stdout


def test_bad_launch_files_named(tmp_path: Path) -> None:
    raising = tmp_path / "raises.launch.py"
    raising.write_text("from launch import LaunchDescription\n\ndef generate_launch_description():\n"
                       "    value = {}['missing']\n    return LaunchDescription([])\n")
    done = launch_cli(str(raising), "--print")
    assert done.returncode == 1 and f"{raising}:4" in done.stderr and "KeyError" in done.stderr, done.stderr

    missing_pkg = tmp_path / "pkg.launch.py"
    missing_pkg.write_text("from launch import LaunchDescription\nfrom launch_ros.actions import Node\n\n"
                           "def generate_launch_description():\n"
                           "    return LaunchDescription([Node(package='no_such_pkg', executable='x')])\n")
    done = launch_cli(str(missing_pkg), "--print")
    assert done.returncode == 2 and "no_such_pkg" in done.stderr and "searched" in done.stderr, done.stderr

    cycle = tmp_path / "cycle.launch.py"
    cycle.write_text("from launch import LaunchDescription\nfrom launch.actions import IncludeLaunchDescription\n"
                     "from launch.launch_description_sources import PythonLaunchDescriptionSource\n\n"
                     "def generate_launch_description():\n"
                     "    return LaunchDescription([IncludeLaunchDescription(PythonLaunchDescriptionSource(__file__))])\n")
    done = launch_cli(str(cycle), "--print")
    assert done.returncode == 2 and "include cycle refused" in done.stderr, done.stderr

    unknown_exe = tmp_path / "exe.launch.py"
    unknown_exe.write_text("from launch import LaunchDescription\nfrom launch.actions import ExecuteProcess\n\n"
                           "def generate_launch_description():\n"
                           "    return LaunchDescription([ExecuteProcess(cmd=['no-such-program-zr', '-x'])])\n")
    done = launch_cli(str(unknown_exe), "--print")
    assert done.returncode == 2 and "'no-such-program-zr' not found" in done.stderr and "exe.launch.py:5" in done.stderr

    required = tmp_path / "req.launch.py"
    required.write_text("from launch import LaunchDescription\nfrom launch.actions import DeclareLaunchArgument\n\n"
                        "def generate_launch_description():\n"
                        "    return LaunchDescription([DeclareLaunchArgument('robot_name')])\n")
    done = launch_cli(str(required), "--print")
    assert done.returncode == 2 and "missing required argument 'robot_name'" in done.stderr, done.stderr

    junk = tmp_path / "notes.txt"
    junk.write_text("just: [some, text\n")
    done = launch_cli(str(junk), "--print")
    assert done.returncode == 2 and "tried Python" in done.stderr and "ROS XML" in done.stderr, done.stderr


# -- the seeds' files ----------------------------------------------------------------------------------------
@needs_seeds
@pytest.mark.slow
def test_seed000_spawn_launch_puts_humanoid_at_z(tmp_path: Path, zenoh_port: int) -> None:
    """Seed 000's launch file, only its placeholder URDF path pointed at our humanoid: gazebo_ros's
    gazebo.launch.py (our simulator, paused so the pose stays), robot_state_publisher, spawn_entity.py."""
    text = (SEEDS / "000/launch/000_spawn_humanoid.launch.py").read_text()
    assert "/path/to/humanoid.urdf" in text
    (tmp_path / "spawn_humanoid.launch.py").write_text(text.replace("/path/to/humanoid.urdf",
                                                                    str(ROOT / "robots/humanoid.urdf")))
    launch = Launch(str(tmp_path / "spawn_humanoid.launch.py"), "world:=simple_lab.world", "z:=1.5", "pause:=true",
                    "sensors:=false", log_dir=tmp_path / "run", port=zenoh_port)
    try:
        session = launch.peer()
        states: list[dict] = []
        session.declare_subscriber("sim/model_states", lambda s: states.append(msgpack.unpackb(s.payload.to_bytes())))

        wait_output(launch, r"'spawn_entity' \[pid \d+\] exited with status 0", 90)
        # paused, the world publishes nothing: unpause, and the first state is where the humanoid was put
        subprocess.run([sys.executable, "-m", "nodes.tools", "sim", "unpause", "--zenoh-port", str(zenoh_port)],
                       check=True, capture_output=True, timeout=30, env=child_env(), cwd=ROOT)
        first = launch.wait(lambda: next((m for m in states if "humanoid" in m["name"]), None), 60,
                            "the humanoid in sim/model_states")
        assert "table" in first["name"], f"simple_lab.world's models missing: {first['name']}"
        z = first["pose"][first["name"].index("humanoid")]["position"]["z"]
        assert abs(z - 1.5) < 0.01, z
    finally:
        launch.close()


@needs_seeds
def test_seed002_examples_fail_as_on_ros(tmp_path: Path) -> None:
    """The listings the README says fail on ROS fail here the same way, naming the file and line."""
    launch_dir = SEEDS / "002/launch"
    done = launch_cli(str(launch_dir / "002_humanoid_complete.launch.py"), "--print")
    assert done.returncode == 1 and "NameError" in done.stderr and "002_humanoid_complete.launch.py:21" in done.stderr
    done = launch_cli(str(launch_dir / "002_shutdown_handler.fragment.launch.py"), "--print")
    assert done.returncode == 1 and "NameError" in done.stderr and "LaunchDescription" in done.stderr
    done = launch_cli(str(launch_dir / "002_humanoid_system.launch.py"), "--print")
    assert done.returncode == 1 and "perception_package" in done.stderr and "searched" in done.stderr
    done = launch_cli(str(launch_dir / "002_camera_driver.launch.py"), "--print")
    assert done.returncode == 2 and "camera_package" in done.stderr
    done = launch_cli(str(launch_dir / "002_camera_driver.launch.xml"), "--print")
    assert done.returncode == 2 and "camera_package" in done.stderr


MOTOR_NODE = """#!/usr/bin/env python3
import signal, sys, time
print('motor_node argv: ' + ' '.join(sys.argv[1:]), flush=True)
signal.signal(signal.SIGINT, lambda *a: sys.exit(0))
while True:
    time.sleep(0.1)
"""


@needs_seeds
def test_seed002_examples_do_what_they_say(tmp_path: Path, zenoh_port: int) -> None:
    """The camera launch (Python and XML) and the OnShutdown fragment, with their packages made real and the
    fragment's imports added: parameters, remappings, names reach the node as ROS passes them; OnShutdown logs."""
    for package, executable in (("camera_package", "camera_node"), ("motor_controller", "motor_node")):
        folder = tmp_path / "src" / package
        (folder / "scripts").mkdir(parents=True)
        (folder / "package.xml").write_text(f"<package format='3'><name>{package}</name><version>0.0.0</version>"
                                            "<description>t</description><maintainer email='a@b.c'>a</maintainer>"
                                            "<license>MIT</license></package>")
        script = folder / "scripts" / executable
        script.write_text(MOTOR_NODE)
        script.chmod(0o755)
    env = child_env({"ROS_PACKAGE_PATH": str(tmp_path / "src")})
    for name in ("002_camera_driver.launch.py", "002_camera_driver.launch.xml"):
        done = launch_cli(str(SEEDS / "002/launch" / name), "--print", env={"ROS_PACKAGE_PATH": str(tmp_path / "src")})
        assert done.returncode == 0, done.stderr
        assert "__node:=camera_driver" in done.stdout and "/camera/image:=/perception/camera/rgb" in done.stdout
    fragment = (SEEDS / "002/launch/002_shutdown_handler.fragment.launch.py").read_text()
    fixed = "from launch import LaunchDescription\nfrom launch_ros.actions import Node\n" + fragment
    (tmp_path / "shutdown.launch.py").write_text(fixed)
    launch = Launch(str(tmp_path / "shutdown.launch.py"), log_dir=tmp_path / "run", port=zenoh_port, env=env)
    try:
        wait_output(launch, r"motor_node argv")
        time.sleep(0.5)
    finally:
        launch.close()
    assert "Shutting down motor controller..." in launch.output()


@needs_seeds
def test_seed003_launch_runs(tmp_path: Path, zenoh_port: int) -> None:
    """Seed 003's launch file in its package (run as `ros2 launch robot_controller_lab simple_robot.launch.py`):
    as printed, xacro refuses the file (a comment before <?xml ?>, as on ROS); with that line removed,
    robot_state_publisher serves the xacro's robot_description and the two spawners run."""
    package = tmp_path / "src" / "robot_controller_lab"
    (package / "urdf").mkdir(parents=True)
    (package / "launch").mkdir()
    (package / "package.xml").write_text("<package format='3'><name>robot_controller_lab</name><version>0.0.0</version>"
                                         "<description>t</description><maintainer email='a@b.c'>a</maintainer>"
                                         "<license>MIT</license></package>")
    xacro = (SEEDS / "003/urdf/003_simple_robot.urdf.xacro").read_text()
    (package / "urdf/simple_robot.urdf.xacro").write_text(xacro)
    (package / "launch/simple_robot.launch.py").write_text((SEEDS / "003/launch/003_simple_robot.launch.py").read_text())
    env = {"ROS_PACKAGE_PATH": str(tmp_path / "src")}
    done = launch_cli("robot_controller_lab", "simple_robot.launch.py", "--print", env=env)
    assert done.returncode == 2 and "simple_robot.launch.py:14" in done.stderr, done.stderr
    assert "XML or text declaration not at start of entity" in done.stderr, done.stderr

    first, rest = xacro.split("\n", 1)
    assert first.startswith("<!--")
    (package / "urdf/simple_robot.urdf.xacro").write_text(rest)
    launch = Launch("robot_controller_lab", "simple_robot.launch.py", log_dir=tmp_path / "run", port=zenoh_port,
                    env=child_env(env))
    try:
        launch.wait(lambda: "/robot_state_publisher" in node_list(zenoh_port), 60, "robot_state_publisher")
        echo = subprocess.run([sys.executable, "-m", "nodes.tools", "topic", "echo", "/robot_description", "--once",
                               "--zenoh-port", str(zenoh_port)], capture_output=True, text=True, timeout=60,
                              env=child_env(), cwd=ROOT)
        assert "joint1" in echo.stdout and "simple_robot" in echo.stdout, echo.stdout + echo.stderr
        assert len(launch.node_pids("spawner")) == 1 and len(launch.node_pids("spawner_2")) == 1
    finally:
        launch.close()


HEADER = "from launch import LaunchDescription\nfrom launch_ros.actions import Node\n"


def _packages(root: Path, *pairs: tuple[str, str]) -> dict[str, str]:
    for package, executable in pairs:
        folder = root / package
        (folder / "scripts").mkdir(parents=True, exist_ok=True)
        (folder / "package.xml").write_text(f"<package format='3'><name>{package}</name><version>0.0.0</version>"
                                            "<description>t</description><maintainer email='a@b.c'>a</maintainer>"
                                            "<license>MIT</license></package>")
        script = folder / "scripts" / executable
        script.write_text(MOTOR_NODE)
        script.chmod(0o755)
    return {"ROS_PACKAGE_PATH": str(root)}


@needs_seeds
def test_seed002_snippets_as_on_ros(tmp_path: Path) -> None:
    """Seed 002's Node snippets (wrapped in a launch file with their imports) and its use_sim fragment: names,
    namespaces and remappings reach the command line as ROS passes them; parameter_files= and the missing
    gazebo executable fail as on ROS."""
    env = _packages(tmp_path / "src", ("my_package", "my_node"), ("planner", "planner_node"),
                    ("motor_controller", "motor_node"), ("realsense2_camera", "realsense2_camera_node"))
    snippets = SEEDS / "002/launch/snippets"

    def wrapped(name: str) -> Path:
        body = "\n".join("        " + line for line in (snippets / name).read_text().splitlines())
        path = tmp_path / name.replace(".fragment.py", ".launch.py")
        path.write_text(HEADER + "\ndef generate_launch_description():\n    return LaunchDescription([\n"
                        + body + "\n    ])\n")
        return path

    done = launch_cli(str(wrapped("002_node_basic.fragment.py")), "--print", env=env)
    assert done.returncode == 0, done.stderr
    assert "__node:=my_node_instance" in done.stdout and "__ns:=/perception" in done.stdout
    done = launch_cli(str(wrapped("002_node_remapping.fragment.py")), "--print", env=env)
    assert done.returncode == 0, done.stderr
    assert "/input/goal:=/navigation/goal" in done.stdout and "/output/path:=/control/path" in done.stdout
    done = launch_cli(str(wrapped("002_node_parameters.fragment.py")), "--print", env=env)
    assert done.returncode == 1 and "TypeError" in done.stderr and "parameter_files" in done.stderr, done.stderr
    assert "002_node_parameters.launch.py:" in done.stderr

    system = tmp_path / "system.launch.py"
    system.write_text(HEADER + (SEEDS / "002/launch/002_system.fragment.launch.py").read_text())
    done = launch_cli(str(system), "--print", env=env)
    assert done.returncode == 0 and "realsense2_camera_node" in done.stdout and "gazebo_ros" not in done.stdout
    done = launch_cli(str(system), "use_sim:=true", "--print", env=env)
    assert done.returncode == 2 and "gazebo_ros" in done.stderr and "'gazebo'" in done.stderr, done.stderr


def test_xml_container_and_load_composable_node(tmp_path: Path) -> None:
    (tmp_path / "c.launch.xml").write_text("""<launch>
  <node_container pkg="rclcpp_components" exec="component_container" name="box" namespace="">
    <composable_node pkg="nodes.sim" plugin="nodes.sim.node::SimulatorNode" name="simulator">
      <param name="mode" value="lockstep"/>
    </composable_node>
  </node_container>
  <load_composable_node target="box">
    <composable_node pkg="nodes.control" plugin="nodes.control.node::ControllerManagerNode" name="controller_manager"
                     namespace="humanoid"><remap from="a" to="b"/></composable_node>
  </load_composable_node>
</launch>
""")
    done = launch_cli(str(tmp_path / "c.launch.xml"), "--print")
    assert done.returncode == 0, done.stderr
    assert "nodes.core.container" in done.stdout and "ControllerManagerNode" in done.stdout and "a:=b" in done.stdout


CHAINED = """
import os
from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import ExecuteProcess, IncludeLaunchDescription, RegisterEventHandler
from launch.event_handlers import OnProcessExit
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch_ros.actions import Node

def generate_launch_description():
    share = get_package_share_directory('zenroid_description')
    gazebo = IncludeLaunchDescription(PythonLaunchDescriptionSource(
        [os.path.join(get_package_share_directory('gazebo_ros'), 'launch'), '/gazebo.launch.py']))
    with open(os.path.join(share, 'urdf', 'humanoid.urdf')) as file:
        params = {'robot_description': file.read()}
    rsp = Node(package='robot_state_publisher', executable='robot_state_publisher', output='screen',
               parameters=[params])
    spawn_entity = Node(package='gazebo_ros', executable='spawn_entity.py',
                        arguments=['-topic', 'robot_description', '-entity', 'humanoid', '-z', '0.93'], output='screen')
    load_jsb = ExecuteProcess(cmd=['ros2', 'control', 'load_controller', '--set-state', 'active',
                                   'joint_state_broadcaster'], output='screen')
    load_jtc = ExecuteProcess(cmd=['ros2', 'control', 'load_controller', '--set-state', 'active',
                                   'joint_trajectory_controller'], output='screen')
    return LaunchDescription([
        RegisterEventHandler(event_handler=OnProcessExit(target_action=spawn_entity, on_exit=[load_jsb])),
        RegisterEventHandler(event_handler=OnProcessExit(target_action=load_jsb, on_exit=[load_jtc])),
        gazebo, rsp, spawn_entity,
    ])
"""


@pytest.mark.slow
def test_gazebo_ros2_control_style_chain(tmp_path: Path, zenoh_port: int) -> None:
    """gazebo_ros2_control's demo pattern at the root namespace: gazebo.launch.py included, spawn_entity.py from
    /robot_description, then `ros2 control load_controller --set-state active` for the JSB and the JTC chained
    with OnProcessExit; the URDF's gazebo_ros2_control plugin starts the controller manager, as in Gazebo;
    /joint_states flows and both controllers are active."""
    (tmp_path / "chain.launch.py").write_text(CHAINED)
    launch = Launch(str(tmp_path / "chain.launch.py"), "sensors:=false", log_dir=tmp_path / "run", port=zenoh_port)
    try:
        session = launch.peer()
        states: list[bytes] = []
        session.declare_subscriber("joint_states", lambda s: states.append(s.payload.to_bytes()))
        launch.wait(lambda: len(states) > 10, 120, "/joint_states")
        wait_output(launch, r"'ros2_2' \[pid \d+\] exited with status 0", 120)
        listed = subprocess.run([sys.executable, "-m", "nodes.tools", "control", "list_controllers", "--ns", "/",
                                 "--zenoh-port", str(zenoh_port)], capture_output=True, text=True, timeout=60,
                                env=child_env(), cwd=ROOT)
        assert re.search(r"joint_state_broadcaster\s.*active", listed.stdout), listed.stdout + listed.stderr
        assert re.search(r"joint_trajectory_controller\s.*active", listed.stdout), listed.stdout
    finally:
        launch.close()
    out = launch.output()
    order = [out.index(s) for s in ("'spawn_entity' [pid", "started 'ros2' [pid", "'ros2' [pid", "started 'ros2_2'")]
    assert order == sorted(order), out


def test_python_includes_xml_and_yaml(tmp_path: Path) -> None:
    """The ROS docs' mixed-format example: a .launch.py including ROS XML and ROS YAML files (launch_xml's and
    launch_yaml's sources), each in its own pushed namespace, arguments passed down."""
    (tmp_path / "bot.launch.xml").write_text(XML)
    (tmp_path / "bot.launch.yaml").write_text(ROS_YAML)
    (tmp_path / "tiny.urdf").write_text(SMALL_URDF)
    (tmp_path / "mixed.launch.py").write_text("""
from launch import LaunchDescription
from launch.actions import GroupAction, IncludeLaunchDescription
from launch.substitutions import ThisLaunchFileDir
from launch_ros.actions import PushROSNamespace
from launch_xml.launch_description_sources import XMLLaunchDescriptionSource
from launch_yaml.launch_description_sources import YAMLLaunchDescriptionSource

def generate_launch_description():
    return LaunchDescription([
        GroupAction([PushROSNamespace('left'), IncludeLaunchDescription(
            XMLLaunchDescriptionSource([ThisLaunchFileDir(), '/bot.launch.xml']), launch_arguments={'ns': 'a'}.items())]),
        GroupAction([PushROSNamespace('right'), IncludeLaunchDescription(
            YAMLLaunchDescriptionSource([ThisLaunchFileDir(), '/bot.launch.yaml']), launch_arguments=[('ns', 'b')])]),
    ])
""")
    done = launch_cli(str(tmp_path / "mixed.launch.py"), "--print")
    assert done.returncode == 0, done.stderr
    assert "__ns:=/left/a" in done.stdout or "namespace: left/a" in done.stdout, done.stdout
    assert "namespace: right/b" in done.stdout, done.stdout


# -- examples/cart_demo: a package written the gazebo_ros2_control way ---------------------------------------
CART_DEMO = {"ROS_PACKAGE_PATH": str(ROOT / "examples")}


def _cart_joint(states: list[bytes]) -> tuple[float, float] | None:
    """(position, velocity) of slider_to_cart in the newest /joint_states."""
    if not states:
        return None
    msg = msgpack.unpackb(states[-1])
    index = msg["name"].index("slider_to_cart")
    return msg["position"][index], msg["velocity"][index]


def _put_commands(session, controller: str, value: float) -> None:
    import msgs

    command = msgs.get_type("std_msgs/msg/Float64MultiArray")(data=[value])
    session.put(f"{controller}/commands", msgs.encode(command))


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["position", "velocity", "effort"])
def test_cart_demo_package(tmp_path: Path, zenoh_port: int, variant: str) -> None:
    """`ros2 launch cart_demo cart_example_VARIANT.launch.py`: gazebo.launch.py included, the xacro (its
    $(find cart_demo) include) spawned from /robot_description by spawn_entity.py, the controllers loaded one
    after the other (load_controller or spawner chained with OnProcessExit) by the plugin's controller
    manager. The cart starts at the state interface's initial_value; position: example_position.py's
    FollowJointTrajectory goal (rclpy) takes it through -1 to 0.5; velocity and effort: a command moves it
    in the commanded direction; the velocity cart's IMU publishes. Effort also: `spawner NAME -t TYPE --load-only` leaves it loaded, unconfigured."""
    command = (sys.executable, "-m", "nodes.tools.ros2", "launch")
    sensors = "sensors:=true" if variant == "velocity" else "sensors:=false"   # the velocity cart has an IMU
    launch = Launch("cart_demo", f"cart_example_{variant}.launch.py", sensors, log_dir=tmp_path / "run",
                    port=zenoh_port, command=command, env=child_env(CART_DEMO))
    try:
        session = launch.peer()
        states: list[bytes] = []
        session.declare_subscriber("joint_states", lambda s: states.append(s.payload.to_bytes()))
        controller = {"position": "joint_trajectory_controller", "velocity": "velocity_controller",
                      "effort": "effort_controller"}[variant]
        imu: list[bytes] = []
        session.declare_subscriber("imu_sensor_broadcaster/imu", lambda s: imu.append(s.payload.to_bytes()))
        last = "imu_sensor_broadcaster" if variant == "velocity" else controller   # the chain's last one
        wait_output(launch, rf"(Successfully loaded controller {last} into state active"
                            rf"|Configured and activated {last})", 150)
        start, _ = launch.wait(lambda: _cart_joint(states), 60, "slider_to_cart in /joint_states")
        assert start == pytest.approx(0.0 if variant == "velocity" else 1.0, abs=0.01)   # initial_value
        if variant == "position":
            lowest = [start]
            session.declare_subscriber("joint_states", lambda s: lowest.append(_cart_joint([s.payload.to_bytes()])[0]))
            done = subprocess.run([sys.executable, "-m", "nodes.tools.ros2", "run", "cart_demo", "example_position.py",
                                   "0.5"], capture_output=True, text=True, timeout=90,
                                  env=child_env({**CART_DEMO, "ZENOH_CONNECT": launch.endpoint}), cwd=ROOT)
            assert done.returncode == 0 and "result: error_code 0" in done.stdout, done.stdout + done.stderr
            launch.wait(lambda: abs(_cart_joint(states)[0] - 0.5) < 0.02, 10, "the cart at 0.5")
            assert min(lowest) < -0.8, min(lowest)       # it went through the trajectory's -1 on the way
        else:
            value, sign = (-1.0, -1) if variant == "velocity" else (-5.0, -1)
            moved = lambda: (_put_commands(session, controller, value),   # noqa: E731
                             (p := _cart_joint(states)[0]) * sign > sign * start + 0.3 and p)[1]
            launch.wait(moved, 30, f"the cart moved by its {variant} command", interval=0.1)
            _, velocity = _cart_joint(states)
            assert velocity * sign > 0.1, velocity
            if variant == "velocity":
                assert velocity == pytest.approx(value, abs=0.05)
                # the IMU riding on the cart: its frame, and gravity's reaction along z
                reading = msgpack.unpackb(launch.wait(lambda: imu and imu[-1], 30, "/imu_sensor_broadcaster/imu"))
                assert reading["header"]["frame_id"] == "imu"
                assert reading["linear_acceleration"]["z"] == pytest.approx(9.81, abs=0.3), reading
            else:   # the spawner's other options: a type given on the command line, loaded only
                ros2 = [sys.executable, "-m", "nodes.tools.ros2"]
                done = subprocess.run([*ros2, "run", "controller_manager", "spawner", "extra_broadcaster", "-t",
                                       "joint_state_broadcaster/JointStateBroadcaster", "--load-only", "-c",
                                       "/controller_manager"], capture_output=True, text=True, timeout=60,
                                      env=child_env({"ZENOH_CONNECT": launch.endpoint}), cwd=ROOT)
                assert done.returncode == 0 and "Loaded extra_broadcaster" in done.stdout, done.stdout + done.stderr
                listed = subprocess.run([*ros2, "control", "list_controllers"], capture_output=True, text=True,
                                        timeout=60, env=child_env({"ZENOH_CONNECT": launch.endpoint}), cwd=ROOT)
                assert re.search(r"extra_broadcaster\s+joint_state_broadcaster/JointStateBroadcaster\s+unconfigured",
                                 listed.stdout), listed.stdout + listed.stderr
    finally:
        launch.close()
    out = launch.output()
    order = [out.index(s) for s in ("'spawn_entity' [pid", "controller manager /controller_manager with",
                                    "loaded controller 'joint_state_broadcaster'", f"loaded controller '{controller}'",
                                    f"loaded controller '{last}'")]
    assert order == sorted(order), out


LIFECYCLE_NODE = """#!/usr/bin/env python3
import rclpy
from rclpy.lifecycle import Node, TransitionCallbackReturn


class Talker(Node):
    def on_configure(self, state):
        self.get_logger().info('on_configure called')
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state):
        self.get_logger().info('on_activate called')
        return super().on_activate(state)


rclpy.init()
node = Talker('talker')
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
"""

LIFECYCLE_LAUNCH = """
from launch import LaunchDescription
from launch.actions import EmitEvent, LogInfo, RegisterEventHandler
from launch_ros.actions import LifecycleNode
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events import matches_action
from launch_ros.events.lifecycle import ChangeState
from lifecycle_msgs.msg import Transition


def generate_launch_description():
    talker = LifecycleNode(package='lc_pkg', executable='talker', name='talker', namespace='', output='screen')
    configure = EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(talker),
                                            transition_id=Transition.TRANSITION_CONFIGURE))
    on_inactive = RegisterEventHandler(OnStateTransition(
        target_lifecycle_node=talker, goal_state='inactive',
        entities=[LogInfo(msg="talker reached 'inactive', activating"),
                  EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(talker),
                                              transition_id=Transition.TRANSITION_ACTIVATE))]))
    on_active = RegisterEventHandler(OnStateTransition(
        target_lifecycle_node=talker, goal_state='active',
        entities=lambda event, context: [LogInfo(msg=f'{event.node_name} went {event.start_state} -> {event.goal_state}')]))
    auto = LifecycleNode(package='lc_pkg', executable='talker', name='auto', namespace='', autostart=True)
    return LaunchDescription([on_inactive, on_active, talker, configure, auto])
"""


@pytest.mark.slow
def test_lifecycle_node_driven_by_change_state_events(tmp_path: Path, zenoh_port: int) -> None:
    """launch_ros' lifecycle pattern: EmitEvent(ChangeState(configure)) once the node is up, an
    OnStateTransition(goal_state='inactive') handler that emits the activate, another that sees it active;
    LifecycleNode(autostart=True) configured and activated by itself."""
    env = _packages(tmp_path / "src", ("lc_pkg", "talker"))
    (tmp_path / "src/lc_pkg/scripts/talker").write_text(LIFECYCLE_NODE)
    (tmp_path / "lifecycle.launch.py").write_text(LIFECYCLE_LAUNCH)
    launch = Launch(str(tmp_path / "lifecycle.launch.py"), log_dir=tmp_path / "run", port=zenoh_port,
                    env=child_env(env))
    try:
        wait_output(launch, r"/talker went inactive -> active", 90)
        wait_output(launch, r"'change_state_configure_activate' \[pid \d+\] exited with status 0", 60)
        for name in ("/talker", "/auto"):   # auto: LifecycleNode(autostart=True)
            state = subprocess.run([sys.executable, "-m", "nodes.tools.ros2", "lifecycle", "get", name],
                                   capture_output=True, text=True, timeout=60,
                                   env=child_env({"ZENOH_CONNECT": launch.endpoint}), cwd=ROOT)
            assert state.stdout.startswith("active"), name + state.stdout + state.stderr
    finally:
        launch.close()
    out = launch.output()
    # the talker's own lines and the launcher's (auto's on_activate may come at any point)
    talker = "\n".join(line for line in out.splitlines() if line.startswith(("[talker]", "[launch]")))
    order = [talker.index(s) for s in ("on_configure called", "talker reached 'inactive', activating",
                                       "on_activate called", "/talker went inactive -> active")]
    assert order == sorted(order), out
