"""A minimal lockstep partner for the simulator: answers every ``hardware/state`` with a ``hardware/command``.

It stands in for the controller manager in tests and benchmarks. ``policy(state) -> {joint: position}``
decides the position targets (default: hold the first state's positions). Run as a process with
``python -m tests.support.hardware_client --ns humanoid`` (the bench's "minimal hardware client").
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import msgpack

import msgs
from nodes.core import Node, run_node
from nodes.core.delivery import Inline, Raw
from nodes.sim.interfaces import HardwareCommand, HardwareState

_pack_command = msgs.packer("zenroid_msgs/msg/HardwareCommand")

Policy = Callable[[dict[str, Any]], dict[str, float]]


class HardwareClient:
    """Subscribes ``<ns>/hardware/state`` (raw msgpack, no dataclasses: this is the hot path) and answers."""

    def __init__(self, node: Node, namespace: str, policy: Policy | None = None, update_rate: int = 1000,
                 record: bool = False) -> None:
        self.namespace = namespace.strip("/")
        self.policy = policy
        self.update_rate = update_rate
        self.record = record
        self.trajectory: list[tuple[int, float, list[float]]] = []   # (step, sim time, positions)
        self.states = 0
        self.last_state: dict[str, Any] | None = None
        self.enabled = True
        self._hold: list[float] | None = None
        self._lock = threading.Lock()
        self._pub = node.create_publisher(HardwareCommand, f"/{self.namespace}/hardware/command", express=True)
        node.create_subscription(HardwareState, f"/{self.namespace}/hardware/state", self._on_state,
                                 delivery=Inline(), message=Raw())

    def _on_state(self, payload: bytes) -> None:
        state = msgpack.unpackb(payload, raw=False)
        with self._lock:
            self.states += 1
            self.last_state = state
            if self.record:
                stamp = state["stamp"]
                self.trajectory.append((state["step"], stamp["sec"] + stamp["nanosec"] * 1e-9, state["position"]))
            if not self.enabled:
                return
            if self.policy is not None:
                targets = self.policy(state)
                names, values = list(targets), list(targets.values())
            else:
                if self._hold is None:
                    self._hold = list(state["position"])
                names, values = state["name"], self._hold
        self._pub.publish_raw(_pack_command(step=state["step"], update_rate=self.update_rate, name=names,
                                            interface=["position"] * len(names), value=values))

    def reset_recording(self) -> None:
        with self._lock:
            self.trajectory = []
            self.states = 0


class HardwareClientNode(Node):
    """Holds the robot's first reported pose through the lockstep hardware interface."""

    default_name = "hardware_client"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("hardware_client", **kwargs)
        robot = self.declare_parameter("robot_namespace", "humanoid", description="robot to drive")
        rate = self.declare_parameter("update_rate", 1000, description="control rate (Hz)", min_value=1)
        self.client = HardwareClient(self, robot, update_rate=rate)


def main(argv: list[str] | None = None) -> int:
    return run_node(HardwareClientNode, argv)


if __name__ == "__main__":
    raise SystemExit(main())
