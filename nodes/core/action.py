"""Actions over Zenoh with exactly the ROS 2 layout (docs/architecture.md, Services and actions): send_goal / cancel_goal / get_result
services and feedback / status topics under the action's key."""

from __future__ import annotations

import os
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zenoh

import msgs
from msgs.action_msgs import CancelGoal, GoalInfo, GoalStatus, GoalStatusArray
from msgs.unique_identifier_msgs import UUID
from nodes.core import graph
from nodes.core.endpoints import Deferred, Publisher, ServiceError, call_raw, decode_request, encoding_for
from nodes.core.executor import CallbackGroup
from nodes.core.runtime import NodeRuntime
from nodes.core.weak_callback import weak_callback

ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = 1, 2, 3, 4, 5, 6
TERMINAL = frozenset({SUCCEEDED, CANCELED, ABORTED})
STATUS_NAMES = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED", 5: "CANCELED",
                6: "ABORTED"}
_KEEP_FINISHED = 64  # terminal goals remembered for late get_result calls


@dataclass(eq=False)
class ServerGoalHandle:
    server: ActionServer
    goal_id: bytes
    goal: Any
    stamp: Any
    status: int = ACCEPTED
    result: Any = None
    _waiting: list[zenoh.Query] = field(default_factory=list, init=False, repr=False)  # get_result queries
    _lock: threading.Lock = field(default_factory=threading.Lock, init=False, repr=False)

    @property
    def is_active(self) -> bool:
        return self.status in (ACCEPTED, EXECUTING, CANCELING)

    @property
    def is_cancel_requested(self) -> bool:
        return self.status == CANCELING

    def execute(self) -> None:
        self._set(EXECUTING)

    def publish_feedback(self, feedback: Any) -> None:
        if self.is_active:
            self.server._publish_feedback(self.goal_id, feedback)

    def succeed(self, result: Any | None = None) -> None:
        self._finish(SUCCEEDED, result)

    def abort(self, result: Any | None = None) -> None:
        self._finish(ABORTED, result)

    def canceled(self, result: Any | None = None) -> None:
        self._finish(CANCELED, result)

    def _set(self, status: int) -> None:
        with self._lock:
            if self.status in TERMINAL:
                return
            self.status = status
        self.server._publish_status()

    def _finish(self, status: int, result: Any | None) -> None:
        with self._lock:
            if self.status in TERMINAL:
                return
            self.status = status
            self.result = result if result is not None else self.server.action_type.Result()
            waiting, self._waiting = self._waiting, []
        for query in waiting:
            self.server._reply_result(query, self)
        self.server._publish_status()
        self.server._on_terminal(self)


@dataclass(frozen=True)
class _ServerCallbacks:
    """An action server's callbacks (rclpy's names without ``_callback``); None: the default behaviour."""

    goal: Callable[[Any], bool | tuple[bool, str]] | None
    cancel: Callable[[ServerGoalHandle], bool] | None
    accepted: Callable[[ServerGoalHandle], None] | None
    execute: Callable[[ServerGoalHandle], Any] | None
    preempt: Callable[[ServerGoalHandle], None] | None


