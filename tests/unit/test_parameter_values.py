"""Parameters as ROS 2 types them (nodes/core/parameter_values.py) and the answers of rcl_interfaces' parameter
services for a nodes.core node (nodes/core/ros_parameters.py), without a network."""

from __future__ import annotations

import math

import pytest

import msgs
from msgs.type_hash import rihs01
from nodes.core import parameter_values as pv
from nodes.core.node_parameters import NodeParameters
from nodes.core.params import ParameterDescriptor
from nodes.core.ros_parameters import SERVICES, CoreParameterBackend

ParameterValue = msgs.get_type("rcl_interfaces/msg/ParameterValue")
Parameter = msgs.get_type("rcl_interfaces/msg/Parameter")

# Jazzy's type hashes of the six services, as rmw_zenoh announces them (published in several independent
# rmw_zenoh clients); zenoh-ros2-sdk computes DescribeParameters' (bounded sequences) differently.
JAZZY_HASHES = {
    "GetParameters": "RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc",
    "SetParameters": "RIHS01_56eed9a67e169f9cb6c1f987bc88f868c14a8fc9f743a263bc734c154015d7e0",
    "SetParametersAtomically": "RIHS01_0e192ef259c07fc3c07a13191d27002222e65e00ccec653ca05e856f79285fcd",
    "ListParameters": "RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d",
    "DescribeParameters": "RIHS01_845b484d71eb0673dae682f2e3ba3c4851a65a3dcfb97bddd82c5b57e91e4cff",
    "GetParameterTypes": "RIHS01_da199c878688b3e530bdfe3ca8f74cb9fa0c303101e980a9e8f260e25e1c80ca",
}


def test_the_six_services_have_jazzys_type_hashes() -> None:
    assert len(SERVICES) == 6
    for name, expected in JAZZY_HASHES.items():
        assert rihs01(f"rcl_interfaces/srv/{name}") == expected, name


@pytest.mark.parametrize(("value", "ptype", "field"), [
    (True, pv.BOOL, "bool_value"),
    (-3, pv.INTEGER, "integer_value"),
    (2.5, pv.DOUBLE, "double_value"),
    ("hi", pv.STRING, "string_value"),
    (b"\x01\x02", pv.BYTE_ARRAY, "byte_array_value"),
    ([True, False], pv.BOOL_ARRAY, "bool_array_value"),
    ([1, 2], pv.INTEGER_ARRAY, "integer_array_value"),
    ([1.5, 2.0], pv.DOUBLE_ARRAY, "double_array_value"),
    (["a", "b"], pv.STRING_ARRAY, "string_array_value"),
])
def test_each_ros_type_round_trips(value, ptype, field) -> None:
    msg = pv.to_msg(value)
    assert msg.type == ptype
    assert getattr(msg, field) == value
    assert pv.from_msg(msg) == value
    decoded = msgs.decode(ParameterValue, msgs.encode(msg))   # what travels (the wire twin converts to CDR)
    assert pv.from_msg(decoded) == value


def test_values_ros_cannot_type() -> None:
    assert pv.to_msg(None).type == pv.NOT_SET and pv.from_msg(ParameterValue()) is None
    assert pv.type_of([1, 2.5]) == pv.DOUBLE_ARRAY and pv.to_msg([1, 2.5]).double_array_value == [1.0, 2.5]
    assert pv.type_of([]) == pv.STRING_ARRAY and pv.type_of([], pv.DOUBLE_ARRAY) == pv.DOUBLE_ARRAY
    as_text = pv.to_msg({"hip": {"p": 100.0}})      # maps, mixed and nested lists: one-line YAML in a string
    assert as_text.type == pv.STRING and as_text.string_value == "{hip: {p: 100.0}}"
    assert pv.to_msg([1, "a"]).string_value == "[1, a]"
    assert pv.to_msg(1 << 70).type == pv.STRING    # beyond int64
    with pytest.raises(ValueError, match="unknown parameter type 12"):
        pv.from_msg(ParameterValue(type=12))


