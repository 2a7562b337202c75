"""The executables zenroid serves for ROS packages, started the ROS way (``nodes.packages.serve PKG EXEC
--ros-args ...``, what ``ros2 run`` and launch_ros' ``Node`` run) as real processes over real Zenoh:
joint_state_publisher (description as a parameter and from the topic), joint_state_publisher_gui (its page
in headless Chromium), tf2_ros' static_transform_publisher (both argument forms)."""

from __future__ import annotations

import json
import math
import re
import threading
import urllib.request

import pytest
import zenoh

import msgs
from tests.conftest import wait_until

pytestmark = pytest.mark.slow

JointState = msgs.get_type("sensor_msgs/msg/JointState")
String = msgs.get_type("std_msgs/msg/String")
TFMessage = msgs.get_type("tf2_msgs/msg/TFMessage")

CART = """<robot name="cart">
  <link name="base"/><link name="slider"/><link name="arm"/><link name="wheel"/><link name="twin"/><link name="cam"/>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="slider"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" effort="10" velocity="1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="slider"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="0.2" upper="1.0" effort="10" velocity="1"/></joint>
  <joint name="spin" type="continuous"><parent link="base"/><child link="wheel"/><axis xyz="0 1 0"/></joint>
  <joint name="shadow" type="revolute"><parent link="base"/><child link="twin"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/><mimic joint="shoulder" multiplier="2" offset="0.1"/></joint>
  <joint name="mount" type="fixed"><parent link="arm"/><child link="cam"/></joint>
</robot>"""


class Latest:
    """The newest message on a key, decoded."""

    def __init__(self, session, key: str, msg_type) -> None:
        self.msg = None
        self.count = 0
        self._lock = threading.Lock()
        self._type = msg_type
        self._sub = session.declare_subscriber(key, self._on)

    def _on(self, sample) -> None:
        with self._lock:
            self.msg = msgs.decode(self._type, sample.payload.to_bytes())
            self.count += 1

    def positions(self) -> dict[str, float] | None:
        with self._lock:
            return None if self.msg is None else dict(zip(self.msg.name, self.msg.position))


def serve(processes, zenoh_port: int, package: str, executable: str, *args: str):
    return processes.start("-m", "nodes.packages.serve", package, executable, *args,
                           name=executable)


def test_joint_state_publisher_from_the_parameter(processes, zenoh_port, session) -> None:
    states = Latest(session, "joint_states", JointState)
    serve(processes, zenoh_port, "joint_state_publisher", "joint_state_publisher",
          "--ros-args", "-p", f"robot_description:={CART}", "-p", "rate:=20.0")
    got = wait_until(states.positions, timeout=30, message="joint_states from joint_state_publisher")
    # 0 where the limits allow it, the middle where they do not; the mimic joint follows; no fixed joint
    assert list(got) == ["rail", "shoulder", "spin", "shadow"]
    assert got["rail"] == 0.0 and got["spin"] == 0.0
    assert got["shoulder"] == pytest.approx(0.6)
    assert got["shadow"] == pytest.approx(2 * 0.6 + 0.1)


def test_joint_state_publisher_from_the_topic_in_a_namespace(processes, zenoh_port, session) -> None:
    description = session.declare_publisher("cart/robot_description")
    # our robot_state_publisher publishes the latched description the JSP reads when it has no parameter
    serve(processes, zenoh_port, "robot_state_publisher", "robot_state_publisher",
          "--ros-args", "-r", "__ns:=/cart", "-p", f"robot_description:={CART}")
    states = Latest(session, "cart/joint_states", JointState)
    serve(processes, zenoh_port, "joint_state_publisher", "joint_state_publisher", "--ros-args", "-r", "__ns:=/cart",
          "-p", "zeros:={rail: 0.25}")
    got = wait_until(states.positions, timeout=30, message="cart/joint_states from the topic's description")
    assert got["rail"] == 0.25 and got["shoulder"] == pytest.approx(0.6)
    del description


