"""The world's models without processes: sim/scene in, Rerun rows out (saved to a file and read back)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rerun as rr

import msgs
from nodes.viz.blueprint import build_blueprint
from nodes.viz.world import MESH_ENTITY, WORLD_ENTITY, WorldModels, WorldProblem, camera_eye, read_scene
from tests.support.rrd import record as record_rrd

Scene = msgs.get_type("zenroid_msgs/msg/Scene")
Pose = msgs.get_type("geometry_msgs/msg/Pose")
Point = msgs.get_type("geometry_msgs/msg/Point")
TETRAHEDRON = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "<f4").tobytes(),
               np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], "<u4").tobytes())


def pose(x: float = 0.0, y: float = 0.0, z: float = 0.0, yaw: float = 0.0) -> dict:
    return {"position": {"x": x, "y": y, "z": z},
            "orientation": {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


def shape(link: int, kind: int, size: list[float], color=(1.0, 0.0, 0.0, 1.0), **extra: Any) -> dict:
    return {"link": link, "kind": kind, "size": size, "pose": pose(), "visual": True, "collision": True,
            "color": dict(zip("rgba", color, strict=True)), **extra}


def scene(version: int = 1, **changes: Any) -> Any:
    """The ground, a static wall, a dynamic ball, a robot and a mesh on a dynamic 'rock' (as the simulator
    writes them: nodes/sim/scene.py)."""
    vertices, triangles = TETRAHEDRON
    data = {
        "version": version,
        "models": ["ground_plane", "wall", "ball", "humanoid", "rock"],
        "namespaces": ["", "", "", "humanoid", ""],
        "static_models": [True, True, False, False, False],
        "descriptions": ["", "", "", "<robot/>", ""],
        "links": ["ground_plane::link", "wall::link", "ball::link", "humanoid::pelvis", "rock::link"],
        "link_models": [0, 1, 2, 3, 4],
        "shapes": [shape(0, 1, [50.0, 50.0, 1.0]), shape(1, 1, [10.0, 0.1, 1.5], (0.85, 0.85, 0.8, 1.0)),
                   shape(1, 1, [10.0, 0.1, 1.5], visual=False),  # collision only: not drawn
                   shape(2, 3, [0.1], (0.95, 0.85, 0.1, 1.0)), shape(3, 1, [0.2, 0.3, 0.4]),
                   shape(4, 4, [], vertices=vertices, triangles=triangles, mesh_uri="/rock.stl")],
        "has_camera_pose": True, "camera_pose": pose(-4.5, -4.5, 3.2),
    }
    data.update(changes)
    return msgs.from_dict(Scene, data)


def record(tmp_path: Path, body) -> dict:
    return record_rrd(tmp_path / "world.rrd", body, "test_viz_world")


def test_the_scene_draws_world_models_only() -> None:
    layout, problems = read_scene(scene())
    assert problems == []
    assert layout.models == ["wall", "ball", "rock"], "no ground (the grid), no robot (its URDF)"
    assert [s.kind for s in layout.shapes] == [1, 3, 4], "the collision-only box is not drawn"
    assert layout.static == {1} and set(layout.links) == {"wall::link", "ball::link", "rock::link"}
    assert layout.shapes[0].color == [217, 217, 204, 255]
    assert layout.shapes[2].normals is not None and layout.shapes[2].triangles.shape == (4, 3)


def test_the_gui_camera_pose_becomes_the_views_eye() -> None:
    from nodes.urdf.model import rpy_matrix

    gazebo = np.eye(4)
    gazebo[:3, :3] = rpy_matrix(0.0, 0.45, 0.785)  # simple_lab.world: -4.5 -4.5 3.2 0 0.45 0.785
    gazebo[:3, 3] = [-4.5, -4.5, 3.2]
    eye, target = camera_eye(gazebo)
    assert eye == pytest.approx([-4.5, -4.5, 3.2])
    assert target[2] == pytest.approx(0.0, abs=1e-9), "it looks down at the ground"
    assert target[0] > -4.5 and target[1] > -4.5, "towards the room's centre"
    level, ahead = camera_eye(np.eye(4))
    assert ahead == pytest.approx([5.0, 0.0, 0.0]), "a level camera looks 5 m ahead"
    layout, _ = read_scene(scene())
    assert layout.eye is not None and layout.eye[0] == pytest.approx([-4.5, -4.5, 3.2])
    assert read_scene(scene(has_camera_pose=False))[0].eye is None
    view = build_blueprint(eye=layout.eye).root_container.contents[0]
    eye_property = view.properties["EyeControls3D"]
    assert eye_property.position.as_arrow_array().to_pylist() == [pytest.approx([-4.5, -4.5, 3.2])]


@pytest.mark.parametrize(("changes", "reason"), [
    ({"shapes": [shape(9, 1, [1.0, 1.0, 1.0])]}, "shapes[0]: link 9 is not one of the 5 links"),
    ({"shapes": [shape(1, 1, [1.0, 1.0])]}, "shapes[0] (wall::link): size [1.0, 1.0]: a BOX needs 3 positive"),
    ({"shapes": [shape(1, 3, [-0.1])]}, "a SPHERE needs 1 positive number(s)"),
    ({"shapes": [shape(1, 7, [1.0])]}, "kind 7 is not BOX (1), CYLINDER (2), SPHERE (3) or MESH (4)"),
    ({"shapes": [shape(1, 4, [], vertices=b"\0" * 13, triangles=TETRAHEDRON[1])]},
     "vertices has 13 bytes: not float32 x y z triples"),
    ({"shapes": [shape(1, 4, [], vertices=TETRAHEDRON[0], triangles=np.array([0, 1, 9], "<u4").tobytes())]},
     "triangles has index 9 for 4 vertices"),
    ({"shapes": [{**shape(1, 1, [1.0, 1.0, 1.0]), "pose": {"orientation": {"w": 0.0}}}]},
     "pose: orientation is the zero quaternion"),
])
def test_bad_shapes_are_skipped_with_the_field_and_reason(changes: dict, reason: str) -> None:
    layout, problems = read_scene(scene(**changes))
    assert layout.shapes == []
    assert len(problems) == 1 and reason in problems[0], problems


def test_a_scene_whose_lists_disagree_is_refused() -> None:
    with pytest.raises(WorldProblem, match="namespaces has 1 entries for 5 models"):
        read_scene(scene(namespaces=[""]))


def test_meshes_over_the_viewers_cap_are_not_drawn() -> None:
    layout, problems = read_scene(scene(), max_triangles=3)
    assert [s.kind for s in layout.shapes] == [1, 3] and "cap of 3" in problems[0]


def test_world_rows_place_shapes_at_link_poses_and_follow_moving_models(tmp_path: Path) -> None:
    def body(recording: rr.RecordingStream) -> None:
        world = WorldModels(recording)
        layout, _ = read_scene(scene())
        world.load(layout, 1.0)  # nothing placed yet: an empty row
        assert world.needs_link_states()
        poses = {"wall::link": pose(0, 5, 0.75), "ball::link": pose(1, 2, 0.1),
                 "rock::link": pose(3, 0, 0, math.pi / 2), "humanoid::pelvis": pose(0, 0, 0.9)}
        moved, problems = world.update_poses(list(poses), [msgs.from_dict(Pose, p) for p in poses.values()])
        assert moved and problems == []
        world.log(1.1)
        # A resting ball that jitters by a micrometre draws no row; a NaN pose is refused, the last one kept
        # (the codec refuses NaN on the wire already: built here as a decoded message would hold it).
        nan = Pose(position=Point(x=float("nan")))
        moved, problems = world.update_poses(["ball::link", "wall::link"],
                                             [msgs.from_dict(Pose, pose(1, 2, 0.100001)), nan])
        assert not moved and "sim/link_states: wall::link: not finite" in problems[0]
        moved, _ = world.update_poses(["ball::link"], [msgs.from_dict(Pose, pose(1.5, 2, 0.1))])
        assert moved
        world.log(1.2)
        assert world.needs_link_states(), "the ball and the rock move"
        world.load(read_scene(scene(version=2, shapes=[shape(1, 1, [10.0, 0.1, 1.5])]))[0], 1.3)
        assert not world.needs_link_states(), "a static wall, placed: no more link_states"

    data = record(tmp_path, body)
    rows = data[WORLD_ENTITY].rows
    assert [r["sim_time"] for r in rows] == [1.0, 1.1, 1.2, 1.3]
    assert rows[0]["Boxes3D:centers"] == [] and rows[0]["Ellipsoids3D:centers"] == []
    placed = rows[1]
    assert placed["Boxes3D:centers"] == [pytest.approx([0, 5, 0.75])]
    assert placed["Boxes3D:half_sizes"] == [pytest.approx([5.0, 0.05, 0.75])], "no robot box, no ground box"
    assert placed["Ellipsoids3D:centers"] == [pytest.approx([1, 2, 0.1])]
    assert placed["Ellipsoids3D:half_sizes"] == [pytest.approx([0.1, 0.1, 0.1])]
    assert placed["Cylinders3D:centers"] == []
    assert rows[2]["Ellipsoids3D:centers"] == [pytest.approx([1.5, 2, 0.1])]
    assert rows[2]["Boxes3D:centers"] == [pytest.approx([0, 5, 0.75])], "the NaN pose kept the last one"
    assert rows[3]["Boxes3D:centers"] == [pytest.approx([0, 5, 0.75])] and rows[3]["Ellipsoids3D:centers"] == []
    # The rock's mesh: logged with the scene and when it was placed, turned 90 degrees about z at (3, 0, 0).
    meshes = [r for r in data[MESH_ENTITY].rows if r.get("Mesh3D:vertex_positions")]
    assert [r["sim_time"] for r in meshes] == [1.1], "drawn once placed, not again while it rests"
    vertices = np.array(meshes[0]["Mesh3D:vertex_positions"])
    assert vertices[1] == pytest.approx([3.0, 1.0, 0.0], abs=1e-6), "x turned to y"
    assert meshes[0]["Mesh3D:vertex_colors"][0] == 0xFF0000FF
    assert len(meshes[0]["Mesh3D:vertex_normals"]) == 4
    assert data[MESH_ENTITY].column("Clear:is_recursive") == [(1.3, [False])], "the rock left the scene"


def test_an_idle_world_is_drawn_again_at_key_frames(tmp_path: Path) -> None:
    """A late page gets only the newest message from the server: the whole world comes again."""
    def body(recording: rr.RecordingStream) -> None:
        world = WorldModels(recording)
        world.refresh(0.5, period=0.0)  # no scene yet: nothing
        world.load(read_scene(scene())[0], 1.0)
        world.refresh(1.5, period=60.0)
        world.refresh(2.0, period=0.0)

    rows = record(tmp_path, body)[WORLD_ENTITY].rows
    assert [r["sim_time"] for r in rows] == [1.0, 2.0]
