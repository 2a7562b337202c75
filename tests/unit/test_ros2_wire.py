"""ROS 2 wire pieces checked against independent implementations: rosbags (RIHS01 hashes of the Jazzy
interfaces, CDR), zenoh-ros2-sdk (service hashes, rmw_zenoh key layout, attachment) — never only ours."""

from __future__ import annotations

import math
import os
import random

import numpy as np
import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

import msgs
from examples import ros2_client
from msgs import cdr
from msgs.registry import get_spec
from msgs.schema_text import _body, full_definition
from msgs.type_hash import rihs01
from nodes.core.ros2 import attachment, names

JAZZY = get_typestore(Stores.ROS2_JAZZY)

# Standard Jazzy values of interfaces rosbags does not ship: computed with rosbags' hash_rihs01 from the
# upstream definitions (ros-controls/control_msgs branch jazzy 5.8.0, ros-controls/ros2_control branch jazzy),
# services and action parts composed as REP-2011 describes (request/response/event; ServiceEventInfo's
# char[16] as uint8[16], which is what rosidl turns msg `char` into).
UPSTREAM_JAZZY = {
    "controller_manager_msgs/srv/SwitchController":
        "RIHS01_d4ad10aa5da7808bc522d55d4123d8ef79de73d049d165639d7663ac37cc9895",
    "controller_manager_msgs/srv/ListHardwareInterfaces":
        "RIHS01_c3e561a6e8cc7b9d577d8065c783038e51f6950cbe9bed67fb117a3e2e04d8f1",
    "controller_manager_msgs/srv/LoadController":
        "RIHS01_e37f7596c50c88cf8cb7a10cd376ff7579850cc63b5e787e9c8f11981f9ab4d2",
    "controller_manager_msgs/srv/ConfigureController":
        "RIHS01_b5de498113f4eabc7b932e019ca0498d67304b1ca465fe8a426ea89644865ff9",
    "controller_manager_msgs/srv/UnloadController":
        "RIHS01_4055728e84c041348648d7f808c6681562000e3a9ce9fbb42c3350df25773f16",
    "controller_manager_msgs/msg/ControllerState":
        "RIHS01_9a8780ab9814b6032978a07c6c7033cf1a7894ac8d948a6fb72afea07b04cc83",
    "control_msgs/msg/JointTrajectoryControllerState":
        "RIHS01_51d8dd89cc624cbe9daaeeb4d80d6de9b86168ffdc3be41fefc0953e3c26e480",
    "control_msgs/action/FollowJointTrajectory":
        "RIHS01_738ebcb7a2d7cfa42f9f1001cc99ce3a4383d1cfe508015d9be8485e4b1c66f6",
    # rosidl turns a .msg `char` into uint8 (rosidl_adapter's MSG_TYPE_TO_IDL); rosbags hashes it as a char of
    # its own. The value the generated Jazzy bindings carry (e.g. ros-z's and cyclonedds' msgspec stubs):
    "std_msgs/msg/Char": "RIHS01_3ad2d04dd29ba19d04b16659afa3ccaedd691914b02a64e82e252f2fa6a586a9",
}


def _standard_message_types() -> list[str]:
    return [t for t in msgs.list_types() if "/msg/" in t and t in JAZZY.types]


def test_every_standard_message_hashes_like_rosbags_jazzy():
    types = _standard_message_types()
    assert {"sensor_msgs/msg/JointState", "trajectory_msgs/msg/JointTrajectory", "tf2_msgs/msg/TFMessage",
            "rosgraph_msgs/msg/Clock", "rcl_interfaces/msg/Log", "action_msgs/msg/GoalStatusArray"} <= set(types)
    for type_name in types:
        if type_name not in UPSTREAM_JAZZY:   # rosbags hashes a `char` field unlike rosidl (see there)
            assert rihs01(type_name) == JAZZY.hash_rihs01(type_name), type_name


@pytest.mark.parametrize("type_name", sorted(UPSTREAM_JAZZY))
def test_control_interfaces_hash_like_upstream_jazzy(type_name):
    assert rihs01(type_name) == UPSTREAM_JAZZY[type_name]