def test_static_transform_publisher_both_forms(processes, zenoh_port, session) -> None:
    serve(processes, zenoh_port, "tf2_ros", "static_transform_publisher",
          "--x", "1", "--y", "2", "--z", "3", "--yaw", str(math.pi / 2), "--frame-id", "world", "--child-frame-id", "a")
    serve(processes, zenoh_port, "tf2_ros", "static_transform_publisher", "0", "0", "0.5", "0", "0", "0", "1",
          "a", "b")

    def frames():
        # every latched publisher's answer (ROS's transient-local tf_static gives a late joiner all of them)
        found: dict[str, dict] = {}
        for reply in session.get("tf_static", timeout=2.0, target=zenoh.QueryTarget.ALL,
                                 consolidation=zenoh.ConsolidationMode.NONE):
            if reply.ok is not None:
                for t in msgs.decode(TFMessage, reply.ok.payload.to_bytes()).transforms:
                    found[t.child_frame_id] = t
        return found if {"a", "b"} <= set(found) else None

    found = wait_until(frames, timeout=30, message="both static transforms on tf_static")
    a, b = found["a"], found["b"]
    assert a.header.frame_id == "world" and (a.transform.translation.x, a.transform.translation.z) == (1.0, 3.0)
    assert (a.transform.rotation.z, a.transform.rotation.w) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5)))
    assert b.header.frame_id == "a" and b.transform.translation.z == 0.5 and b.transform.rotation.w == 1.0


def test_static_transform_publisher_refuses_bad_arguments(processes, zenoh_port) -> None:
    proc = serve(processes, zenoh_port, "tf2_ros", "static_transform_publisher", "1", "2", "world", "a")
    assert proc.wait(timeout=60) == 2
    assert "expected 'x y z yaw pitch roll frame_id child_frame_id'" in processes.output(proc)


def test_joint_state_publisher_gui_page_moves_a_joint(processes, zenoh_port, session) -> None:
    from tests.support.browser import HeadlessBrowser, find_browser

    states = Latest(session, "joint_states", JointState)
    proc = serve(processes, zenoh_port, "joint_state_publisher_gui", "joint_state_publisher_gui",
                 "--ros-args", "-p", f"robot_description:={CART}", "-p", "rate:=20.0")
    url = wait_until(lambda: (m := re.search(r"joint_state_publisher_gui: (http://\S+)", processes.output(proc)))
                     and m[1], timeout=30, message="the sliders page's URL printed")
    joints = json.loads(urllib.request.urlopen(f"{url}joints", timeout=10).read())["joints"]
    assert [(j["name"], j["lower"], j["upper"]) for j in joints] == [
        ("rail", -0.5, 0.5), ("shoulder", 0.2, 1.0), ("spin", -math.pi, math.pi)]
    wait_until(states.positions, timeout=30, message="joint_states from the GUI publisher")
    if find_browser() is None:
        pytest.skip("no Chromium here: the page's slider was not driven (the JSON side was checked)")
    with HeadlessBrowser(timeout=120) as browser:
        browser.navigate(url)
        wait_until(lambda: browser.evaluate("document.querySelectorAll('input[type=range]').length") == 3,
                   timeout=60, message="three sliders on the page (the mimic joint has none)")
        assert browser.evaluate("[...document.querySelectorAll('input[type=range]')].map(s => "
                                "[s.dataset.joint, +s.min, +s.max])") == [
            ["rail", -0.5, 0.5], ["shoulder", 0.2, 1.0], ["spin", -math.pi, math.pi]]
        browser.evaluate("(() => { const s = document.getElementById('joint-shoulder'); s.value = 0.9; "
                         "s.dispatchEvent(new Event('input')); })()")
        got = wait_until(lambda: (p := states.positions()) and abs(p["shoulder"] - 0.9) < 1e-6 and p, timeout=30,
                         message="the slider's value in joint_states")
        assert got["shadow"] == pytest.approx(2 * 0.9 + 0.1)
        # beyond the limits is clamped, as the slider itself does
        browser.evaluate("fetch('/joint', {method: 'POST', body: JSON.stringify({name: 'rail', position: 7})})")
        wait_until(lambda: (p := states.positions()) and p["rail"] == 0.5, timeout=30, message="rail clamped at 0.5")


