"""``Node``: a named participant with parameters, endpoints, timers, a clock, a logger and a graph presence.

Callbacks run one at a time, as under rclpy's single-threaded executor (``nodes/core/executor.py``:
on the delivering Zenoh thread under the node's executor lock, or all on the spinning thread for nodes
that ask for it); ``inline=True`` endpoints run on Zenoh's thread without the lock.
"""

from __future__ import annotations

import functools
import queue
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import zenoh

import msgs
from nodes.core import graph, names, ros2
from nodes.core.endpoints import Client, Publisher, ServiceServer, Subscription
from nodes.core.executor import Executor, Timer
from nodes.core.log import Logger
from nodes.core.params import ParameterDescriptor, ParameterError, coerce
from nodes.core.session import open_peer

_Log = msgs.get_type("rcl_interfaces/msg/Log")
_Clock = msgs.get_type("rosgraph_msgs/msg/Clock")
_Header = msgs.get_type("std_msgs/msg/Header")
_GetParameters = msgs.get_type("zenroid_msgs/srv/GetParameters")
_SetParameters = msgs.get_type("zenroid_msgs/srv/SetParameters")
_GetLoggerLevels = msgs.get_type("rcl_interfaces/srv/GetLoggerLevels")
_SetLoggerLevels = msgs.get_type("rcl_interfaces/srv/SetLoggerLevels")
_LoggerLevel = msgs.get_type("rcl_interfaces/msg/LoggerLevel")
_SetLoggerLevelsResult = msgs.get_type("rcl_interfaces/msg/SetLoggerLevelsResult")


@dataclass
class Event:
    """A dora-style event from ``Node.events()``: ``kind`` is "input" (topic + msg) or "stop"."""

    kind: str
    topic: str = ""
    msg: Any = None