class ActionServer:
    def __init__(self, node: NodeRuntime, action_type: Any, key: str, *,
                 goal_callback: Callable[[Any], bool | tuple[bool, str]] | None = None,
                 cancel_callback: Callable[[ServerGoalHandle], bool] | None = None,
                 accepted_callback: Callable[[ServerGoalHandle], None] | None = None,
                 execute_callback: Callable[[ServerGoalHandle], Any] | None = None,
                 single_goal: bool = False,
                 preempt_callback: Callable[[ServerGoalHandle], None] | None = None) -> None:
        """``single_goal``: a newly accepted goal preempts (aborts) the active one, after ``preempt_callback``."""
        self.node, self.action_type, self.key = node, action_type, key
        self.callbacks = _ServerCallbacks(goal_callback, cancel_callback, accepted_callback, execute_callback,
                                          preempt_callback)
        self.single_goal = single_goal
        self.group: CallbackGroup | None = None   # on a spinning thread: its callback group (rclpy's)
        self.goals: OrderedDict[bytes, ServerGoalHandle] = OrderedDict()
        self._lock = threading.RLock()
        self._feedback = Publisher(node, action_type.FeedbackMessage, f"{key}/feedback")
        self._status = Publisher(node, GoalStatusArray, f"{key}/status")
        s = node.session
        self._queryables = [
            s.declare_queryable(f"{key}/send_goal", weak_callback(self.handle_send_goal), complete=True),
            s.declare_queryable(f"{key}/cancel_goal", weak_callback(self.handle_cancel_goal), complete=True),
            s.declare_queryable(f"{key}/get_result", weak_callback(self.handle_get_result), complete=True),
        ]
        self._token = node.presence.token("act", key, action_type._type)
        self._mirror = node.presence.mirror(self)  # ROS 2 wire twin (nodes/core/ros2) or None

    # -- zenoh side: decode, then hand the work to the node's executor
    def _decode(self, query: zenoh.Query, cls: Any) -> Any | None:
        return decode_request(self.node, query, cls, f"action '{self.key}'")

    def handle_send_goal(self, query: zenoh.Query) -> None:
        request = self._decode(query, self.action_type.SendGoalRequest)
        if request is not None:
            self.node.executor.dispatch(self._handle_goal, query, request, where=f"action '{self.key}' goal", group=self.group)

    def handle_cancel_goal(self, query: zenoh.Query) -> None:
        request = self._decode(query, CancelGoal.Request)
        if request is not None:
            self.node.executor.dispatch(self._handle_cancel, query, request, where=f"action '{self.key}' cancel", group=self.group)

    def handle_get_result(self, query: zenoh.Query) -> None:
        request = self._decode(query, self.action_type.GetResultRequest)
        if request is None:
            return
        goal_id = bytes(request.goal_id.uuid)
        with self._lock:
            handle = self.goals.get(goal_id)
            if handle is None:
                response = self.action_type.GetResultResponse(status=0)
                query.reply(query.key_expr, msgs.encode(response),
                            encoding=encoding_for(self.action_type.GetResultResponse._type))
                query.drop()
                return
            with handle._lock:
                if handle.status not in TERMINAL:
                    handle._waiting.append(query)  # answered when the goal ends (clients pass a timeout)
                    return
        self._reply_result(query, handle)

    # -- executor side
    def _handle_goal(self, query: zenoh.Query, request: Any) -> None:
        goal_id = bytes(request.goal_id.uuid)
        verdict: Any = True
        try:
            if goal_id in self.goals:
                verdict = (False, "duplicate goal id")
            elif self.callbacks.goal is not None:
                verdict = self.callbacks.goal(request.goal)
        except Exception as exc:  # noqa: BLE001 - a failing goal callback rejects the goal
            verdict = (False, f"{type(exc).__name__}: {exc}")
        if isinstance(verdict, Deferred):   # decided later (rclpy's coroutine goal callback): back on the executor
            verdict.on_done(lambda result, error: self.node.executor.dispatch(
                self._decide_goal, query, request, (False, f"{type(error).__name__}: {error}") if error else result,
                where=f"action '{self.key}' goal", group=self.group))
            return
        self._decide_goal(query, request, verdict)

    def _decide_goal(self, query: zenoh.Query, request: Any, verdict: Any) -> None:
        goal_id = bytes(request.goal_id.uuid)
        accepted, reason = verdict if isinstance(verdict, tuple) else (bool(verdict), "")
        stamp = self.node.now_msg()
        response = self.action_type.SendGoalResponse(accepted=accepted, stamp=stamp)
        if not accepted:
            self.node.logger.warn(f"action '{self.key}': goal rejected" + (f": {reason}" if reason else ""))
            self._reply(query, response)
            return
        handle = ServerGoalHandle(self, goal_id, request.goal, stamp)
        if self.single_goal:
            for old in [h for h in self.goals.values() if h.is_active]:
                if self.callbacks.preempt is not None:
                    self.node.executor.run_callback(self.callbacks.preempt, old, where="preempt callback")
                old.abort()
        with self._lock:
            self.goals[goal_id] = handle
            self._trim()
        self._reply(query, response)
        self._publish_status()
        if self.callbacks.accepted is not None:
            self.node.executor.run_callback(self.callbacks.accepted, handle, where="accepted callback")
        elif self.callbacks.execute is not None:
            handle.execute()
            threading.Thread(target=self._run_execute, args=(handle,), daemon=True,
                             name=f"action:{self.key}").start()
        else:
            handle.execute()

    def _run_execute(self, handle: ServerGoalHandle) -> None:
        try:
            result = self.callbacks.execute(handle)  # type: ignore[misc]
        except Exception as exc:  # noqa: BLE001
            self.node.logger.error(f"action '{self.key}' execute failed: {type(exc).__name__}: {exc}")
            handle.abort()
            return
        if handle.is_active:  # the callback returned without choosing: success, as rclpy does
            if handle.is_cancel_requested:
                handle.canceled(result)
            else:
                handle.succeed(result)

    def _handle_cancel(self, query: zenoh.Query, request: Any) -> None:
        goal_id = bytes(request.goal_info.goal_id.uuid)
        cancel_all = goal_id == bytes(16)
        targets = [h for h in self.goals.values() if cancel_all or h.goal_id == goal_id]
        code = 0
        if not targets:
            code = 2  # ERROR_UNKNOWN_GOAL_ID
        verdicts: list[tuple[ServerGoalHandle, Any]] = []
        for handle in targets:
            if not handle.is_active:
                if not cancel_all:
                    code = 3  # ERROR_GOAL_TERMINATED
                continue
            allowed: Any = True
            if self.callbacks.cancel is not None:
                try:
                    allowed = self.callbacks.cancel(handle)
                except Exception as exc:  # noqa: BLE001
                    self.node.logger.error(f"cancel callback failed: {exc}")
                    allowed = False
            verdicts.append((handle, allowed))
        pending = [v for _, v in verdicts if isinstance(v, Deferred)]
        if not pending:
            self._decide_cancel(query, targets, code, verdicts)
            return
        # some are decided later (rclpy's coroutine cancel callback): answer once all are, on the executor
        remaining = [len(pending)]
        lock = threading.Lock()

        def one_done(_result: Any, error: BaseException | None) -> None:
            if error is not None:
                self.node.logger.error(f"cancel callback failed: {type(error).__name__}: {error}")
            with lock:
                remaining[0] -= 1
                last = remaining[0] == 0
            if last:
                self.node.executor.dispatch(self._decide_cancel, query, targets, code, verdicts,
                                            where=f"action '{self.key}' cancel", group=self.group)

        for deferred in pending:
            deferred.on_done(one_done)

    def _decide_cancel(self, query: zenoh.Query, targets: list[ServerGoalHandle], code: int,
                       verdicts: list[tuple[ServerGoalHandle, Any]]) -> None:
        canceling = []
        for handle, allowed in verdicts:
            if isinstance(allowed, Deferred):
                outcome = allowed.outcome
                allowed = outcome is not None and outcome[1] is None and outcome[0]
            if bool(allowed) and handle.is_active:
                handle._set(CANCELING)
                canceling.append(GoalInfo(goal_id=UUID(uuid=handle.goal_id), stamp=handle.stamp))
        if targets and not canceling and code == 0:
            code = 1  # ERROR_REJECTED
        self._reply(query, CancelGoal.Response(return_code=code, goals_canceling=canceling))

    # -- replies and topics
    def _reply(self, query: zenoh.Query, response: Any) -> None:
        try:
            query.reply(query.key_expr, msgs.encode(response), encoding=encoding_for(response._type))
        finally:
            query.drop()

    def _reply_result(self, query: zenoh.Query, handle: ServerGoalHandle) -> None:
        self._reply(query, self.action_type.GetResultResponse(status=handle.status, result=handle.result))

    def _publish_feedback(self, goal_id: bytes, feedback: Any) -> None:
        self._feedback.publish(self.action_type.FeedbackMessage(goal_id=UUID(uuid=goal_id), feedback=feedback))

    def _publish_status(self) -> None:
        with self._lock:
            status_list = [
                GoalStatus(goal_info=GoalInfo(goal_id=UUID(uuid=h.goal_id), stamp=h.stamp), status=h.status)
                for h in self.goals.values()
            ]
        self._status.publish(GoalStatusArray(status_list=status_list))

    def _on_terminal(self, handle: ServerGoalHandle) -> None:
        with self._lock:
            self._trim()

    def _trim(self) -> None:
        finished = [gid for gid, h in self.goals.items() if not h.is_active]
        for gid in finished[: max(0, len(finished) - _KEEP_FINISHED)]:
            del self.goals[gid]

    def destroy(self) -> None:
        for h in list(self.goals.values()):
            if h.is_active:
                h.abort()
        for q in self._queryables:
            q.undeclare()
        # zenoh-python may keep an undeclared queryable's callback (our bound method) until the object goes:
        # a cycle through native code, which the cyclic GC cannot see
        self._queryables = []
        self._feedback.destroy()
        self._status.destroy()
        self._token.undeclare()
        if self._mirror is not None:
            mirror, self._mirror = self._mirror, None
            mirror.close()
        # the owner's methods (see Subscription.destroy): no request reaches them any more
        self.callbacks = _ServerCallbacks(None, None, None, None, None)


