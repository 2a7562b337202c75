"""rclpy's publisher, subscription, service, client, timer, rate and guard condition over ``nodes.core``
endpoints (the classes ``rclpy.publisher`` & co. export)."""

from __future__ import annotations

import inspect
import re
import threading
import time as _time
from typing import TYPE_CHECKING, Any

import msgs
from nodes.core.endpoints import MAX_ARRAY_LENGTH, ServiceError, call_raw, decode_limits
from rclpy._qos_events import PublisherEvents, SubscriptionEvents
from rclpy.exceptions import not_implemented
from rclpy.qos import QoSProfile
from rclpy.task import Future

if TYPE_CHECKING:
    from rclpy.node import Node


def ros_name(key: str) -> str:
    """A zenroid key as the ROS name users see (``joint_states`` → ``/joint_states``)."""
    return "/" + key.lstrip("/")


def check_message(msg: Any, msg_type: Any, where: str) -> bytes:
    """``msg`` encoded and checked as every receiver checks it: a message the codec refuses (a NaN where none
    is allowed, a string or array over the limits) is refused here, in the sending program, with the field
    named (``msgs.DecodeError``, a ValueError), instead of being dropped by every receiver."""
    if getattr(msg, "_type", None) != msg_type._type:
        raise TypeError(f"{where}: expected {msg_type._type}, got {type(msg).__module__}.{type(msg).__name__}")
    try:
        payload = msgs.encode(msg)   # a ValueError here already names the field: it goes as it is
    except (TypeError, OverflowError) as exc:
        raise TypeError(f"{where}: {msg_type._type} cannot be encoded: {exc}") from None
    # Decoding every message would double the cost of a publish: only a payload that may hold what receivers
    # refuse is decoded here, to name the field. Under MAX_ARRAY_LENGTH bytes no array can be too long, and
    # a non-finite float shows as a msgpack float whose exponent bits are all ones.
    if len(payload) >= MAX_ARRAY_LENGTH or _NON_FINITE.search(payload):
        msgs.decode(msg_type, payload, decode_limits())
    return payload


# msgpack float64 (0xcb) and float32 (0xca) with every exponent bit set: +-inf and NaN (or string bytes that
# look so, which the decode then clears)
_NON_FINITE = re.compile(rb"\xcb[\x7f\xff][\xf0-\xff]|\xca[\x7f\xff][\x80-\xff]")


class Publisher:
    def __init__(self, node: Node, core: Any, msg_type: Any, qos: QoSProfile, callback_group: Any,
                 event_callbacks: Any) -> None:
        self._node, self._core, self.msg_type = node, core, msg_type
        self.qos_profile, self.callback_group, self.event_callbacks = qos, callback_group, event_callbacks
        self._raw = hasattr(core, "publish_raw")   # checked once encoded: sent as those bytes
        self._events = PublisherEvents(node, core.key, msg_type._type, qos, event_callbacks, callback_group) \
            if PublisherEvents.needed(qos, event_callbacks) else None

    @property
    def topic_name(self) -> str:
        return ros_name(self._core.key)

    @property
    def topic(self) -> str:
        return self.topic_name

    @property
    def handle(self) -> Any:
        raise not_implemented("Publisher.handle")

    def publish(self, msg: Any) -> None:
        if isinstance(msg, (bytes, bytearray)):   # a serialized message, as rclpy accepts (ours: msgpack)
            msg = msgs.decode(self.msg_type, bytes(msg), decode_limits())
        payload = check_message(msg, self.msg_type, f"publisher on '{self.topic_name}'")
        if self._raw:
            self._core.publish_raw(payload)
        else:
            self._core.publish(msg)   # a latched publisher keeps the message for late joiners
        if self._events is not None:
            self._events.published()

    def get_subscription_count(self) -> int:
        return self._node.count_subscribers(self.topic_name)

    def wait_for_all_acked(self, timeout: Any = None) -> bool:
        """True at once, as rmw_zenoh answers: Zenoh acknowledges nothing end to end (a reliable publisher's
        message is handed to the link in order, and only a congested link makes ``publish`` wait)."""
        return True

    def assert_liveliness(self) -> None:
        """MANUAL_BY_TOPIC: tell the subscriptions this publisher is alive (publishing does too); with the
        other policies there is nothing to assert."""
        if self._events is not None:
            self._events.asserted()

    def _close_events(self) -> None:
        if self._events is not None:
            self._events.close()

    def destroy(self) -> None:
        self._node.destroy_publisher(self)

    def __enter__(self) -> Publisher:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()


