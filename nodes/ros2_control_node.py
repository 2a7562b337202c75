"""controller_manager's ``ros2_control_node``: our controller manager, with its hardware taken from the
``<ros2_control>`` of the robot description (the ``robot_description`` parameter, else the latched
``robot_description`` topic, as ros2_control reads it).

- A ``<hardware><plugin>`` of Gazebo's (``gazebo_ros2_control/GazeboSystem`` ...): the simulator is the hardware;
  only the manager runs, and it waits for the simulator as it always does.
- Any other plugin (``mock_components/GenericSystem``, or a real robot's we cannot drive): GenericSystem's
  semantics in this process (nodes/mock_hardware.py), so controllers, topics and ``ros2 control`` work as
  against ros2_control's mock hardware.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time

from msgs.std_msgs import String
from nodes.control.node import ControllerManagerNode
from nodes.core import Node, run_node
from nodes.core.runner import add_node_arguments, node_kwargs
from nodes.mock_hardware import MockHardware, MockSystem, read_system
from nodes.urdf import UrdfError, load_robot_description

DESCRIPTION_WAIT = 30.0  # s the topic is waited for (robot_state_publisher may start after us)


def robot_description(args: argparse.Namespace, params: dict) -> str:
    """The description as a parameter, else from the latched topic; UrdfError when neither has one."""
    text = params.get("robot_description")
    if isinstance(text, str) and text.strip():
        return load_robot_description(xml=text)
    probe = Node("ros2_control_node_description", **{k: v for k, v in node_kwargs(args, "x").items()
                                                      if k in ("namespace", "connect", "log_level")})
    try:
        deadline = time.monotonic() + DESCRIPTION_WAIT
        while time.monotonic() < deadline:
            message = probe.fetch_latched(String, "robot_description", timeout=1.0)
            if message is not None and message.data:
                return load_robot_description(xml=message.data)
        where = f"/{probe.namespace}/robot_description" if probe.namespace else "/robot_description"
    finally:
        probe.destroy()
    raise UrdfError(f"no robot_description parameter, and nothing on {where} after {DESCRIPTION_WAIT:g} s")


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="ros2_control_node", description=__doc__.split("\n")[0])
    add_node_arguments(parser)
    args, _ = parser.parse_known_args(argv)
    try:
        kwargs = node_kwargs(args, "controller_manager")
        system: MockSystem = read_system(robot_description(args, kwargs["params"]))
    except (UrdfError, ValueError) as exc:
        print(f"ros2_control_node: {exc}", file=sys.stderr)
        return 2
    if system.simulated:
        print(f"ros2_control_node: hardware '{system.plugin}' is the simulator's", flush=True)
        return run_node(ControllerManagerNode, argv)
    rate = float(kwargs["params"].get("update_rate", 100.0))
    hardware = MockHardware(system, rate, namespace=kwargs["namespace"], connect=kwargs["connect"],
                            log_level=kwargs["log_level"])
    spinner = threading.Thread(target=hardware.spin, name="mock-hardware", daemon=True)
    spinner.start()
    try:
        return run_node(ControllerManagerNode, argv)
    finally:
        hardware.request_shutdown()
        spinner.join(timeout=5.0)
        hardware.destroy()


if __name__ == "__main__":
    sys.exit(main())
