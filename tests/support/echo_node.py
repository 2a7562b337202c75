"""A real node process for the core integration tests: echoes every message type, serves a service,
an action (feedback, cancel, preemption) and lifecycle transitions."""

from __future__ import annotations

import time
from typing import Any

import msgs
from nodes.core import LifecycleNode, ServerGoalHandle, run_node

Trigger = msgs.get_type("std_srvs/srv/Trigger")
SetBool = msgs.get_type("std_srvs/srv/SetBool")
Navigate = msgs.get_type("humanoid_msgs/action/NavigateToGoal")


class EchoNode(LifecycleNode):
    default_name = "echo"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("echo", **kwargs)
        types = self.declare_parameter("types", [""], description="message types to echo")
        self.calls = 0
        for type_name in filter(None, types):
            cls = msgs.get_type(type_name)
            pub = self.create_publisher(cls, f"/echo/out/{type_name}")
            self.create_subscription(cls, f"/echo/in/{type_name}", pub.publish)
        self.create_service(Trigger, "~/trigger", self.on_trigger)
        self.create_service(SetBool, "~/fail", self.on_fail)
        self.create_action_server(Navigate, "~/navigate", execute_callback=self.navigate, single_goal=True,
                                  cancel_callback=lambda handle: True)
        self.logger.info("ready")

    def on_trigger(self, request: Any) -> Any:
        self.calls += 1
        return Trigger.Response(success=True, message=f"call {self.calls}")

    def on_fail(self, request: Any) -> Any:
        raise RuntimeError("this handler always fails")

    def navigate(self, handle: ServerGoalHandle) -> Any:
        goal = handle.goal
        steps = max(1, int(goal.max_velocity * 10))  # max_velocity doubles as "seconds to run" here
        for i in range(steps):
            if not handle.is_active:
                return Navigate.Result(success=False, message="preempted")
            if handle.is_cancel_requested:
                handle.canceled(Navigate.Result(success=False, message="canceled"))
                return None
            handle.publish_feedback(Navigate.Feedback(progress_percent=100.0 * i / steps,
                                                      distance_remaining=float(steps - i)))
            time.sleep(0.1)
        return Navigate.Result(success=True, message="arrived", total_distance=float(steps))


def main(argv: list[str] | None = None) -> int:
    return run_node(EchoNode, argv)


if __name__ == "__main__":
    raise SystemExit(main())
