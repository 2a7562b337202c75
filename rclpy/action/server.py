"""``ActionServer`` as rclpy has it, over ``nodes.core.action.ActionServer``.

The goal, cancel and accepted callbacks run on the spinning thread (the server's callback group), goal and
cancel callbacks that are ``async def`` as tasks of the node's executor (the request is answered when they
return); the execute callback runs as a task of the node's executor, a coroutine if it is ``async def``. The goal ends
with the status the execute callback chose (``succeed``/``abort``/``canceled``) and the result it returned.
"""

from __future__ import annotations

import enum
import inspect
import threading
from typing import Any

from nodes.core.action import ABORTED, ACCEPTED, CANCELED, CANCELING, EXECUTING, SUCCEEDED, TERMINAL
from nodes.core.endpoints import Deferred
from rclpy.action.endpoint import ActionEndpoint


class GoalResponse(enum.Enum):
    REJECT = 1
    ACCEPT = 2


class CancelResponse(enum.Enum):
    REJECT = 1
    ACCEPT = 2


class GoalEvent(enum.Enum):
    EXECUTE = 1
    CANCEL_GOAL = 2
    SUCCEED = 3
    ABORT = 4
    CANCELED = 5


def default_goal_callback(goal_request: Any) -> GoalResponse:
    return GoalResponse.ACCEPT


def default_handle_accepted_callback(goal_handle: ServerGoalHandle) -> None:
    goal_handle.execute()


def default_cancel_callback(cancel_request: Any) -> CancelResponse:
    return CancelResponse.REJECT


class ServerGoalHandle:
    def __init__(self, server: ActionServer, core: Any) -> None:
        self._server, self._core = server, core
        self._status = ACCEPTED   # what the user chose; the core handle follows when execute returns
        self._lock = threading.Lock()
        self._finished = False

    @property
    def request(self) -> Any:
        return self._core.goal

    @property
    def goal_id(self) -> Any:
        from msgs.unique_identifier_msgs import UUID

        return UUID(uuid=self._core.goal_id)

    @property
    def is_active(self) -> bool:
        return self._status in (ACCEPTED, EXECUTING, CANCELING) and self._core.status not in TERMINAL

    @property
    def is_cancel_requested(self) -> bool:
        return self._core.status == CANCELING

    @property
    def status(self) -> int:
        if self._status in TERMINAL:
            return self._status
        return self._core.status

    def execute(self, execute_callback: Any = None) -> None:
        """Start the execute callback as a task of the node's executor."""
        self._core.execute()
        self._status = EXECUTING
        callback = execute_callback or self._server._execute_callback
        executor = self._server._node.executor
        if executor is None:
            raise RuntimeError("goal_handle.execute(): the action server's node is not added to an executor")
        task = executor.create_task(self._run, callback)
        task.add_done_callback(self._done)

    def _run(self, callback: Any) -> Any:
        result = callback(self)
        return result

    def _done(self, task: Any) -> None:
        error = task.exception()
        result = None if error is not None else task.result()
        if error is not None:
            self._server._node.get_logger().error(
                f"action '{self._server._core.key}': execute callback raised {type(error).__name__}: {error}")
        self._finish(result)

    def _finish(self, result: Any) -> None:
        with self._lock:
            if self._finished:
                return
            self._finished = True
        action_type = self._server._action_type
        if result is not None and getattr(result, "_type", None) != action_type.Result._type:
            self._server._node.get_logger().error(
                f"action '{self._server._core.key}': execute callback returned {type(result).__name__}, expected "
                f"{action_type.Result._type}; sending an empty result")
            result = None
        status = self._status
        if status not in TERMINAL:
            self._server._node.get_logger().warn(
                f"Goal state not set, assuming aborted. Goal ID: {self._core.goal_id.hex()}")
            status = ABORTED
        {SUCCEEDED: self._core.succeed, CANCELED: self._core.canceled, ABORTED: self._core.abort}[status](result)

    def _update(self, status: int) -> None:
        if self._status in TERMINAL:
            raise RuntimeError(f"goal {self._core.goal_id.hex()} has already ended")
        self._status = status

    def succeed(self) -> None:
        self._update(SUCCEEDED)

    def abort(self) -> None:
        self._update(ABORTED)

    def canceled(self) -> None:
        self._update(CANCELED)

    def publish_feedback(self, feedback: Any) -> None:
        feedback_type = self._server._action_type.Feedback
        if getattr(feedback, "_type", None) != feedback_type._type:
            raise TypeError(f"publish_feedback: expected {feedback_type._type}, got {type(feedback).__name__}")
        self._core.publish_feedback(feedback)

    def destroy(self) -> None:
        return None