@pytest.mark.parametrize("type_name", sorted(ros2_client.HASHES))
def test_the_outside_client_s_jazzy_hashes_are_ours(type_name):
    """examples/ros2_client.py spells out Jazzy's hashes (list_controllers and the action's parts among them,
    computed like UPSTREAM_JAZZY's) for the SDK; ours agree."""
    assert rihs01(type_name) == ros2_client.HASHES[type_name]


def _dependencies(type_name: str, found: dict[str, str]) -> dict[str, str]:
    for f in get_spec(type_name).fields:
        if not f.is_primitive and f.base not in found:
            found[f.base] = _body(f.base)
            _dependencies(f.base, found)
    return found


@pytest.mark.parametrize("srv", ["controller_manager_msgs/srv/SwitchController", "action_msgs/srv/CancelGoal",
                                 "controller_manager_msgs/srv/LoadController", "std_srvs/srv/SetBool"])
def test_service_hashes_match_zenoh_ros2_sdk(srv):
    from zenoh_ros2_sdk.utils import compute_service_type_hash

    deps = _dependencies(f"{srv}_Response", _dependencies(f"{srv}_Request", {}))
    assert rihs01(srv) == compute_service_type_hash(srv, _body(f"{srv}_Request"), _body(f"{srv}_Response"), deps)


# ---------------------------------------------------------------- CDR

def _rosbags_store_with(*type_names: str):
    """Jazzy plus our definitions of types it lacks (registered from our schema text)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for type_name in type_names:
        if type_name not in store.types:
            alias = type_name.replace("/action/", "/msg/").replace("/srv/", "/msg/")
            text = full_definition(type_name).replace(type_name.rsplit("/", 1)[0] + "/", alias.rsplit("/", 1)[0] + "/")
            store.register(get_types_from_msg(text, alias))
    return store


def _random_value(f, rng: random.Random, depth: int = 0):
    def scalar():
        if f.base == "bool":
            return rng.random() < 0.5
        if f.base in ("float32",):
            return float(np.float32(rng.uniform(-1e3, 1e3)))
        if f.base == "float64":
            return rng.uniform(-1e6, 1e6)
        if f.base in ("string", "wstring"):
            return "".join(rng.choice("abcé/_ 0") for _ in range(rng.randint(0, 7)))
        lo, hi = {"int8": (-128, 127), "uint8": (0, 255), "byte": (0, 255), "char": (0, 255),
                  "int16": (-2**15, 2**15 - 1), "uint16": (0, 2**16 - 1), "int32": (-2**31, 2**31 - 1),
                  "uint32": (0, 2**32 - 1), "int64": (-2**63, 2**63 - 1), "uint64": (0, 2**64 - 1)}[f.base]
        return rng.randint(lo, hi)

    if not f.is_array:
        return scalar() if f.is_primitive else _random_data(f.base, rng, depth + 1)
    n = f.array_size if f.array_size is not None else rng.randint(0, 3 if depth > 1 else 5)
    if f.is_bytes:
        return bytes(rng.randrange(256) for _ in range(n))
    if f.is_primitive:
        return [scalar() for _ in range(n)]
    return [_random_data(f.base, rng, depth + 1) for _ in range(n)]


def _random_data(type_name: str, rng: random.Random, depth: int = 0) -> dict:
    return {f.name: _random_value(f, rng, depth) for f in get_spec(type_name).fields}


def _plain(value):
    """rosbags' message objects → plain data for comparison."""
    if hasattr(value, "__msgtype__"):
        return {k: _plain(getattr(value, k)) for k in value.__dataclass_fields__
                if k not in ("__msgtype__", "structure_needs_at_least_one_member")
                and not k.isupper()}  # constants are class fields there
    if isinstance(value, np.ndarray):
        return bytes(value.tobytes()) if value.dtype == np.uint8 else [_plain(v) for v in value.tolist()]
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


