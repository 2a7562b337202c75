"""Markers end to end (real processes, real Zenoh): seed 002's trajectory_visualizer publishes its LINE_STRIP,
a third party receives and decodes it, and the visualiser draws it and RViz's other marker types (placed
through tf, deleted, expired) into its .rrd, read back with Rerun's own reader. Bad markers are refused on
rosout by name and reason, and the visualiser keeps running."""

from __future__ import annotations

import math
import signal
import time
from pathlib import Path

import msgpack
import numpy as np
import pytest

import msgs
from nodes.core import Node
from tests.conftest import wait_until
from tests.support.rrd import load

ROOT = Path(__file__).resolve().parents[2]
HUMANOID = ROOT / "robots" / "humanoid.urdf"
TRAJECTORY = "world/markers/visualization/trajectory/_/0"
Marker = msgs.get_type("visualization_msgs/msg/Marker")
MarkerArray = msgs.get_type("visualization_msgs/msg/MarkerArray")


def marker(**fields) -> object:
    base = {"header": {"frame_id": "map"}, "ns": "test", "scale": {"x": 0.1, "y": 0.1, "z": 0.1},
            "color": {"r": 0.0, "g": 1.0, "b": 0.0, "a": 1.0}}
    base.update(fields)
    return msgs.from_dict(Marker, base)