class Subscription:
    def __init__(self, node: Node, core: Any, msg_type: Any, callback: Any, qos: QoSProfile, callback_group: Any,
                 event_callbacks: Any, raw: bool, events: SubscriptionEvents | None = None) -> None:
        self._node, self._core, self.msg_type, self.callback = node, core, msg_type, callback
        self.qos_profile, self.callback_group, self.event_callbacks, self.raw = qos, callback_group, \
            event_callbacks, raw
        self._events = events

    def _close_events(self) -> None:
        if self._events is not None:
            self._events.close()

    @property
    def topic_name(self) -> str:
        return ros_name(self._core.key)

    @property
    def handle(self) -> Any:
        raise not_implemented("Subscription.handle")

    def destroy(self) -> None:
        self._node.destroy_subscription(self)

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()


class Service:
    def __init__(self, node: Node, core: Any, srv_type: Any, callback: Any, qos: QoSProfile,
                 callback_group: Any) -> None:
        self._node, self._core, self.srv_type, self.callback = node, core, srv_type, callback
        self.qos_profile, self.callback_group = qos, callback_group

    @property
    def service_name(self) -> str:
        return ros_name(self._core.key)

    srv_name = service_name

    def destroy(self) -> None:
        self._node.destroy_service(self)


class _Calls:
    """Service calls and goals wait for their answer on a thread of their own, not on the spinning thread: the
    answer is then handed to the node's executor, so done callbacks run where rclpy runs them. Daemon
    threads: a call still waiting (a goal's result) never keeps the program from ending."""

    def submit(self, work: Any) -> None:
        threading.Thread(target=work, daemon=True, name="rclpy-call").start()


_calls = _Calls()
# A call never answered (no server ever came) gives up after this long, silently as in ROS 2.
CALL_TIMEOUT_S = 3600.0


class Client:
    def __init__(self, node: Node, core: Any, srv_type: Any, qos: QoSProfile, callback_group: Any) -> None:
        self._node, self._core, self.srv_type = node, core, srv_type
        self.qos_profile, self.callback_group = qos, callback_group
        self._pending: set[Future] = set()

    @property
    def service_name(self) -> str:
        return ros_name(self._core.key)

    srv_name = service_name

    def _request_bytes(self, request: Any) -> bytes:
        return check_message(request, self.srv_type.Request, f"client of '{self.service_name}'")

    def _ask(self, payload: bytes, timeout: float) -> Any:
        data = call_raw(self._node._zr.session, self._core.key, payload, timeout)
        return msgs.decode(self.srv_type.Response, data)

    def call(self, request: Any, timeout_sec: float | None = None) -> Any:
        """The response (blocks this thread; unlike rclpy it needs no other thread spinning). None after
        ``timeout_sec``."""
        payload = self._request_bytes(request)
        try:
            return self._ask(payload, CALL_TIMEOUT_S if timeout_sec is None else timeout_sec)
        except ServiceError:
            if timeout_sec is not None:
                return None
            raise

    def call_async(self, request: Any) -> Future:
        """A Future completed on the spinning thread when the response arrives."""
        payload = self._request_bytes(request)
        future = Future()
        self._pending.add(future)
        executor = self._node._zr.executor

        def done(result: Any, error: BaseException | None) -> None:
            self._pending.discard(future)
            if future.done():
                return
            if error is not None:
                future.set_exception(error)
            else:
                future.set_result(result)

        def work() -> None:
            try:
                response = self._ask(payload, CALL_TIMEOUT_S)
            except ServiceError as exc:
                if "returned an error" in str(exc):
                    self._node.get_logger().error(str(exc))
                return   # no response: the future stays pending, as in ROS 2
            except Exception as exc:  # noqa: BLE001 - a bad response is this future's exception
                executor.put((done, (None, exc), "client response", self.callback_group))
                return
            executor.put((done, (response, None), "client response", self.callback_group))

        _calls.submit(work)
        return future

    def remove_pending_request(self, future: Future) -> None:
        self._pending.discard(future)

    def service_is_ready(self) -> bool:
        return self._core.service_is_ready()

    def wait_for_service(self, timeout_sec: float | None = None) -> bool:
        deadline = None if timeout_sec is None else _time.monotonic() + timeout_sec
        while True:
            if self._core.service_is_ready():
                return True
            from rclpy.context import get_default_context

            if not self._node.context.ok() and self._node.context is get_default_context():
                return False
            if deadline is not None and _time.monotonic() >= deadline:
                return False
            _time.sleep(0.05)

    def destroy(self) -> None:
        self._node.destroy_client(self)


