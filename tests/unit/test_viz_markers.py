"""The marker layer without processes: validation (RViz's refusals), actions, lifetime, frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rerun as rr

import msgs
from nodes.viz.markers import MarkerError, MarkerLayer, archetypes, marker_entity, validate
from tests.support.rrd import load

Marker = msgs.get_type("visualization_msgs/msg/Marker")


def marker(**fields):
    base = {"header": {"frame_id": "map"}, "ns": "n", "scale": {"x": 0.2, "y": 0.2, "z": 0.2},
            "color": {"r": 1.0, "a": 1.0}}
    base.update(fields)
    return msgs.from_dict(Marker, base)


@pytest.mark.parametrize(("fields", "reason"), [
    ({"type": 99}, "type 99 is not a Marker type"),
    ({"type": 1, "action": 1}, "action 1 is not ADD (0), DELETE (2) or DELETEALL (3) (1 is deprecated)"),
    ({"type": 12, "points": [{}, {}]}, "ARROW_STRIP (12) is not implemented"),
    ({"type": 2, "scale": {"x": 1.0, "y": -1.0, "z": 1.0}}, "scale.y is -1.0: a SPHERE needs a positive size"),
    ({"type": 4, "points": [{}]}, "a LINE_STRIP needs at least 2"),
    ({"type": 5, "points": [{}, {}, {}]}, "a LINE_LIST needs pairs"),
    ({"type": 0, "points": [{}, {}, {}]}, "an ARROW takes 2 (start, end) or none"),
    ({"type": 8, "points": []}, "points is empty"),
    ({"type": 8, "points": [{}], "colors": [{}, {}]}, "colors has 2 entries for 1 points"),
    ({"type": 9, "text": ""}, "text is empty"),
    ({"type": 10, "mesh_resource": "package://no_such_robot_pkg/mesh.dae"}, "package 'no_such_robot_pkg' not found"),
    ({"type": 10, "mesh_resource": "package://zenroid_description/no_mesh.dae"}, "no_mesh.dae is not a file"),
    ({"type": 10, "mesh_resource": "http://example.invalid/m.dae"}, "only local mesh files"),
])
def test_markers_rviz_refuses_are_refused_with_the_reason(fields: dict, reason: str) -> None:
    with pytest.raises(MarkerError, match=reason.replace("(", r"\(").replace(")", r"\)")):
        validate(marker(**fields))


def test_pose_and_frame_place_the_shape() -> None:
    frame = np.eye(4)
    frame[:3, 3] = [1.0, 2.0, 0.0]
    cube = marker(type=1, pose={"position": {"x": 0.5}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}})
    [boxes] = archetypes(cube, frame)  # an all-zero quaternion is the identity, as in RViz
    assert np.allclose(boxes.centers.as_arrow_array().to_pylist()[0], [1.5, 2.0, 0.0])
    arrow = marker(type=0, scale={"x": 2.0, "y": 0.1, "z": 0.1})
    [arrows] = archetypes(arrow, np.eye(4))
    assert np.allclose(arrows.vectors.as_arrow_array().to_pylist()[0], [2.0, 0.0, 0.0])


def test_actions_lifetime_and_unknown_frames(tmp_path: Path) -> None:
    now = [100.0]
    frames = {"map": np.eye(4)}
    recording = rr.RecordingStream("test_markers")
    path = tmp_path / "m.rrd"
    recording.save(str(path))
    recording.set_time("sim_time", duration=1.0)
    layer = MarkerLayer(recording, lambda topic, frame: frames.get(frame), clock=lambda: now[0], max_markers=4)
    layer.handle("t", marker(id=1, type=2))
    layer.handle("t", marker(id=2, type=2, ns="other"))
    layer.handle("t", marker(id=3, type=2, lifetime={"sec": 2}))
    layer.handle("t", marker(id=4, type=2, header={"frame_id": "hand"}))
    with pytest.raises(MarkerError, match="4 markers are shown already"):
        layer.handle("t", marker(id=5, type=2))
    layer.flush()
    assert set(layer.unresolved) == {("t", "hand")}, "a frame tf does not know is reported, not drawn"
    now[0] = 103.0
    recording.set_time("sim_time", duration=2.0)
    layer.handle("t", marker(action=3, ns="n"))  # DELETEALL of ns "n": 1, 3 and 4 (4 was never drawn)
    layer.flush()
    assert set(layer.live) == {("t", "other", 2)}
    recording.flush()
    recording.disconnect()
    data = load(path)
    assert data[marker_entity("t", "n", 1)].rows[-1]["Clear:is_recursive"] == [False]
    assert marker_entity("t", "n", 4) not in data
    assert marker_entity("t", "other", 2) in data