@pytest.mark.slow
def test_trajectory_visualizer_markers_are_received_decoded_and_drawn(processes, router: str, tmp_path: Path) -> None:
    rrd = tmp_path / "markers.rrd"
    processes.start("-m", "nodes.state_publisher", "--ns", "humanoid",
                    "--param", f"robot_description_file:={HUMANOID}", name="state_publisher")
    viz = processes.start("-m", "nodes.viz", "--save", str(rrd), "--robots", "humanoid", name="viz")
    wait_until(lambda: "23 visuals" in processes.output(viz), 40, message="the robot model in the visualiser")
    received: list[dict] = []
    with Node("marker_tester", connect=[router]) as node:
        # A third party: plain Zenoh + msgpack sees the tutorial's marker on the tutorial's topic.
        raw = node.session.declare_subscriber("visualization/trajectory",
                                              lambda s: received.append(msgpack.unpackb(s.payload.to_bytes())))
        commander = processes.start("-m", "nodes.commanders.trajectory_visualizer", "--param", "period:=0.5",
                                    name="trajectory_visualizer")
        wait_until(lambda: received, 30, message="the trajectory marker on visualization/trajectory")
        seed = received[-1]
        assert seed["header"]["frame_id"] == "map" and seed["type"] == 4 and seed["action"] == 0
        assert seed["scale"]["x"] == 0.05 and (seed["color"]["r"], seed["color"]["a"]) == (1.0, 1.0)
        assert len(seed["points"]) == 5
        decoded = msgs.decode(Marker, msgpack.packb(seed))  # our validating codec agrees
        assert decoded.type == Marker.LINE_STRIP
        raw.undeclare()

        single = node.create_publisher(Marker, "/humanoid/visualization_marker")
        array = node.create_publisher(MarkerArray, "/visualization_marker_array")
        time.sleep(1.5)  # the visualiser's subscriptions meet ours through the router
        shapes = [
            marker(id=1, type=Marker.ARROW, scale={"x": 0.5, "y": 0.05, "z": 0.05}),
            marker(id=2, type=Marker.CUBE, pose={"position": {"x": 1.0}, "orientation": {"w": 1.0}}),
            marker(id=3, type=Marker.SPHERE),
            marker(id=4, type=Marker.CYLINDER),
            marker(id=5, type=Marker.LINE_LIST, points=[{"x": 0.0}, {"x": 1.0}, {"y": 0.0}, {"y": 1.0}]),
            marker(id=6, type=Marker.POINTS, points=[{"x": 0.0}, {"x": 1.0}],
                   colors=[{"r": 1.0, "a": 1.0}, {"b": 1.0, "a": 1.0}]),
            marker(id=7, type=Marker.TEXT_VIEW_FACING, text="hello", pose={"position": {"z": 2.0},
                                                                           "orientation": {"w": 1.0}}),
            marker(id=8, type=Marker.SPHERE, lifetime={"sec": 1}),  # expires
            marker(id=9, type=Marker.CUBE),  # deleted below
        ]
        array.publish(MarkerArray(markers=shapes))
        # A marker in a link frame of the robot: placed through tf (the state publisher's, at zero pose).
        single.publish(marker(id=10, type=Marker.SPHERE, header={"frame_id": "left_foot"}))
        time.sleep(1.0)
        array.publish(MarkerArray(markers=[marker(id=9, action=Marker.DELETE)]))
        # Bad markers: refused with the field and the reason, the visualiser goes on.
        single.publish(marker(id=20, type=Marker.LINE_STRIP, points=[{"x": 1.0}]))
        single.publish(marker(id=21, type=42))
        single.publish(marker(id=22, type=Marker.CUBE, scale={"x": 0.0, "y": 1.0, "z": 1.0}))
        single.publish(marker(id=23, type=Marker.POINTS, points=[{"x": 1.0}], colors=[{}, {}]))
        wait_until(lambda: "marker 'test' 22 refused" in processes.output(viz), 20, message="the refusals")
        time.sleep(2.5)  # the lifetime runs out; a key frame and a few flushes
    output = processes.output(viz)
    assert "points has 1 entries: a LINE_STRIP needs at least 2" in output
    assert "type 42 is not a Marker type" in output
    assert "scale.x is 0.0: a CUBE needs a positive size" in output
    assert "colors has 2 entries for 1 points" in output
    assert viz.poll() is None, "the visualiser died on bad markers"
    commander.send_signal(signal.SIGINT)
    viz.send_signal(signal.SIGINT)
    viz.wait(20)
    assert viz.returncode == 0, processes.output(viz)

    data = load(rrd)
    for entity in data.values():  # no simulator here: rows are on the wall_time timeline, not sim_time
        entity.rows.sort(key=lambda row: (row.get("wall_time", 0.0), row.get("log_time", 0.0)))

    def last(entity: str, component: str):
        """The newest value."""
        return [row[component] for row in data[entity].rows if component in row][-1]

    strip = last(TRAJECTORY, "LineStrips3D:strips")[0]
    assert len(strip) == 5 and strip[1] == pytest.approx([0.5, 0.0, 0.02]), strip
    assert data[TRAJECTORY].rows[-1]["LineStrips3D:radii"] == [pytest.approx(0.025)]
    array_topic = "world/markers/visualization_marker_array/test"
    drawn = {name.rsplit("/", 1)[1]: entity for name, entity in data.items() if name.startswith(array_topic)}
    kinds = {"1": "Arrows3D", "2": "Boxes3D", "3": "Ellipsoids3D", "4": "Cylinders3D", "5": "LineStrips3D",
             "6": "Points3D", "7": "Points3D"}
    for marker_id, archetype in kinds.items():
        assert any(key.startswith(f"{archetype}:") for row in drawn[marker_id].rows for key in row), marker_id
    assert last(f"{array_topic}/2", "Boxes3D:centers") == [pytest.approx([1.0, 0.0, 0.0])]
    assert last(f"{array_topic}/7", "Points3D:labels") == ["hello"]
    for gone in ("8", "9"):  # expired, deleted: cleared after they were drawn
        rows = drawn[gone].rows
        assert any("Ellipsoids3D:centers" in r or "Boxes3D:centers" in r for r in rows)
        assert rows[-1].get("Clear:is_recursive") == [False], (gone, rows[-1])
    assert not any(name.endswith(("/20", "/21", "/22", "/23")) for name in data), "refused markers were drawn"
    # left_foot at the zero pose: below the hip, near the ground (placed through tf, not at the origin).
    foot = last("world/markers/humanoid/visualization_marker/test/10", "Ellipsoids3D:centers")[0]
    assert foot[2] < 0.3 and abs(foot[1]) > 0.03 and not np.allclose(foot, [0, 0, 0]), foot
    assert math.isfinite(sum(foot))
