"""The main job's viewer records the world, the body sensors and the rendered sensors (real simulator with
simple_lab.world, controller manager and sensor broadcasters, renderer, state publisher and viewer, over real
Zenoh), read back from its ``--save`` recording with Rerun's own reader."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from rerun.chunk import RrdReader

from bench.common import Launch
from nodes.urdf.model import parse_urdf
from tests.support.rrd import load

ROOT = Path(__file__).resolve().parents[2]
ROBOT, CAMERA, RANGES = "world/humanoid/robot", "world/humanoid/cameras/camera", "world/humanoid/ranges"


def rgba(r: float, g: float, b: float) -> int:
    """A material colour as the recording packs it."""
    return (round(r * 255) << 24) | (round(g * 255) << 16) | (round(b * 255) << 8) | 0xFF


def blueprint_eye(path: Path) -> list[float]:
    """The 3-D view's eye position in the layout the viewer sent."""
    reader = RrdReader(str(path))
    for chunk in reader.stream(store=reader.blueprints()[-1]):
        if chunk.entity_path.endswith("/EyeControls3D"):
            return chunk.to_record_batch().column("EyeControls3D:position").to_pylist()[-1][0]
    raise AssertionError("no EyeControls3D in the layout")


@pytest.mark.slow
def test_main_job_viewer_records_world_body_and_rendered_sensors(tmp_path: Path, zenoh_port: int) -> None:
    rrd = tmp_path / "main.rrd"
    viewer_log = tmp_path / "logs" / "viewer.log"
    with Launch("humanoid.yaml", "mode:=realtime", f"viewer_args:=--save {rrd}", log_dir=tmp_path, port=zenoh_port,
                gui=True) as launch:
        launch.wait_output("started 'joint_commander'", 120)
        launch.wait(lambda: viewer_log.exists() and "world: scene version" in viewer_log.read_text(), 60,
                    "the world in the viewer")
        time.sleep(12.0)  # the robot stands, squats; the sensors come a frame at a time
        assert launch.close(30) == 0, launch.output()[-3000:]
    log = viewer_log.read_text()
    assert "9 models drawn (16 shapes)" in log, log[-2000:]
    data = load(rrd)

    # simple_lab.world: walls (4), table top, block, book, three boxes, ramp; the table's legs; the ball. No
    # ground box (the grid is the ground), none of the robot's boxes (its URDF draws it).
    world = data["world/models"].rows[-1]
    assert len(world["Boxes3D:centers"]) == 11 and len(world["Cylinders3D:centers"]) == 4
    assert len(world["Ellipsoids3D:centers"]) == 1
    assert max(max(h) for h in world["Boxes3D:half_sizes"]) < 6.0, "no 50 m ground box"
    assert rgba(0.6, 0.4, 0.2) in world["Boxes3D:colors"] and rgba(0.95, 0.85, 0.1) in world["Ellipsoids3D:colors"]
    table = world["Boxes3D:centers"][world["Boxes3D:colors"].index(rgba(0.6, 0.4, 0.2))]
    assert table == pytest.approx([3.0, 0.0, 0.73], abs=1e-3), "the table top at its pose in the world file"
    # The world file's <gui><camera><pose> is where the 3-D view starts.
    assert blueprint_eye(rrd) == pytest.approx([-4.5, -4.5, 3.2], abs=1e-5)

    # Body sensors: the pelvis IMU standing (gravity up), and the feet carrying the weight above the ankles.
    robot = data[ROBOT]
    accel = [v for _, v in robot.column("linear_acceleration:imu_sensor_broadcaster_imu")]
    assert len(accel) > 20 and accel[-1][2] == pytest.approx(9.81, abs=1.5)
    model = parse_urdf((ROOT / "robots" / "humanoid.urdf").read_text())
    feet = model.links["left_foot"].inertial.mass + model.links["right_foot"].inertial.mass
    weight = (model.total_mass() - feet) * 9.81
    last = next(r for r in reversed(robot.rows) if len(r.get("Arrows3D:vectors") or []) == 2)
    carried = sum(v[2] for v in last["Arrows3D:vectors"]) / 0.001  # wrench_scale: 1 mm per N
    assert carried == pytest.approx(weight, rel=0.25), (carried, weight)
    # and the foot contact sensors' points (the bumper plugins' ContactsState) on the floor under the soles
    magenta = (230 << 24) | (40 << 16) | (200 << 8) | 255   # scene.CONTACT_COLOR, packed as Rerun stores it
    contacts = [p for r in robot.rows[-20:] for p, c in zip(r.get("Points3D:positions") or [], r.get("Points3D:colors")
                                                             or []) if c == magenta]
    assert contacts and all(abs(p[2]) < 0.01 and abs(p[0]) < 0.3 for p in contacts), contacts[:4]

    # Rendered sensors: the head camera (JPEG), its depth image, the lidar and laser points.
    camera = data[CAMERA].rows
    assert len(camera) >= 3 and camera[-1]["EncodedImage:media_type"] == ["image/jpeg"]
    assert camera[-1]["Pinhole:resolution"] == [[320.0, 240.0]]
    assert camera[-1]["DepthImage:meter"] == [1000.0], "the depth image in the camera's row"
    ranges = data[RANGES].rows
    assert len(ranges) >= 3 and len(ranges[-1]["Points3D:positions"]) > 2000, "the lidar sees the walls"
