"""``ActionClient`` as rclpy has it, over ``nodes.core.action.ActionClient``: goals, results and cancels
return Futures completed on the spinning thread; feedback callbacks run there too."""

from __future__ import annotations

import time
from typing import Any

from rclpy._entities import CALL_TIMEOUT_S, _calls, check_message
from rclpy.action.endpoint import ActionEndpoint
from rclpy.task import Future


class ClientGoalHandle:
    def __init__(self, client: ActionClient, core: Any, goal_id: Any, accepted: bool, stamp: Any) -> None:
        self._client, self._core = client, core
        self.goal_id, self.stamp, self.accepted = goal_id, stamp, accepted
        self._status = 1 if accepted else 0

    def __repr__(self) -> str:
        return f"ClientGoalHandle <id={bytes(self.goal_id.uuid).hex()}, accepted={self.accepted}, " \
               f"status={self.status}>"

    @property
    def status(self) -> int:
        return self._status

    def get_result_async(self) -> Future:
        return self._client._get_result_async(self)

    def cancel_goal_async(self) -> Future:
        return self._client._cancel_goal_async(self)

    def get_result(self) -> Any:
        future = self.get_result_async()
        future.wait()
        return future.result()

    def cancel_goal(self) -> Any:
        future = self.cancel_goal_async()
        future.wait()
        return future.result()


class ActionClient(ActionEndpoint):
    def __init__(self, node: Any, action_type: Any, action_name: str, *, callback_group: Any = None,
                 goal_service_qos_profile: Any = None, result_service_qos_profile: Any = None,
                 cancel_service_qos_profile: Any = None, feedback_sub_qos_profile: Any = None,
                 status_sub_qos_profile: Any = None) -> None:
        self._node, self._action_type = node, action_type
        key = node._zr_resolve(action_name)
        self._core = node._zr.create_action_client(action_type, "/" + key)
        self._attach(callback_group)

    def _complete(self, future: Future, result: Any = None, error: BaseException | None = None) -> None:
        """Hand a result to the spinning thread, which completes ``future`` (its done callbacks run there)."""
        def done() -> None:
            if future.done():
                return
            if error is not None:
                future.set_exception(error)
            else:
                future.set_result(result)

        self._node._zr.executor.put((done, (), "action client", self.callback_group))

    def _in_background(self, work: Any) -> None:
        _calls.submit(work)

    def server_is_ready(self) -> bool:
        return self._core.wait_for_server(0.3)

    def wait_for_server(self, timeout_sec: float | None = None) -> bool:
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        while True:
            if self._core.wait_for_server(0.3):
                return True
            if not self._node.context.ok():
                return False
            if deadline is not None and time.monotonic() >= deadline:
                return False

    def send_goal_async(self, goal: Any, feedback_callback: Any = None, goal_uuid: Any = None) -> Future:
        check_message(goal, self._action_type.Goal, f"goal of action '{self._core.key}'")
        future = Future()
        executor = self._node._zr.executor
        feedback_type = self._action_type.FeedbackMessage

        def on_feedback(feedback: Any, goal_id: bytes) -> None:
            from msgs.unique_identifier_msgs import UUID

            message = feedback_type(goal_id=UUID(uuid=goal_id), feedback=feedback)
            executor.put((feedback_callback, (message,), "feedback callback", self.callback_group))

        def work() -> None:
            holder: dict[str, bytes] = {}
            callback = None
            if feedback_callback is not None:
                def callback(fb: Any) -> None:
                    on_feedback(fb, holder.get("id", b""))
            try:
                core = self._send(goal, callback, holder)
            except Exception as exc:  # noqa: BLE001 - no server ever answered: the future stays pending
                self._node.get_logger().debug(f"send_goal: {exc}")
                return
            from msgs.unique_identifier_msgs import UUID

            handle = ClientGoalHandle(self, core, UUID(uuid=core.goal_id), core.accepted, core.stamp)
            self._complete(future, handle)

        self._in_background(work)
        return future

    def _send(self, goal: Any, callback: Any, holder: dict[str, bytes]) -> Any:
        """The core client's send_goal, with the goal id known to the feedback callback before any feedback."""
        import os

        goal_id = os.urandom(16)
        holder["id"] = goal_id
        return self._core.send_goal(goal, callback, timeout=CALL_TIMEOUT_S, goal_id=goal_id)

    def send_goal(self, goal: Any, feedback_callback: Any = None, goal_uuid: Any = None) -> Any:
        """Send and wait for the result (rclpy's blocking form; needs no other thread spinning here)."""
        future = self.send_goal_async(goal, feedback_callback, goal_uuid)
        future.wait()
        handle = future.result()
        if not handle.accepted:
            return None
        return handle.get_result()

    def _get_result_async(self, handle: ClientGoalHandle) -> Future:
        future = Future()

        def work() -> None:
            try:
                status, result = handle._core.get_result(timeout=CALL_TIMEOUT_S)
            except Exception as exc:  # noqa: BLE001 - no answer: the goal is unknown to the server now
                self._node.get_logger().debug(f"get_result: {exc}")
                return
            handle._status = status
            response = self._action_type.GetResultResponse(status=status, result=result)
            self._complete(future, response)

        self._in_background(work)
        return future

    def _cancel_goal_async(self, handle: ClientGoalHandle) -> Future:
        future = Future()

        def work() -> None:
            try:
                response = handle._core.cancel(timeout=30.0)
            except Exception as exc:  # noqa: BLE001
                self._node.get_logger().warn(f"cancel_goal: {exc}")
                return
            self._complete(future, response)

        self._in_background(work)
        return future


__all__ = ["ActionClient", "ClientGoalHandle"]
