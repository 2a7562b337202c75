"""Programs written the ROS way, run as real processes over real Zenoh: a user package's message (seed 002's
humanoid_msgs in a workspace src/, no build) decoded by zenoh-ros2-sdk, an independent rmw_zenoh client; and
tf2_ros broadcasters and a listener's Buffer between two programs."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from tests.conftest import wait_until
from tests.integration.test_rclpy_compat import peer
from tests.unit.test_msgs_rosidl import SEED_PACKAGE

PUBLISHER = '''
import rclpy
from rclpy.node import Node
from geometry_msgs.msg import Point
from humanoid_msgs.msg import HumanoidState


class StatePublisher(Node):
    def __init__(self):
        super().__init__('humanoid_state_publisher')
        self.publisher = self.create_publisher(HumanoidState, 'humanoid_state', 10)
        self.timer = self.create_timer(0.1, self.tick)

    def tick(self):
        msg = HumanoidState()
        msg.header.frame_id = 'base_link'
        msg.joint_names = ['left_knee', 'right_knee']
        msg.joint_positions = [0.4, -0.4]
        msg.center_of_mass.z = 0.9
        msg.support_polygon.append(Point(x=0.1, y=0.05))
        self.publisher.publish(msg)


rclpy.init()
rclpy.spin(StatePublisher())
'''


def test_a_workspace_package_message_reaches_an_independent_ros2_client(tmp_path: Path, processes,
                                                                         zenoh_port: int) -> None:
    workspace = tmp_path / "ws"
    shutil.copytree(SEED_PACKAGE, workspace / "src" / "humanoid_msgs")
    (workspace / "state_publisher.py").write_text(PUBLISHER)
    publisher = processes.start("-c", f"import os, runpy; os.chdir({str(workspace)!r}); "
                    f"runpy.run_path('state_publisher.py', run_name='__main__')", name="state_publisher")
    type_name = "humanoid_msgs/msg/HumanoidState"
    # the workspace's definition (the seed's, not the extended one zenroid ships), hashed by rosbags
    definition = subprocess.run(
        [sys.executable, "-c", f"from msgs.schema_text import full_definition; print(full_definition({type_name!r}))"],
        cwd=workspace, env=processes.env(), capture_output=True, text=True, check=True, timeout=60).stdout
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(definition, type_name))
    heard = peer(zenoh_port, "listen", "/humanoid_state", type_name, definition, store.hash_rihs01(type_name), "6")
    assert heard, "zenoh-ros2-sdk heard nothing on /humanoid_state\n" + processes.output(publisher)[-2000:]
    msg = heard[-1]
    assert msg["joint_names"] == ["left_knee", "right_knee"] and msg["joint_positions"] == [0.4, -0.4]
    assert msg["header"]["frame_id"] == "base_link" and msg["center_of_mass"]["z"] == 0.9
    assert msg["support_polygon"][0]["x"] == 0.1


BROADCASTER = '''
import math
import rclpy
from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from tf2_ros import StaticTransformBroadcaster, TransformBroadcaster


class Frames(Node):
    def __init__(self):
        super().__init__('frames')
        self.tf_broadcaster = TransformBroadcaster(self)
        self.static_broadcaster = StaticTransformBroadcaster(self)
        camera = TransformStamped()
        camera.header.stamp = self.get_clock().now().to_msg()
        camera.header.frame_id = 'base_link'
        camera.child_frame_id = 'camera'
        camera.transform.translation.z = 0.5
        camera.transform.rotation.w = 1.0
        self.static_broadcaster.sendTransform(camera)
        self.timer = self.create_timer(0.05, self.tick)

    def tick(self):
        t = TransformStamped()
        t.header.stamp = self.get_clock().now().to_msg()
        t.header.frame_id = 'world'
        t.child_frame_id = 'base_link'
        t.transform.translation.x = 2.0
        t.transform.rotation.z = math.sin(math.pi / 4)
        t.transform.rotation.w = math.cos(math.pi / 4)
        self.tf_broadcaster.sendTransform(t)


rclpy.init()
rclpy.spin(Frames())
'''

LISTENER = '''
import rclpy
from rclpy.node import Node
from rclpy.time import Time
from tf2_ros import Buffer, LookupException, TransformException, TransformListener


class Looker(Node):
    def __init__(self):
        super().__init__('looker')
        self.tf_buffer = Buffer()
        self.tf_listener = TransformListener(self.tf_buffer, self)
        self.timer = self.create_timer(0.2, self.tick)

    def tick(self):
        try:
            self.tf_buffer.lookup_transform('no_such_frame', 'camera', Time())
        except LookupException:
            pass
        if not self.tf_buffer.can_transform('world', 'camera', Time()):
            return
        try:
            t = self.tf_buffer.lookup_transform('world', 'camera', Time())
        except TransformException as ex:
            self.get_logger().info(f'Could not transform: {ex}')
            return
        p = t.transform.translation
        print(f'camera in world: {p.x:.3f} {p.y:.3f} {p.z:.3f}', flush=True)


rclpy.init()
rclpy.spin(Looker())
'''


def test_tf2_ros_broadcasters_and_a_listener_buffer(tmp_path: Path, processes) -> None:
    (tmp_path / "frames.py").write_text(BROADCASTER)
    (tmp_path / "looker.py").write_text(LISTENER)
    processes.start(str(tmp_path / "frames.py"), name="frames")
    looker = processes.start(str(tmp_path / "looker.py"), name="looker")
    wait_until(lambda: "camera in world:" in processes.output(looker), timeout=60,
               message="the listener's lookup of camera in world\n" + processes.output(looker)[-2000:])
    line = next(x for x in processes.output(looker).splitlines() if x.startswith("camera in world:"))
    assert line.split()[-3:] == ["2.000", "0.000", "0.500"], line
