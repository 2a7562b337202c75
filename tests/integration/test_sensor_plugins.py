"""A gazebo_ros IMU plugin (libgazebo_ros_imu_sensor.so) without ros2_control: the simulator publishes
sensor_msgs/Imu itself, on the plugin's remapped topic in its namespace, with its frame_name, at the sensor's
update_rate, stamped with sim time, its covariances from the declared noise."""

from __future__ import annotations

import threading
from pathlib import Path

import msgpack
import pytest

from nodes.core import Node
from tests.conftest import wait_until

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
PLUGIN = """<plugin name="imu_plugin" filename="libgazebo_ros_imu_sensor.so">
        <ros><namespace>/demo</namespace><remapping>~/out:=imu</remapping></ros>
        <frame_name>torso</frame_name>
      </plugin>
    </sensor>"""


def test_imu_plugin_publishes_from_the_simulator(processes, router, tmp_path):
    xml = (ROOT / "robots" / "humanoid.urdf").read_text()
    start = xml.index('<sensor name="imu_sensor" type="imu">')
    end = xml.index("</sensor>", start) + len("</sensor>")
    sensor = xml[start:end].replace("<update_rate>1000</update_rate>", "<update_rate>100</update_rate>")
    (tmp_path / "robot.urdf").write_text(xml[:start] + sensor.replace("</sensor>", PLUGIN) + xml[end:])
    processes.start("-m", "nodes.sim", "--params-file", "config/sim.yaml", "--param", "mode:=realtime",
                    "--param", f"entities:=[{{name: humanoid, file: {tmp_path / 'robot.urdf'}, z: 0.93}}]", name="sim")
    node = Node("plugin_test_client", connect=[router])
    lock = threading.Lock()
    received: list[dict] = []

    def on_imu(payload: bytes) -> None:
        with lock:
            received.append(msgpack.unpackb(payload))

    try:
        node.create_subscription(None, "/demo/imu", on_imu, inline=True, raw=True)
        wait_until(lambda: len(received) > 200, timeout=90, message="200 Imu messages on demo/imu")
        with lock:
            messages = list(received)
        stamps = [m["header"]["stamp"]["sec"] + m["header"]["stamp"]["nanosec"] * 1e-9 for m in messages]
        steps = sorted(round(b - a, 4) for a, b in zip(stamps, stamps[1:], strict=False))
        assert steps[len(steps) // 2] == pytest.approx(0.01)     # 100 Hz of sim time
        assert {m["header"]["frame_id"] for m in messages} == {"torso"}
        late = [m for m, t in zip(messages, stamps, strict=True) if t > 1.5]   # landed and standing
        assert late and all(abs(m["linear_acceleration"]["z"] - 9.81) < 0.3 for m in late)
        assert messages[-1]["angular_velocity_covariance"][0] == pytest.approx(2e-4 ** 2)
        assert messages[-1]["linear_acceleration_covariance"][8] == pytest.approx(1.7e-2 ** 2)
    finally:
        node.shutdown()