class Node:
    # True: every callback runs on the thread that spins (the simulator: DART from one thread only);
    # False: on the Zenoh thread that delivers it, under the executor lock (no hand-off; see executor.py).
    callbacks_on_spin_thread = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Every subclass constructor that raises after ``Node.__init__`` opened the session destroys the
        node on the way out: an open Zenoh session would keep the process from exiting and reporting."""
        super().__init_subclass__(**kwargs)
        init = cls.__dict__.get("__init__")
        if init is None:
            return

        @functools.wraps(init)
        def guarded_init(self: Node, *args: Any, **kw: Any) -> None:
            depth = self.__dict__.get("_init_depth", 0)
            self.__dict__["_init_depth"] = depth + 1
            try:
                init(self, *args, **kw)
            except BaseException:
                if getattr(self, "_closed", True) is False:
                    self.destroy()
                raise
            finally:
                self.__dict__["_init_depth"] = depth
                if depth == 0:
                    self._constructed()

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
        self.executor = Executor(self.logger.error, on_spin_thread=self.callbacks_on_spin_thread)
        self.executor.lock.acquire()   # released once the whole constructor ran (no callback sees half a node)
        self._constructing = True
        self.session = session if session is not None else open_peer(connect)
        try:
            self._init_runtime(params, remap)
        except BaseException:
            self._closed = True
            self._constructed()
            if self._owns_session:
                self.session.close()  # an open session would keep the process from exiting
            raise
        if not self.__dict__.get("_init_depth"):
            self._constructed()   # a plain Node, not a subclass

    def _constructed(self) -> None:
        if self.__dict__.get("_constructing"):
            self._constructing = False
            self.executor.lock.release()

    def _init_runtime(self, params: dict[str, Any] | None, remap: dict[str, str] | None) -> None:
        self.session_id = str(self.session.info.zid())
        self._remap = dict(remap or {})
        self._overrides = dict(params or {})
        self._params: dict[str, Any] = {}
        self._descriptors: dict[str, ParameterDescriptor] = {}
        self._param_callbacks: list[Callable[[str, Any], str | None]] = []
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        self._closed = False
        self._entities: list[Any] = []
        self._tokens: list[Any] = [self.session.liveliness().declare_token(
            graph.node_key(self.session_id, self.fully_qualified_name))]
        self._ros2 = ros2.attach(self)  # the ROS 2 wire (rmw_zenoh) presence, None when off
        self._sim_now = 0.0
        self._have_clock = False
        self.use_sim_time = bool(self.declare_parameter(
            "use_sim_time", False, description="follow sim/clock instead of the wall clock",
            read_only="the clock is chosen at start-up: restart the node with --param use_sim_time:=..."))
        self._rosout = Publisher(self, _Log, "rosout")
        self.logger.set_sink(self._publish_log)
        if self.use_sim_time:
            self.create_subscription(_Clock, "/sim/clock", self._on_clock, inline=True)
        self.create_service(_GetParameters, "~/get_parameters", self._srv_get_parameters)
        self.create_service(_SetParameters, "~/set_parameters", self._srv_set_parameters)
        # rclpy's logger services (ROS 2 Iron+): `zenroid log level NODE debug` changes the level at run time
        self.create_service(_GetLoggerLevels, "~/get_logger_levels", self._srv_get_logger_levels)
        self.create_service(_SetLoggerLevels, "~/set_logger_levels", self._srv_set_logger_levels)

    # ------------------------------------------------------------ names, graph, logging
    def resolve(self, name: str, *, wildcards: bool = False) -> str:
        resolved = names.resolve(name, self.namespace, self.name, wildcards=wildcards)
        return names.apply_remap(resolved, self._remap, self.namespace, self.name)

    def _graph_token(self, kind: str, key: str, type_name: str) -> Any:
        token = self.session.liveliness().declare_token(
            graph.endpoint_key(kind, self.session_id, self.fully_qualified_name, key, type_name))
        self._tokens.append(token)
        return token

    def _mirror(self, endpoint: Any) -> Any | None:
        """The endpoint's twin on the ROS 2 wire (an object with ``close()``), None when not mirrored."""
        return self._ros2.mirror(endpoint) if self._ros2 is not None else None

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
                          read_only: bool | str = False) -> Any:
        """Declare a typed parameter and return its value (override from launch/CLI, else default).

        ``read_only`` (True, or the reason as text) refuses changes at run time: use it for every parameter
        the node only reads at start-up, so ``zenroid param set`` says so instead of pretending."""
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
            why = desc.read_only if isinstance(desc.read_only, str) else "fixed at start-up: restart the node to change it"
            raise ParameterError(f"parameter '{name}' is read-only ({why})")
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

    def _srv_get_parameters(self, request: Any) -> Any:
        from nodes.core.params import dump_value

        wanted = request.names or sorted(self._params)
        found = [n for n in wanted if n in self._params]
        return _GetParameters.Response(names=found, values_yaml=[dump_value(self._params[n]) for n in found])

    def _srv_get_logger_levels(self, request: Any) -> Any:
        names = request.names or [self.logger.name]
        return _GetLoggerLevels.Response(levels=[
            _LoggerLevel(name=n, level=self.logger.level if n == self.logger.name else 0) for n in names])

    def _srv_set_logger_levels(self, request: Any) -> Any:
        from nodes.core.log import parse_level

        results = []
        for item in request.levels:
            if item.name not in (self.logger.name, self.name, self.fully_qualified_name):
                results.append(_SetLoggerLevelsResult(successful=False, reason=f"no logger '{item.name}' in this "
                                                      f"node (its logger is '{self.logger.name}')"))
                continue
            try:
                self.logger.set_level(parse_level(int(item.level)))
            except ValueError as exc:
                results.append(_SetLoggerLevelsResult(successful=False, reason=str(exc)))
                continue
            self.logger.info(f"log level set to {self.logger.level_name}")
            results.append(_SetLoggerLevelsResult(successful=True))
        return _SetLoggerLevels.Response(results=results)

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
                            inline: bool = False, raw: bool = False, with_key: bool = False,
                            max_rate: float | None = None) -> Subscription:
        """``with_key=True`` calls ``callback(msg, key)`` (useful with wildcards like ``"/*/joint_states"``);
        ``max_rate`` (Hz) batches a fast topic: every message still arrives, at most that many wake-ups a second."""
        sub = Subscription(self, msg_type, self.resolve(topic, wildcards=True), callback, inline=inline, raw=raw,
                           with_key=with_key, max_rate=max_rate)
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
        timer = Timer(period, callback, use_sim, self.now if use_sim else time.monotonic)
        self.executor.add_timer(timer)
        return timer

    # ------------------------------------------------------------ clock
    def _on_clock(self, msg: Any) -> None:
        t = msg.clock.sec + msg.clock.nanosec * 1e-9
        if t < self._sim_now - 1e-9:
            self.logger.info(f"sim time jumped back from {self._sim_now:.3f} to {t:.3f} s (reset): timers restart")
            self.executor.restart_sim_timers(t)
        self._sim_now = t
        self._have_clock = True
        # each clock message checks the sim timers at its own time, on the spinning thread
        self.executor.call_soon(self.executor.run_sim_timers, t, where="sim timers")

    def now(self) -> float:
        """Seconds on the node clock: sim time when ``use_sim_time`` (0 before the first clock), else wall."""
        return self._sim_now if self.use_sim_time else time.time()

    def now_msg(self) -> Any:
        return msgs.time_from_sec(self.now())

    def header(self, frame_id: str = "") -> Any:
        return _Header(stamp=self.now_msg(), frame_id=frame_id)

    # ------------------------------------------------------------ executor
    def call_soon(self, fn: Callable[[], None], where: str = "callback") -> None:
        """Run ``fn`` on the spinning thread (from any thread), after what is already queued."""
        self.executor.call_soon(fn, where=where)

    def destroy_entity(self, entity: Any) -> None:
        """Undeclare one publisher/subscription/service/client/action endpoint of this node."""
        try:
            entity.destroy()
        finally:
            if entity in self._entities:
                self._entities.remove(entity)

    def deliver_event(self, topic: str, msg: Any) -> None:
        """A message for ``events()`` (subscriptions created without a callback)."""
        self._events.put(Event("input", topic, msg))

    def spin_once(self, timeout: float | None = None) -> bool:
        """Run due timers and at most one queued callback, waiting up to ``timeout`` s. True if work ran."""
        return self.executor.spin_once(timeout)

    def spin(self) -> None:
        """Process callbacks until ``shutdown()`` / SIGINT / SIGTERM."""
        while not self.executor.stopped:
            self.executor.spin_once(0.1)

    def events(self, timeout: float | None = None) -> Iterator[Event]:
        """Yield messages of subscriptions created without a callback (dora-rs style) until stop.

        Timers and callback-based endpoints keep running between events. ``timeout`` ends the iteration
        after that many seconds without an event.
        """
        last = time.monotonic()
        while not self.executor.stopped:
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
        self.executor.request_stop()

    @property
    def ok(self) -> bool:
        return not self.executor.stopped

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
        if self._ros2 is not None:
            self._ros2.close()
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