MOCK_CART = """<robot name="cart">
  <link name="base"/><link name="slider"/>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="slider"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="2"/></joint>
  <ros2_control name="cart" type="system">
    <hardware><plugin>mock_components/GenericSystem</plugin>{params}</hardware>
    <joint name="rail">
      <command_interface name="{command}"/>
      <state_interface name="position"><param name="initial_value">0.3</param></state_interface>
      <state_interface name="velocity"/>
    </joint>
  </ros2_control>
</robot>"""

MOCK_CONTROLLERS = """controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    forward_controller:
      type: forward_command_controller/ForwardCommandController
forward_controller:
  ros__parameters:
    joints: [rail]
    interface_name: {command}
"""


@pytest.mark.parametrize(("command", "params", "value", "expect"), [
    ("position", "", 0.7, lambda p, v: p == pytest.approx(0.7)),
    ("velocity", '<param name="calculate_dynamics">true</param>', 0.5,
     lambda p, v: v == pytest.approx(0.5) and p > 0.45),   # integrated: moving from 0.3 at 0.5 m/s
])
def test_ros2_control_node_with_mock_hardware(processes, zenoh_port, session, tmp_path, command, params, value,
                                              expect) -> None:
    Float64MultiArray = msgs.get_type("std_msgs/msg/Float64MultiArray")
    config = tmp_path / "controllers.yaml"
    config.write_text(MOCK_CONTROLLERS.format(command=command))
    states = Latest(session, "joint_states", JointState)
    serve(processes, zenoh_port, "controller_manager", "ros2_control_node",
          "--ros-args", "-p", f"robot_description:={MOCK_CART.format(command=command, params=params)}",
          "--params-file", str(config))
    spawner = serve(processes, zenoh_port, "controller_manager", "spawner", "joint_state_broadcaster",
                    "forward_controller", "--controller-manager-timeout", "60")
    assert spawner.wait(timeout=120) == 0, processes.output(spawner)
    # the state interface's initial_value is where the joint starts
    first = wait_until(states.positions, timeout=30, message="joint_states from the mock hardware's broadcaster")
    assert first["rail"] == pytest.approx(0.3)
    velocities = lambda: dict(zip(states.msg.name, states.msg.velocity))  # noqa: E731
    payload = msgs.encode(Float64MultiArray(data=[value]))
    wait_until(lambda: session.put("forward_controller/commands", payload) or
               expect(states.positions()["rail"], velocities()["rail"]),
               timeout=30, interval=0.1, message=f"the {command} command mirrored into joint_states")


def test_rviz2_opens_our_viewer_with_the_config_mapped(processes, zenoh_port, tmp_path) -> None:
    config = tmp_path / "view.rviz"
    config.write_text("Visualization Manager:\n  Displays:\n    - Class: rviz_default_plugins/RobotModel\n"
                      "      Name: RobotModel\n      Description Topic: {Value: /robot_description}\n"
                      "    - Class: rviz_default_plugins/Path\n      Name: Path\n      Topic: {Value: /plan}\n"
                      "  Global Options: {Fixed Frame: map}\n")
    proc = serve(processes, zenoh_port, "rviz2", "rviz2", "-d", str(config), "--ros-args", "-r", "__node:=rviz2")
    wait_until(lambda: "Rerun web viewer:" in processes.output(proc), timeout=90, message="the viewer's URL")
    out = processes.output(proc)
    assert f"rviz2: {config} shown: fixed frame 'map', RobotModel (/robot_description)" in out
    assert "rviz2: not shown by our viewer: Path (Path, /plan)" in out
    assert proc.poll() is None, out


