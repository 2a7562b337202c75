"""gazebo_ros' sensor plugins without ros2_control: the simulator publishes them itself, on each plugin's
remapped topic in its namespace (else the robot's), with its frame_name, at the sensor's update_rate, stamped
with sim time: the IMU plugin's sensor_msgs/Imu (covariances from the declared noise), the force/torque
plugin's geometry_msgs/WrenchStamped and the bumper plugin's gazebo_msgs/ContactsState (the shipped humanoid's
foot contact sensors)."""

from __future__ import annotations

import threading
from pathlib import Path

import msgpack
import pytest

from nodes.core import Node
from nodes.core.delivery import Inline, Raw
from tests.conftest import wait_until

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
PLUGIN = """<plugin name="imu_plugin" filename="libgazebo_ros_imu_sensor.so">
        <ros><namespace>/demo</namespace><remapping>~/out:=imu</remapping></ros>
        <frame_name>torso</frame_name>
      </plugin>
    </sensor>"""
FT_PLUGIN = """<plugin name="ft_plugin" filename="libgazebo_ros_ft_sensor.so">
        <ros><remapping>wrench:=left_ankle/wrench</remapping></ros>
      </plugin>
    </sensor>"""


def with_plugin(xml: str, sensor_start: str, plugin: str, rate: str | None = None) -> str:
    start = xml.index(sensor_start)
    end = xml.index("</sensor>", start) + len("</sensor>")
    sensor = xml[start:end]
    if rate:
        sensor = sensor.replace("<update_rate>1000</update_rate>", f"<update_rate>{rate}</update_rate>")
    return xml[:start] + sensor.replace("</sensor>", plugin) + xml[end:]


def test_imu_plugin_publishes_from_the_simulator(processes, router, tmp_path):
    xml = (ROOT / "robots" / "humanoid.urdf").read_text()
    xml = with_plugin(xml, '<sensor name="imu_sensor" type="imu">', PLUGIN, rate="100")
    xml = with_plugin(xml, '<sensor name="left_foot_ft" type="force_torque">', FT_PLUGIN, rate="200")
    (tmp_path / "robot.urdf").write_text(xml)
    processes.start("-m", "nodes.sim", "--params-file", "config/sim.yaml", "--param", "mode:=realtime",
                    "--param", f"entities:=[{{name: humanoid, file: {tmp_path / 'robot.urdf'}, z: 0.93}}]", name="sim")
    node = Node("plugin_test_client", connect=[router])
    lock = threading.Lock()
    received: list[dict] = []
    streams: dict[str, list[dict]] = {"humanoid/left_ankle/wrench": [], "humanoid/left_foot/contacts": []}

    def on_imu(payload: bytes) -> None:
        with lock:
            received.append(msgpack.unpackb(payload))

    def on_message(payload: bytes, key: str) -> None:
        with lock:
            streams[key].append(msgpack.unpackb(payload))

    try:
        node.create_subscription(None, "/demo/imu", on_imu, delivery=Inline(), message=Raw())
        for key in streams:
            node.create_subscription(None, f"/{key}", on_message,
                                     delivery=Inline(), message=Raw(with_key=True))
        wait_until(lambda: len(received) > 200, timeout=90, message="200 Imu messages on demo/imu")

        def contacts_after_two_seconds() -> bool:   # the same instant's contacts may still be on their way
            with lock:
                return any(m["header"]["stamp"]["sec"] >= 2 for m in streams["humanoid/left_foot/contacts"])
        wait_until(contacts_after_two_seconds, timeout=30, message="contacts on humanoid/left_foot/contacts past 2 s")
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

        # the force/torque plugin (the robot's namespace, gazebo_plugins' topic name remapped), at 200 Hz: the
        # left ankle carries about half the weight above it, in the foot's frame
        with lock:
            wrenches, contacts = list(streams["humanoid/left_ankle/wrench"]), list(streams["humanoid/left_foot/contacts"])
        stamps = [m["header"]["stamp"]["sec"] + m["header"]["stamp"]["nanosec"] * 1e-9 for m in wrenches]
        assert sorted(round(b - a, 4) for a, b in zip(stamps, stamps[1:]))[len(stamps) // 2] == pytest.approx(0.005)
        assert {m["header"]["frame_id"] for m in wrenches} == {"left_foot"}
        loaded = [m["wrench"]["force"]["z"] for m, t in zip(wrenches, stamps) if t > 1.5]
        assert loaded and 150 < abs(sum(loaded) / len(loaded)) < 400, loaded[-5:]
        # the bumper plugin of the shipped foot contact sensor: the sole on the ground, in the world frame
        late = [m for m in contacts if m["header"]["stamp"]["sec"] >= 2]
        assert late and {m["header"]["frame_id"] for m in late} == {"world"}
        states = [s for m in late for s in m["states"]]
        assert states and all(s["collision2_name"] == "ground_plane::link::collision" for s in states)
        assert all(abs(p["z"]) < 0.01 for s in states for p in s["contact_positions"])   # on the floor
        weight_share = [sum(w["force"]["z"] for w in s["wrenches"]) for s in states]
        assert sum(weight_share) / len(weight_share) > 100, weight_share[-5:]
    finally:
        node.destroy()
