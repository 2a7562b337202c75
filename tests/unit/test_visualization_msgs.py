"""visualization_msgs (Marker, MarkerArray) as ROS 2 Jazzy defines them: type hashes pinned and checked
against rosbags' independent copy of the Jazzy interfaces, and the msgpack codec (CDR both ways against
rosbags: tests/unit/test_ros2_wire.py)."""

from __future__ import annotations

import msgpack
import pytest
from rosbags.typesys import Stores, get_typestore

import msgs
from msgs.type_hash import rihs01

JAZZY = get_typestore(Stores.ROS2_JAZZY)

# The standard Jazzy values (rosbags 0.11 computes the same from its own definitions, checked below).
PINNED = {
    "visualization_msgs/msg/Marker": "RIHS01_45b13ccf791f225962bf74e746f9644518855d783a6f42ba0cc14fde2b4f3ce0",
    "visualization_msgs/msg/MarkerArray": "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf",
    "visualization_msgs/msg/MeshFile": "RIHS01_7710ece15a148fb7c9b546364cfb215bb06098087bd6394fe5b73a493508f8c4",
    "visualization_msgs/msg/UVCoordinate": "RIHS01_f27f7ed21fe360c6066944f856b801a0c0d1e94e815b6886444b42d90b196a26",
    "sensor_msgs/msg/CompressedImage": "RIHS01_15640771531571185e2efc8a100baf923961a4d15d5569652e6cb6691e8e371a",
}


@pytest.mark.parametrize("type_name", sorted(PINNED))
def test_type_hash_is_the_jazzy_one(type_name: str) -> None:
    assert rihs01(type_name) == PINNED[type_name]
    assert rihs01(type_name) == JAZZY.hash_rihs01(type_name)


def test_marker_constants_are_rviz_ones() -> None:
    from msgs.visualization_msgs import Marker

    assert (Marker.ARROW, Marker.CUBE, Marker.SPHERE, Marker.CYLINDER, Marker.LINE_STRIP, Marker.LINE_LIST,
            Marker.CUBE_LIST, Marker.SPHERE_LIST, Marker.POINTS, Marker.TEXT_VIEW_FACING, Marker.MESH_RESOURCE,
            Marker.TRIANGLE_LIST, Marker.ARROW_STRIP) == tuple(range(13))
    assert (Marker.ADD, Marker.MODIFY, Marker.DELETE, Marker.DELETEALL) == (0, 0, 2, 3)


def test_msgpack_round_trip_of_the_seed_marker() -> None:
    """The tutorial's LINE_STRIP marker (frame 'map', width 0.05, red) survives our codec."""
    marker = msgs.from_dict(msgs.get_type("visualization_msgs/msg/Marker"), {
        "header": {"frame_id": "map"}, "type": 4, "action": 0, "scale": {"x": 0.05},
        "color": {"r": 1.0, "a": 1.0}, "points": [{"x": 0.0}, {"x": 1.0, "y": 0.5}]})
    back = msgs.decode(type(marker), msgs.encode(marker))
    assert back.header.frame_id == "map" and back.scale.x == 0.05 and back.color.r == 1.0
    assert [(p.x, p.y) for p in back.points] == [(0.0, 0.0), (1.0, 0.5)]


def test_a_bad_marker_is_refused_naming_the_field() -> None:
    marker_type = msgs.get_type("visualization_msgs/msg/Marker")
    with pytest.raises(msgs.DecodeError, match="scale"):
        msgs.decode(marker_type, msgpack.packb({"scale": {"x": "wide"}}))