WIRE_TYPES = [
    "sensor_msgs/msg/JointState", "trajectory_msgs/msg/JointTrajectory", "tf2_msgs/msg/TFMessage",
    "rosgraph_msgs/msg/Clock", "rcl_interfaces/msg/Log", "action_msgs/msg/GoalStatusArray",
    "std_msgs/msg/Float64MultiArray", "std_msgs/msg/Empty", "std_msgs/msg/String", "nav_msgs/msg/Path",
    "control_msgs/msg/JointTrajectoryControllerState", "controller_manager_msgs/msg/ControllerState",
    "control_msgs/action/FollowJointTrajectory_SendGoal_Request",
    "control_msgs/action/FollowJointTrajectory_FeedbackMessage",
    "control_msgs/action/FollowJointTrajectory_GetResult_Response",
    "visualization_msgs/msg/Marker", "visualization_msgs/msg/MarkerArray",
]


@pytest.mark.parametrize("type_name", WIRE_TYPES)
def test_cdr_matches_rosbags_both_ways(type_name):
    store = _rosbags_store_with(type_name)
    alias = type_name.replace("/action/", "/msg/").replace("/srv/", "/msg/")
    rng = random.Random(type_name)
    for _ in range(5):
        data = _random_data(type_name, rng)
        ours = cdr.encode(type_name, data)
        theirs = store.deserialize_cdr(ours, alias)
        assert bytes(store.serialize_cdr(theirs, alias)) == ours
        back = cdr.decode(type_name, ours)
        assert back == _normalise(type_name, data)
        assert _plain(theirs) == _normalise(type_name, data)


def _normalise(type_name: str, data: dict) -> dict:
    """What decoding gives back: float32 rounding is the only change."""
    out = {}
    for f in get_spec(type_name).fields:
        value = data[f.name]
        if not f.is_primitive:
            value = [_normalise(f.base, v) for v in value] if f.is_array else _normalise(f.base, value)
        out[f.name] = value
    return out


def test_cdr_fills_missing_fields_with_ros_defaults():
    raw = cdr.encode("rosgraph_msgs/msg/Clock", {"clock": {"sec": 3}})
    assert raw == bytes.fromhex("00010000" "03000000" "00000000")
    assert cdr.decode("sensor_msgs/msg/JointState", cdr.encode("sensor_msgs/msg/JointState", {}))["name"] == []


@pytest.mark.parametrize("payload", [b"", b"\x00\x01", bytes.fromhex("000100000500000061"),
                                     bytes.fromhex("00010000ffffff7f")])
def test_cdr_rejects_truncated_payloads(payload):
    with pytest.raises(cdr.CdrError, match="std_msgs/msg/String"):
        cdr.decode("std_msgs/msg/String", payload)


def test_cdr_rejects_big_endian_and_bad_values():
    with pytest.raises(cdr.CdrError, match="not little-endian"):
        cdr.decode("std_msgs/msg/Int32", b"\x00\x00\x00\x00\x00\x00\x00\x01")
    with pytest.raises(cdr.CdrError, match="sensor_msgs/msg/JointState"):
        cdr.encode("sensor_msgs/msg/JointState", {"position": ["x"]})
    with pytest.raises(cdr.CdrError, match="uuid"):
        cdr.encode("unique_identifier_msgs/msg/UUID", {"uuid": b"short"})
    assert math.isnan(cdr.decode("std_msgs/msg/Float64", cdr.encode("std_msgs/msg/Float64", {"data": math.nan}))["data"])


# ---------------------------------------------------------------- names, tokens, attachment

def test_data_keys_and_tokens_follow_rmw_zenoh_layout():
    from zenoh_ros2_sdk.entity import EndpointEntity, EntityKind, NodeEntity
    from zenoh_ros2_sdk.keyexpr import endpoint_liveliness_keyexpr, node_liveliness_keyexpr, topic_keyexpr
    from zenoh_ros2_sdk.qos import QosProfile

    js = "sensor_msgs/msg/JointState"
    assert names.data_key(0, "/humanoid/joint_states", js) == topic_keyexpr(
        0, "/humanoid/joint_states", "sensor_msgs::msg::dds_::JointState_", JAZZY.hash_rihs01(js))
    node = NodeEntity(domain_id=3, session_id="abc", node_id=4, node_name="controller_manager", namespace="/humanoid")
    assert names.node_token(3, "abc", 4, "/humanoid", "controller_manager") == node_liveliness_keyexpr(node)
    ep = EndpointEntity(node=node, entity_id=9, kind=EntityKind.PUBLISHER, name="/humanoid/joint_states",
                        dds_type_name=names.dds_type(js), type_hash=rihs01(js), qos=QosProfile().encode())
    assert names.endpoint_token(3, "abc", 4, 9, names.PUBLISHER, "/humanoid", "controller_manager",
                                "/humanoid/joint_states", js, names.DEFAULT_QOS) == endpoint_liveliness_keyexpr(ep)
    assert QosProfile.decode(names.LATCHED_QOS.token()).durability.name == "TRANSIENT_LOCAL"
    assert QosProfile.decode(names.Qos(reliable=False).token()).reliability.name == "BEST_EFFORT"
    parsed = names.parse_endpoint_token(endpoint_liveliness_keyexpr(ep))
    assert (parsed.zid, parsed.kind, parsed.ros_name, parsed.type_name) == ("abc", "MP", "/humanoid/joint_states", js)