@dataclass(eq=False)
class ClientGoalHandle:
    client: ActionClient
    goal_id: bytes
    accepted: bool
    stamp: Any
    status: int = field(init=False)

    def __post_init__(self) -> None:
        self.status = ACCEPTED if self.accepted else 0

    def get_result(self, timeout: float = 30.0) -> tuple[int, Any]:
        """Block until the goal ends; returns (status, result). Raises ServiceError on timeout."""
        request = self.client.action_type.GetResultRequest(goal_id=UUID(uuid=self.goal_id))
        data = call_raw(self.client.node.session, f"{self.client.key}/get_result", msgs.encode(request), timeout)
        response = msgs.decode(self.client.action_type.GetResultResponse, data)
        self.status = response.status
        return response.status, response.result

    def cancel(self, timeout: float = 5.0) -> Any:
        request = CancelGoal.Request(goal_info=GoalInfo(goal_id=UUID(uuid=self.goal_id)))
        data = call_raw(self.client.node.session, f"{self.client.key}/cancel_goal", msgs.encode(request), timeout)
        return msgs.decode(CancelGoal.Response, data)


class ActionClient:
    """Feedback callbacks run on Zenoh's thread, so scripts can use a client without spinning."""

    def __init__(self, node: NodeRuntime, action_type: Any, key: str) -> None:
        self.node = node
        self.action_type = action_type
        self.key = key
        self._feedback_callbacks: dict[bytes, Callable[[Any], None]] = {}
        self._feedback_sub = node.session.declare_subscriber(f"{key}/feedback", weak_callback(self._on_feedback))
        self._token = node.presence.token("actc", key, action_type._type)
        self._mirror = node.presence.mirror(self)  # ROS 2 wire twin (nodes/core/ros2) or None

    def _on_feedback(self, sample: zenoh.Sample) -> None:
        try:
            msg = msgs.decode(self.action_type.FeedbackMessage, sample.payload.to_bytes())
        except msgs.DecodeError as exc:
            self.node.logger.warn_throttle(1.0, f"action '{self.key}': bad feedback: {exc}")
            return
        callback = self._feedback_callbacks.get(bytes(msg.goal_id.uuid))
        if callback is not None:
            self.node.executor.run_callback(callback, msg.feedback, where="feedback callback")

    def wait_for_server(self, timeout: float = 5.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if any(e.kind == "act" and e.name == self.key for e in graph.snapshot(self.node.session, 0.3)):
                return True
            time.sleep(0.05)
        return False

    def send_goal(self, goal: Any, feedback_callback: Callable[[Any], None] | None = None,
                  timeout: float = 5.0, goal_id: bytes | None = None) -> ClientGoalHandle:
        goal_id = goal_id or os.urandom(16)
        if feedback_callback is not None:
            self._feedback_callbacks[goal_id] = feedback_callback
        request = self.action_type.SendGoalRequest(goal_id=UUID(uuid=goal_id), goal=goal)
        try:
            data = call_raw(self.node.session, f"{self.key}/send_goal", msgs.encode(request), timeout)
        except ServiceError:
            self._feedback_callbacks.pop(goal_id, None)
            raise
        response = msgs.decode(self.action_type.SendGoalResponse, data)
        if not response.accepted:
            self._feedback_callbacks.pop(goal_id, None)
        return ClientGoalHandle(self, goal_id, response.accepted, response.stamp)

    def destroy(self) -> None:
        self._feedback_sub.undeclare()
        self._feedback_sub = None   # and its callback, our bound method (see ActionServer.destroy)
        self._token.undeclare()
        if self._mirror is not None:
            mirror, self._mirror = self._mirror, None
            mirror.close()
        self._feedback_callbacks.clear()