class ActionServer(ActionEndpoint):
    def __init__(self, node: Any, action_type: Any, action_name: str, execute_callback: Any, *,
                 callback_group: Any = None, goal_callback: Any = default_goal_callback,
                 handle_accepted_callback: Any = default_handle_accepted_callback,
                 cancel_callback: Any = default_cancel_callback, goal_service_qos_profile: Any = None,
                 result_service_qos_profile: Any = None, cancel_service_qos_profile: Any = None,
                 feedback_pub_qos_profile: Any = None, status_pub_qos_profile: Any = None,
                 result_timeout: int = 900) -> None:
        self._node, self._action_type = node, action_type
        self._execute_callback = execute_callback
        self._goal_callback = goal_callback or default_goal_callback
        self._accepted_callback = handle_accepted_callback or default_handle_accepted_callback
        self._cancel_callback = cancel_callback or default_cancel_callback
        self._handles: dict[bytes, ServerGoalHandle] = {}
        key = node._zr_resolve(action_name)
        self._core = node._zr.create_action_server(
            action_type, "/" + key, goal_callback=self._on_goal, cancel_callback=self._on_cancel,
            accepted_callback=self._on_accepted)
        self._attach(callback_group)
        self._core.group = self.callback_group

    def register_execute_callback(self, execute_callback: Any) -> None:
        self._execute_callback = execute_callback

    def register_goal_callback(self, goal_callback: Any) -> None:
        self._goal_callback = goal_callback or default_goal_callback

    def register_cancel_callback(self, cancel_callback: Any) -> None:
        self._cancel_callback = cancel_callback or default_cancel_callback

    def register_handle_accepted_callback(self, handle_accepted_callback: Any) -> None:
        self._accepted_callback = handle_accepted_callback or default_handle_accepted_callback

    def _on_goal(self, goal: Any) -> Any:
        verdict = self._goal_callback(goal)
        if inspect.iscoroutine(verdict):
            return self._later(verdict, GoalResponse.ACCEPT)
        return verdict == GoalResponse.ACCEPT

    def _later(self, coroutine: Any, yes: Any) -> Deferred:
        """A coroutine callback's verdict: it runs as a task of the node's executor (so it may await
        service calls and other futures); the request is answered when it returns."""
        answer = Deferred()
        executor = self._node.executor
        if executor is None:
            coroutine.close()
            raise RuntimeError("a coroutine goal or cancel callback needs the node added to an executor")

        def done(task: Any) -> None:
            error = task.exception()
            if error is not None:
                answer.fail(error)
            else:
                answer.resolve(task.result() == yes)

        executor.create_task(coroutine).add_done_callback(done)
        return answer

    def _on_accepted(self, core_handle: Any) -> None:
        handle = ServerGoalHandle(self, core_handle)
        self._handles[core_handle.goal_id] = handle
        if len(self._handles) > 256:   # the finished ones are not needed any more
            for goal_id in [g for g, h in self._handles.items() if not h.is_active][:128]:
                del self._handles[goal_id]
        self._accepted_callback(handle)

    def _on_cancel(self, core_handle: Any) -> bool:
        handle = self._handles.get(core_handle.goal_id)
        if handle is None:
            return False
        verdict = self._cancel_callback(handle)
        if inspect.iscoroutine(verdict):
            return self._later(verdict, CancelResponse.ACCEPT)
        return verdict == CancelResponse.ACCEPT