def test_ros_names_of_our_keys():
    fb = "control_msgs/action/FollowJointTrajectory_FeedbackMessage"
    assert names.ros_topic_name("sim/clock", "rosgraph_msgs/msg/Clock") == "/clock"
    assert names.ros_topic_name("humanoid/jtc/follow_joint_trajectory/feedback", fb) == \
        "/humanoid/jtc/follow_joint_trajectory/_action/feedback"
    assert names.ros_topic_name("humanoid/jtc/follow_joint_trajectory/status", "action_msgs/msg/GoalStatusArray") \
        == "/humanoid/jtc/follow_joint_trajectory/_action/status"
    assert names.ros_topic_name("humanoid/feedback", "std_msgs/msg/String") == "/humanoid/feedback"
    assert names.dds_type("control_msgs/action/FollowJointTrajectory_SendGoal") == \
        "control_msgs::action::dds_::FollowJointTrajectory_SendGoal_"
    assert names.is_internal("humanoid/hardware/state")
    assert names.is_internal("humanoid/controller_manager/get_parameters", "zenroid_msgs/srv/GetParameters")
    assert not names.is_internal("humanoid/joint_states", "sensor_msgs/msg/JointState")


def test_attachment_is_what_zenoh_ros2_sdk_reads_and_writes():
    from zenoh_ros2_sdk.attachment import Attachment

    gid = attachment.make_gid("@ros2_lv/0/x")
    raw = attachment.pack(7, gid, 123)
    theirs = Attachment.from_bytes(raw)
    assert (theirs.sequence_id, theirs.timestamp_ns, theirs.gid) == (7, 123, gid)
    ours = attachment.unpack(Attachment(sequence_id=9, timestamp_ns=5, gid=bytes(range(16))).to_bytes())
    assert (ours.sequence, ours.timestamp_ns, ours.gid) == (9, 5, bytes(range(16)))
    assert attachment.is_ours(gid) and not attachment.is_ours(bytes(range(16)))
    assert attachment.unpack(b"\x01") is None


def test_every_launch_file_takes_ros2_false():
    from pathlib import Path

    from launch.cli import child_environment, ros2_wire_of
    from launch.resolve import resolve

    files = sorted((Path(__file__).resolve().parents[2] / "launch").glob("*.yaml"))
    assert len(files) >= 5
    for path in files:
        assert ros2_wire_of(resolve(path, {})) is True, path.name
        assert ros2_wire_of(resolve(path, {"ros2": "false"})) is False, path.name
    assert child_environment(None, ros2=False)["ZENROID_ROS2"] == "0"
    assert "ZENROID_ROS2" not in child_environment(None, ros2=True) or os.environ.get("ZENROID_ROS2")


def test_entity_ids_of_closed_entities_are_taken_again_smallest_first():
    """Zenoh keeps memory for every distinct liveliness key; rmw ids in the keys must not grow with churn."""
    from nodes.core.ros2 import _EntityIds

    ids = _EntityIds()
    assert [ids.take() for _ in range(4)] == [0, 1, 2, 3]
    ids.give_back(2)
    ids.give_back(1)
    assert [ids.take(), ids.take(), ids.take()] == [1, 2, 4]
    for _ in range(1000):               # a robot spawned and deleted over and over: the same ids
        taken = [ids.take() for _ in range(3)]
        for entity_id in taken:
            ids.give_back(entity_id)
    assert ids.take() == 5
