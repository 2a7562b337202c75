"""``Node``: a named participant with parameters, endpoints, timers, a clock, a logger and a graph presence.

Callbacks run one at a time on the thread that calls ``spin()`` (rclpy's single-threaded executor);
``inline=True`` endpoints run on Zenoh's thread instead.
"""

from __future__ import annotations

import functools
import heapq
import itertools
import queue
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import zenoh

import msgs
from nodes.core import graph, names
from nodes.core.endpoints import Client, Publisher, ServiceServer, Subscription
from nodes.core.log import Logger
from nodes.core.params import ParameterDescriptor, ParameterError, coerce
from nodes.core.session import open_peer

_Log = msgs.get_type("rcl_interfaces/msg/Log")
_Clock = msgs.get_type("rosgraph_msgs/msg/Clock")
_Header = msgs.get_type("std_msgs/msg/Header")
_GetParameters = msgs.get_type("zenroid_msgs/srv/GetParameters")
_SetParameters = msgs.get_type("zenroid_msgs/srv/SetParameters")


@dataclass
class Event:
    """A dora-style event from ``Node.events()``: ``kind`` is "input" (topic + msg) or "stop"."""

    kind: str
    topic: str = ""
    msg: Any = None


class Timer:
    def __init__(self, node: Node, period: float, callback: Callable[[], None], sim_time: bool) -> None:
        if not period > 0:
            raise ValueError(f"timer period must be > 0, got {period}")
        self.node = node
        self.period = float(period)
        self.callback = callback
        self.sim_time = sim_time
        self.next_due = (node.now() if sim_time else time.monotonic()) + self.period
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True

    def reset(self) -> None:
        self.next_due = (self.node.now() if self.sim_time else time.monotonic()) + self.period


