"""rclpy's pure API on zenroid: arguments as rcl parses them, Time/Duration, QoS, Parameter, loggers,
futures and tasks, and the import behaviour ROS 2 programs depend on."""

from __future__ import annotations

import subprocess
import sys

import pytest

from bench.common import child_env


def test_import_rclpy_does_not_import_rclpy_node() -> None:
    """001's listings use ``rclpy.node.Node`` after ``import rclpy``: AttributeError on ROS 2, and here."""
    code = "import rclpy\ntry:\n    rclpy.node\nexcept AttributeError as e:\n    print(e)\n"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=child_env(), timeout=60)
    assert done.stdout.strip() == "module 'rclpy' has no attribute 'node'", done.stdout + done.stderr


def test_ros_args_as_rcl_parses_them(tmp_path) -> None:
    from rclpy.arguments import RosArgumentError, parse

    params = tmp_path / "params.yaml"
    params.write_text("/**:\n  ros__parameters:\n    rate: 5.0\n    gains: {p: 2.0}\ntalker:\n"
                      "  ros__parameters:\n    rate: 7.0\nother:\n  ros__parameters:\n    rate: 1.0\n")
    ros, rest = parse(["prog", "--flag", "--ros-args", "-r", "__node:=talker", "-r", "__ns:=/robot",
                       "-r", "chatter:=/news", "-r", "other:x:=y", "-p", "rate:=9.5", "-p", "name:=abc",
                       "--params-file", str(params), "--log-level", "debug", "--", "tail"])
    assert rest == ["prog", "--flag", "tail"]
    assert (ros.node_name, ros.namespace) == ("talker", "/robot")
    assert ros.node_remaps("talker") == {"chatter": "/news"}
    assert ros.node_remaps("other") == {"chatter": "/news", "x": "y"}
    # params files first, node section over /**, then -p (rcl's order)
    assert ros.node_params("talker", "/robot") == {"rate": 9.5, "gains": {"p": 2.0}, "gains.p": 2.0, "name": "abc"}
    assert ros.log_levels == {"": "debug"}
    with pytest.raises(RosArgumentError, match="--ros-args: unknown argument '--bogus'"):
        parse(["--ros-args", "--bogus"])
    with pytest.raises(RosArgumentError, match="-p needs a value"):
        parse(["--ros-args", "-p"])


def test_time_and_duration_arithmetic() -> None:
    from rclpy.clock import ClockType
    from rclpy.duration import Duration
    from rclpy.time import Time

    t = Time(seconds=1, nanoseconds=500_000_000)
    d = Duration(seconds=0.25)
    assert (t + d).nanoseconds == 1_750_000_000
    assert (t - d).nanoseconds == 1_250_000_000
    assert (t - Time(seconds=1)).nanoseconds == 500_000_000
    assert t.seconds_nanoseconds() == (1, 500_000_000)
    assert t.to_msg().sec == 1 and t.to_msg().nanosec == 500_000_000
    assert Time.from_msg(t.to_msg()).nanoseconds == t.nanoseconds
    assert Duration.from_msg(Duration(seconds=2.5).to_msg()) == Duration(seconds=2.5)
    assert d * 2 == Duration(seconds=0.5) and d < Duration(seconds=1)
    with pytest.raises(TypeError):
        _ = Time(clock_type=ClockType.ROS_TIME) - Time(clock_type=ClockType.SYSTEM_TIME)
    with pytest.raises(ValueError):
        Time(seconds=-1)


def test_qos_profiles_and_depth() -> None:
    from rclpy.qos import (
        DurabilityPolicy,
        QoSProfile,
        ReliabilityPolicy,
        qos_profile_from_depth,
        qos_profile_sensor_data,
    )

    assert qos_profile_from_depth(10).depth == 10
    assert qos_profile_sensor_data.reliability == ReliabilityPolicy.BEST_EFFORT
    profile = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability="reliable")
    assert profile.reliability == ReliabilityPolicy.RELIABLE
    with pytest.raises(TypeError):
        QoSProfile()
    with pytest.raises(TypeError):
        qos_profile_from_depth("10")


def test_parameter_types() -> None:
    from rclpy.parameter import Parameter

    assert Parameter("a", value=1.5).type_ == Parameter.Type.DOUBLE
    assert Parameter("a", value=[1, 2]).type_ == Parameter.Type.INTEGER_ARRAY
    assert Parameter("a", value=["x"]).type_ == Parameter.Type.STRING_ARRAY
    assert Parameter("a").type_ == Parameter.Type.NOT_SET
    with pytest.raises(ValueError):
        Parameter("a", Parameter.Type.INTEGER, 1.5)


def test_logger_once_skip_first_throttle(capsys) -> None:
    from rclpy.logging import get_logger

    logger = get_logger("api_test")
    for i in range(5):
        logger.info(f"once {i}", once=True)
        logger.info(f"skip {i}", skip_first=True)
        logger.warning(f"throttled {i}", throttle_duration_sec=60.0)
    logger.set_level("error")
    logger.info("hidden")
    out = capsys.readouterr().out
    assert "once 0" in out and "once 1" not in out
    assert "skip 0" not in out and "skip 1" in out
    assert "throttled 0" in out and "throttled 1" not in out
    assert "hidden" not in out


def test_future_and_task() -> None:
    from rclpy.task import Future, Task

    seen = []
    future = Future()
    future.add_done_callback(lambda f: seen.append(f.result()))
    future.set_result(3)
    assert future.done() and seen == [3]

    async def coro():
        return 7

    task = Task(coro)
    task()
    assert task.done() and task.result() == 7


def test_unimplemented_api_says_so() -> None:
    from rclpy.exceptions import not_implemented

    error = not_implemented("Node.add_waitable")
    assert isinstance(error, NotImplementedError)
    assert "Node.add_waitable" in str(error) and "docs/rclpy.md" in str(error)