PLUGIN_CART = """<robot name="cart">
  <link name="world"/>
  <link name="base"><inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>
    </inertial><collision><geometry><box size="0.4 0.4 0.1"/></geometry></collision></link>
  <link name="slider"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 0.5"/></joint>
  <joint name="slider" type="prismatic"><parent link="base"/><child link="slider"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="100" velocity="2"/></joint>
  <ros2_control name="GazeboSystem" type="system">
    <hardware><plugin>gazebo_ros2_control/GazeboSystem</plugin></hardware>
    <joint name="slider">
      <command_interface name="position"/>
      <state_interface name="position"><param name="initial_value">0.2</param></state_interface>
      <state_interface name="velocity"/>
    </joint>
  </ros2_control>
  <gazebo>
    <plugin filename="libgazebo_ros2_control.so" name="gazebo_ros2_control">
      <ros><namespace>/cart</namespace></ros>
      <parameters>{controllers}</parameters>
    </plugin>
  </gazebo>
</robot>"""

PLUGIN_CONTROLLERS = """controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    joint_trajectory_controller:
      type: joint_trajectory_controller/JointTrajectoryController
joint_trajectory_controller:
  ros__parameters:
    joints: [slider]
    command_interfaces: [position]
    state_interfaces: [position, velocity]
"""


def test_gazebo_ros2_control_plugin_starts_the_manager(processes, zenoh_port, session, tmp_path) -> None:
    """gazebo_ros2_control's way: the URDF's plugin (namespace, parameters file) gives the spawned robot its
    controller manager; the state interface's initial_value is where the joint starts; a trajectory moves it."""
    import subprocess
    import sys

    controllers = tmp_path / "controllers.yaml"
    controllers.write_text(PLUGIN_CONTROLLERS)
    urdf = tmp_path / "cart.urdf"
    urdf.write_text(PLUGIN_CART.format(controllers=controllers))
    job = processes.start("-m", "nodes.tools.ros2", "launch", "gazebo_ros", "gzserver.launch.py",
                          "world:=empty.world", "sensors:=false", name="gzserver")
    wait_until(lambda: "simulator ready" in processes.output(job), timeout=90, message="the simulator")
    env = processes.env()

    def ros2(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "nodes.tools.ros2", *args], env=env, capture_output=True,
                              text=True, timeout=timeout)

    spawned = ros2("run", "gazebo_ros", "spawn_entity.py", "-entity", "cart", "-file", str(urdf))
    assert spawned.returncode == 0, spawned.stdout + spawned.stderr
    wait_until(lambda: "controller manager /cart/controller_manager" in processes.output(job), timeout=60,
               message="the plugin's controller manager")
    states = Latest(session, "cart/joint_states", JointState)
    for name in ("joint_state_broadcaster", "joint_trajectory_controller"):
        loaded = wait_until(lambda n=name: (done := ros2("control", "load_controller", "--set-state", "active", n,
                                                         "-c", "/cart/controller_manager")).returncode == 0 and done,
                            timeout=90, interval=1.0, message=f"{name} loaded and active")
        assert "into state active" in loaded.stdout
    first = wait_until(states.positions, timeout=30, message="cart/joint_states")
    assert first["slider"] == pytest.approx(0.2, abs=0.02)    # initial_value
    sent = ros2("topic", "pub", "--once", "/cart/joint_trajectory_controller/joint_trajectory",
                "trajectory_msgs/msg/JointTrajectory",
                "{joint_names: [slider], points: [{positions: [0.5], time_from_start: {sec: 1}}]}")
    assert sent.returncode == 0, sent.stderr
    wait_until(lambda: abs(states.positions()["slider"] - 0.5) < 0.02, timeout=60, message="the cart at 0.5")