def test_a_declaration_as_a_ros_descriptor() -> None:
    gain = ParameterDescriptor("gain", 1.0, float, "controller gain", min_value=0.0, max_value=10.0)
    d = pv.describe(gain, 1.0)
    assert (d.name, d.type, d.description, d.read_only, d.dynamic_typing) == ("gain", pv.DOUBLE, "controller gain",
                                                                               False, False)
    assert [(r.from_value, r.to_value, r.step) for r in d.floating_point_range] == [(0.0, 10.0, 0.0)]
    count = pv.describe(ParameterDescriptor("n", 3, int, min_value=1), 3)
    assert count.type == pv.INTEGER and count.integer_range[0].from_value == 1
    assert count.integer_range[0].to_value == (1 << 63) - 1
    mode = pv.describe(ParameterDescriptor("mode", "a", str, choices=("a", "b"), read_only="set at start-up"), "a")
    assert mode.read_only and "one of ['a', 'b']" in mode.additional_constraints
    assert "set at start-up" in mode.additional_constraints
    joints = pv.describe(ParameterDescriptor("joints", [], list, element_type=str), [])
    assert joints.type == pv.STRING_ARRAY
    assert pv.describe(ParameterDescriptor("gains", {}, dict), {}).type == pv.STRING
    assert pv.describe(ParameterDescriptor("any", None, None), None).dynamic_typing
    half = pv.describe(ParameterDescriptor("x", 0.0, float, max_value=1.0), 0.0).floating_point_range[0]
    assert half.from_value == -math.inf and half.to_value == 1.0


def test_list_follows_rclpy_prefixes_and_depth() -> None:
    names = ["use_sim_time", "a", "gains.hip.p", "gains.hip.d", "gains.knee", "other.x"]
    everything = pv.list_parameters(names, [], 0)
    assert everything.names == names and everything.prefixes == ["gains.hip", "gains", "other"]
    assert pv.list_parameters(names, [], 1).names == ["use_sim_time", "a"]
    assert pv.list_parameters(names, ["gains"], 0).names == ["gains.hip.p", "gains.hip.d", "gains.knee"]
    assert pv.list_parameters(names, ["gains"], 1).names == ["gains.knee"]
    assert pv.list_parameters(names, ["gains.hip"], 1).names == ["gains.hip.p", "gains.hip.d"]


def _set(name: str, value: ParameterValue) -> Parameter:
    return Parameter(name=name, value=value)


def test_a_core_node_answers_as_rclpy_does() -> None:
    params = NodeParameters({"gain": 2.0})
    params.declare("gain", 1.0, min_value=0.0, max_value=10.0)
    params.declare("mode", "idle", read_only=True)
    params.declare("gains", {"hip": 1.0})
    seen = []
    params.add_on_set_callback(lambda name, value: seen.append((name, value)) or ("no 7" if value == 7.0 else None))
    backend = CoreParameterBackend(params)
    assert [pv.from_msg(v) for v in backend.get_values(["gain", "mode"])] == [2.0, "idle"]
    assert backend.get_values(["gain", "missing"]) == []            # rclpy: one unknown name, no values
    assert backend.get_types(["gain", "gains"]) == [pv.DOUBLE, pv.STRING]
    assert backend.describe(["missing"]) == []
    assert backend.list([], 0).names == ["gain", "mode", "gains"]
    results = backend.set_each([_set("gain", pv.to_msg(3.0)), _set("gain", pv.to_msg(70.0)),
                                _set("mode", pv.to_msg("run")), _set("gain", pv.to_msg(7.0)),
                                _set("nope", pv.to_msg(1)), _set("gain", ParameterValue()),
                                _set("gains", pv.to_msg("{hip: 2.0}"))])
    assert [r.successful for r in results] == [True, False, False, False, False, False, True]
    assert "above the maximum 10.0" in results[1].reason and "read-only" in results[2].reason
    assert "no 7" in results[3].reason and "not declared" in results[4].reason
    assert "cannot be undeclared" in results[5].reason
    assert params.get("gain") == 3.0 and params.get("gains") == {"hip": 2.0}   # a map set from its YAML text
    assert ("gain", 7.0) in seen
    # all or nothing: the valid first value is not applied when the second is refused
    result = backend.set_atomically([_set("gain", pv.to_msg(4.0)), _set("gain", pv.to_msg(70.0))])
    assert not result.successful and params.get("gain") == 3.0
    assert backend.set_atomically([_set("gain", pv.to_msg(4)), _set("gains", pv.to_msg("{}"))]).successful
    assert params.get("gain") == 4.0 and isinstance(params.get("gain"), float)


def test_rclpy_parameters_become_values_the_wire_carries() -> None:
    from rclpy.parameter import Parameter as RclpyParameter

    for value in ([b"\x01", b"\x02"], b"\x01\x02", [1, 2]):   # rclpy's byte arrays are lists of bytes
        msg = RclpyParameter("b", RclpyParameter.Type.BYTE_ARRAY, value).get_parameter_value()
        assert msg.byte_array_value == b"\x01\x02"
        assert pv.from_msg(msgs.decode(ParameterValue, msgs.encode(msg))) == b"\x01\x02"
    back = RclpyParameter.from_parameter_msg(Parameter(name="g", value=pv.to_msg([0.5, 1.0])))
    assert (back.type_, back.value) == (RclpyParameter.Type.DOUBLE_ARRAY, [0.5, 1.0])