class Timer:
    def __init__(self, node: Node, core: Any, callback: Any, callback_group: Any, clock: Any) -> None:
        self._node, self._core, self.callback, self.callback_group, self._clock = node, core, callback, \
            callback_group, clock
        self._last_call: float | None = None

    @property
    def clock(self) -> Any:
        return self._clock

    @property
    def timer_period_ns(self) -> int:
        return int(round(self._core.period * 1e9))

    @timer_period_ns.setter
    def timer_period_ns(self, value: int) -> None:
        self._core.period = value / 1e9
        self._core.reset()

    def is_ready(self) -> bool:
        return not self._core.cancelled and self._core.next_due <= self._core._now()

    def is_canceled(self) -> bool:
        return self._core.cancelled

    def cancel(self) -> None:
        self._core.cancel()

    def reset(self) -> None:
        was_cancelled = self._core.cancelled
        self._core.cancelled = False
        self._core.reset()
        if was_cancelled:
            self._node._zr.executor.add_timer(self._core)

    def time_since_last_call(self) -> int:
        last = self._last_call if self._last_call is not None else self._core.next_due - self._core.period
        return int((self._core._now() - last) * 1e9)

    def time_until_next_call(self) -> int | None:
        if self._core.cancelled:
            return None
        return int((self._core.next_due - self._core._now()) * 1e9)

    def destroy(self) -> None:
        self._node.destroy_timer(self)

    def __enter__(self) -> Timer:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()


class Rate:
    """``sleep()`` until the next period on the node's clock (no spinning thread needed)."""

    def __init__(self, node: Node, frequency: float, clock: Any) -> None:
        if not frequency > 0:
            raise ValueError(f"rate must be > 0 Hz, got {frequency}")
        self._node, self._period, self._clock = node, 1.0 / frequency, clock
        self._next: float | None = None
        self._destroyed = False

    def _now(self) -> float:
        return self._clock.now().nanoseconds / 1e9

    def sleep(self) -> None:
        if self._destroyed:
            from rclpy.exceptions import ROSInterruptException

            raise ROSInterruptException()
        now = self._now()
        if self._next is None:
            self._next = now
        self._next += self._period
        if self._next < now:   # fell behind: the next tick is one period from now
            self._next = now + self._period
        from rclpy.duration import Duration

        self._clock.sleep_for(Duration(seconds=self._next - now))

    def destroy(self) -> None:
        self._destroyed = True


class GuardCondition:
    def __init__(self, node: Node | None, callback: Any, callback_group: Any) -> None:
        self._node, self.callback, self.callback_group = node, callback, callback_group
        self._lock = threading.Lock()

    def trigger(self) -> None:
        if self._node is not None and self.callback is not None:
            self._node._zr.executor.put((_call_maybe_async(self._node, self.callback), (), "guard condition",
                                         self.callback_group))

    def destroy(self) -> None:
        if self._node is not None:
            self._node.destroy_guard_condition(self)


def _call_maybe_async(node: Node, callback: Any) -> Any:
    """``callback`` as the executor runs it: a coroutine function becomes a task of the node's executor."""
    if not inspect.iscoroutinefunction(callback):
        return callback

    def start(*args: Any) -> None:
        executor = node.executor
        if executor is None:
            raise RuntimeError("a coroutine callback needs the node added to an executor")
        executor.create_task(callback, *args)

    return start