class Node:
    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Every subclass constructor that raises after ``Node.__init__`` opened the session destroys the
        node on the way out: an open Zenoh session would keep the process from exiting and reporting."""
        super().__init_subclass__(**kwargs)
        init = cls.__dict__.get("__init__")
        if init is None:
            return

        @functools.wraps(init)
        def guarded_init(self: Node, *args: Any, **kw: Any) -> None:
            try:
                init(self, *args, **kw)
            except BaseException:
                if getattr(self, "_closed", True) is False:
                    self.destroy()
                raise

        cls.__init__ = guarded_init  # type: ignore[method-assign]

    def __init__(self, name: str, *, namespace: str = "", params: dict[str, Any] | None = None,
                 remap: dict[str, str] | None = None, session: zenoh.Session | None = None,
                 connect: list[str] | None = None, log_level: str = "info", node_name: str | None = None) -> None:
        name = node_name or name  # ``--name`` on the command line renames any node
        if not name or "/" in name:
            raise ValueError(f"invalid node name {name!r}")
        self.name = name
        self.namespace = "/".join(p for p in namespace.split("/") if p)
        self.fully_qualified_name = "/" + "/".join(p for p in (self.namespace, name) if p)
        self.logger = Logger(self.fully_qualified_name.lstrip("/"), log_level)
        self._owns_session = session is None
        self.session = session if session is not None else open_peer(connect)
        try:
            self._init_runtime(params, remap)
        except BaseException:
            self._closed = True
            if self._owns_session:
                self.session.close()  # an open session would keep the process from exiting
            raise

    def _init_runtime(self, params: dict[str, Any] | None, remap: dict[str, str] | None) -> None:
        self.session_id = str(self.session.info.zid())
        self._remap = dict(remap or {})
        self._overrides = dict(params or {})
        self._params: dict[str, Any] = {}
        self._descriptors: dict[str, ParameterDescriptor] = {}
        self._param_callbacks: list[Callable[[str, Any], str | None]] = []
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        self._timers: list[tuple[float, int, Timer]] = []
        self._sim_timers: list[Timer] = []
        self._timer_seq = itertools.count()
        self._timer_lock = threading.Lock()
        self._stop = threading.Event()
        self._closed = False
        self._entities: list[Any] = []
        self._tokens: list[Any] = [self.session.liveliness().declare_token(
            graph.node_key(self.session_id, self.fully_qualified_name))]
        self._sim_now = 0.0
        self._have_clock = False
        self.use_sim_time = bool(self.declare_parameter(
            "use_sim_time", False, description="follow sim/clock instead of the wall clock"))
        self._rosout = Publisher(self, _Log, "rosout")
        self.logger.set_sink(self._publish_log)
        if self.use_sim_time:
            self.create_subscription(_Clock, "/sim/clock", self._on_clock, inline=True)
        self.create_service(_GetParameters, "~/get_parameters", self._srv_get_parameters)
        self.create_service(_SetParameters, "~/set_parameters", self._srv_set_parameters)

    # ------------------------------------------------------------ names, graph, logging
    def resolve(self, name: str, *, wildcards: bool = False) -> str:
        resolved = names.resolve(name, self.namespace, self.name, wildcards=wildcards)
        return names.apply_remap(resolved, self._remap, self.namespace, self.name)

    def _graph_token(self, kind: str, key: str, type_name: str) -> Any:
        token = self.session.liveliness().declare_token(
            graph.endpoint_key(kind, self.session_id, self.fully_qualified_name, key, type_name))
        self._tokens.append(token)
        return token

    def _publish_log(self, level: int, name: str, text: str, wall: float) -> None:
        if self._closed:
            return
        stamp = msgs.time_from_sec(self._sim_now if self.use_sim_time else wall)
        self._rosout.publish(_Log(stamp=stamp, level=level, name=name, msg=text))

    # ------------------------------------------------------------ parameters
    def declare_parameter(self, name: str, default: Any, *, description: str = "", type: type | None = None,
                          min_value: float | None = None, max_value: float | None = None,
                          choices: list[Any] | tuple[Any, ...] | None = None,
                          validator: Callable[[Any], str | None] | None = None,
                          read_only: bool = False) -> Any:
        """Declare a typed parameter and return its value (override from launch/CLI, else default)."""
        if name in self._descriptors:
            raise ParameterError(f"parameter '{name}' declared twice")
        ptype = type if type is not None else (builtins_type(default) if default is not None else None)
        desc = ParameterDescriptor(name, default, ptype, description, min_value, max_value,
                                   tuple(choices) if choices is not None else None, validator, read_only)
        value = self._overrides.get(name, default)
        value = coerce(desc, value)
        self._descriptors[name] = desc
        self._params[name] = value
        return value

    def get_parameter(self, name: str) -> Any:
        if name not in self._params:
            raise ParameterError(f"parameter '{name}' is not declared")
        return self._params[name]

    def has_parameter_override(self, name: str) -> bool:
        return name in self._overrides

    def parameter_overrides(self) -> dict[str, Any]:
        """Every value given from outside (launch, params file, --param), declared or not."""
        return dict(self._overrides)

    def set_parameter(self, name: str, value: Any) -> Any:
        desc = self._descriptors.get(name)
        if desc is None:
            raise ParameterError(f"parameter '{name}' is not declared")
        if desc.read_only:
            raise ParameterError(f"parameter '{name}' is read-only")
        value = coerce(desc, value)
        for callback in self._param_callbacks:
            problem = callback(name, value)
            if problem:
                raise ParameterError(f"parameter '{name}': {problem}")
        self._params[name] = value
        return value

    def add_on_set_parameter_callback(self, callback: Callable[[str, Any], str | None]) -> None:
        """``callback(name, value)`` may veto a change by returning a reason."""
        self._param_callbacks.append(callback)

    def describe_parameters(self) -> list[ParameterDescriptor]:
        return list(self._descriptors.values())

    def _srv_get_parameters(self, request: Any) -> Any:
        import yaml

        wanted = request.names or sorted(self._params)
        found = [n for n in wanted if n in self._params]
        return _GetParameters.Response(
            names=found, values_yaml=[yaml.safe_dump(self._params[n], default_flow_style=True).strip() for n in found])

    def _srv_set_parameters(self, request: Any) -> Any:
        from nodes.core.params import parse_value

        if len(request.names) != len(request.values_yaml):
            raise ValueError(f"{len(request.names)} names but {len(request.values_yaml)} values")
        ok, reasons = [], []
        for name, text in zip(request.names, request.values_yaml):
            try:
                self.set_parameter(name, parse_value(text))
                ok.append(True)
                reasons.append("")
            except ParameterError as exc:
                ok.append(False)
                reasons.append(str(exc))
        return _SetParameters.Response(successful=ok, reasons=reasons)

    # ------------------------------------------------------------ endpoints
    def create_publisher(self, msg_type: Any, topic: str, *, reliable: bool = True,
                         priority: zenoh.Priority | None = None, express: bool = False,
                         latched: bool = False) -> Any:
        """``latched=True``: the last message is also answered as a queryable on the key, so late joiners
        get it with ``fetch_latched`` (ROS "transient local", as for robot_description and tf_static)."""
        if latched:
            from nodes.core.latched import LatchedPublisher

            return LatchedPublisher(self, msg_type, topic)
        pub = Publisher(self, msg_type, self.resolve(topic), reliable=reliable, priority=priority, express=express)
        self._entities.append(pub)
        return pub

    def fetch_latched(self, msg_type: Any, topic: str, timeout: float = 2.0) -> Any | None:
        """The last message of a latched topic (None when nobody answers within ``timeout`` s)."""
        from nodes.core.latched import fetch_latched

        return fetch_latched(self.session, msg_type, self.resolve(topic), timeout)

    def create_subscription(self, msg_type: Any, topic: str, callback: Callable[[Any], None] | None = None, *,
                            inline: bool = False, raw: bool = False, with_key: bool = False) -> Subscription:
        """``with_key=True`` calls ``callback(msg, key)`` (useful with wildcards like ``"/*/joint_states"``)."""
        sub = Subscription(self, msg_type, self.resolve(topic, wildcards=True), callback, inline=inline, raw=raw, with_key=with_key)
        self._entities.append(sub)
        return sub

    def create_service(self, srv_type: Any, name: str, handler: Callable[[Any], Any], *,
                       inline: bool = False) -> ServiceServer:
        srv = ServiceServer(self, srv_type, self.resolve(name), handler, inline=inline)
        self._entities.append(srv)
        return srv

    def create_client(self, srv_type: Any, name: str) -> Client:
        cli = Client(self, srv_type, self.resolve(name))
        self._entities.append(cli)
        return cli

    def create_action_server(self, action_type: Any, name: str, **kwargs: Any) -> Any:
        from nodes.core.action import ActionServer

        server = ActionServer(self, action_type, self.resolve(name), **kwargs)
        self._entities.append(server)
        return server

    def create_action_client(self, action_type: Any, name: str) -> Any:
        from nodes.core.action import ActionClient

        client = ActionClient(self, action_type, self.resolve(name))
        self._entities.append(client)
        return client

    def create_timer(self, period: float, callback: Callable[[], None], *, sim_time: bool | None = None) -> Timer:
        """Call ``callback`` every ``period`` s on the node clock (sim time when ``use_sim_time``)."""
        use_sim = self.use_sim_time if sim_time is None else sim_time
        timer = Timer(self, period, callback, use_sim)
        with self._timer_lock:
            if use_sim:
                self._sim_timers.append(timer)
            else:
                heapq.heappush(self._timers, (timer.next_due, next(self._timer_seq), timer))
        self._enqueue(lambda: None)  # wake the executor so it sees the new deadline
        return timer

    # ------------------------------------------------------------ clock
    def _on_clock(self, msg: Any) -> None:
        t = msg.clock.sec + msg.clock.nanosec * 1e-9
        if t < self._sim_now - 1e-9:
            self.logger.info(f"sim time jumped back from {self._sim_now:.3f} to {t:.3f} s (reset): timers restart")
            with self._timer_lock:
                for timer in self._sim_timers:
                    timer.next_due = t + timer.period
        self._sim_now = t
        self._have_clock = True
        self._enqueue(lambda: self._run_sim_timers(t))  # each clock message checks timers at its own time

    def _run_sim_timers(self, now: float) -> None:
        with self._timer_lock:
            self._sim_timers = [t for t in self._sim_timers if not t.cancelled]
            due = [t for t in self._sim_timers if t.next_due <= now + 1e-12]
        for timer in due:
            # Catch up without bursts: one call, next deadline after now.
            timer.next_due += timer.period * max(1, int((now - timer.next_due) // timer.period) + 1)
            self._run_callback(timer.callback, where="timer")

    def now(self) -> float:
        """Seconds on the node clock: sim time when ``use_sim_time`` (0 before the first clock), else wall."""
        return self._sim_now if self.use_sim_time else time.time()

    def now_msg(self) -> Any:
        return msgs.time_from_sec(self.now())

    def header(self, frame_id: str = "") -> Any:
        return _Header(stamp=self.now_msg(), frame_id=frame_id)

    # ------------------------------------------------------------ executor
    def call_soon(self, fn: Callable[[], None], where: str = "callback") -> None:
        """Run ``fn`` on the executor thread (from any thread), after what is already queued."""
        self._enqueue(fn, where)

    def destroy_entity(self, entity: Any) -> None:
        """Undeclare one publisher/subscription/service/client/action endpoint of this node."""
        try:
            entity.destroy()
        finally:
            if entity in self._entities:
                self._entities.remove(entity)

    def _enqueue(self, fn: Callable[[], None], where: str = "callback") -> None:
        self._queue.put((fn, where))

    def _deliver_event(self, topic: str, msg: Any) -> None:
        self._events.put(Event("input", topic, msg))

    def _run_callback(self, fn: Callable[..., None], *args: Any, where: str = "callback") -> None:
        try:
            fn(*args)
        except Exception as exc:  # noqa: BLE001 - a failing callback is reported, the node keeps running
            tb = traceback.extract_tb(exc.__traceback__)
            at = f" at {tb[-1].filename}:{tb[-1].lineno}" if tb else ""
            self.logger.error(f"exception in {where}: {type(exc).__name__}: {exc}{at}")

    def _next_wall_deadline(self) -> float | None:
        with self._timer_lock:
            while self._timers and self._timers[0][2].cancelled:
                heapq.heappop(self._timers)
            return self._timers[0][0] if self._timers else None

    def _run_wall_timers(self) -> None:
        now = time.monotonic()
        due: list[Timer] = []
        with self._timer_lock:
            while self._timers and self._timers[0][0] <= now:
                _, _, timer = heapq.heappop(self._timers)
                if timer.cancelled:
                    continue
                due.append(timer)
                timer.next_due += timer.period
                if timer.next_due < now:  # fell behind: skip missed ticks instead of bursting
                    timer.next_due = now + timer.period
                heapq.heappush(self._timers, (timer.next_due, next(self._timer_seq), timer))
        for timer in due:
            self._run_callback(timer.callback, where="timer")

    def spin_once(self, timeout: float | None = None) -> bool:
        """Run due timers and at most one queued callback, waiting up to ``timeout`` s. True if work ran."""
        self._run_wall_timers()
        deadline = self._next_wall_deadline()
        wait = timeout
        if deadline is not None:
            until_timer = max(0.0, deadline - time.monotonic())
            wait = until_timer if wait is None else min(wait, until_timer)
        try:
            fn, where = self._queue.get(timeout=wait) if wait is None or wait > 0 else self._queue.get_nowait()
        except queue.Empty:
            self._run_wall_timers()
            return False
        self._run_callback(fn, where=where)
        return True

    def spin(self) -> None:
        """Process callbacks until ``shutdown()`` / SIGINT / SIGTERM."""
        while not self._stop.is_set():
            self.spin_once(0.1)

    def events(self, timeout: float | None = None) -> Iterator[Event]:
        """Yield messages of subscriptions created without a callback (dora-rs style) until stop.

        Timers and callback-based endpoints keep running between events. ``timeout`` ends the iteration
        after that many seconds without an event.
        """
        last = time.monotonic()
        while not self._stop.is_set():
            self.spin_once(0.0)
            try:
                event = self._events.get(timeout=0.01)
            except queue.Empty:
                if timeout is not None and time.monotonic() - last > timeout:
                    return
                continue
            last = time.monotonic()
            yield event
        yield Event("stop")

    def request_shutdown(self) -> None:
        """Ask ``spin()`` to return (safe from signal handlers and other threads)."""
        self._stop.set()
        self._queue.put((lambda: None, "wake"))

    @property
    def ok(self) -> bool:
        return not self._stop.is_set()

    def destroy(self) -> None:
        """Undeclare everything and close the session (if this node opened it)."""
        if self._closed:
            return
        self._closed = True  # first: publishers called from in-flight callbacks become no-ops
        self.request_shutdown()
        self.logger.set_sink(None)
        for entity in reversed(self._entities):
            try:
                entity.destroy()
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass
        for token in self._tokens:
            try:
                token.undeclare()
            except Exception:  # noqa: BLE001
                pass
        if self._owns_session:
            self.session.close()

    shutdown = destroy

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()


def builtins_type(value: Any) -> type:
    return {bool: bool, int: int, float: float, str: str, list: list, tuple: list, dict: dict}.get(type(value), object)
