"""``Node``: a named participant with parameters, endpoints, timers, a clock, a logger and a graph presence.

Each concern lives in its own module and ``Node`` composes them: the executor (``executor.py``), parameters
and their services (``node_parameters.py``), endpoint creation (``factory.py``), graph tokens and the ROS 2
twin (``presence.py``), the clock (``clock.py``), the logger services (``log_services.py``). Endpoints see
the node only through ``runtime.NodeRuntime``.

Callbacks run one at a time, as under rclpy's single-threaded executor (``nodes/core/executor.py``:
on the delivering Zenoh thread under the node's executor lock, or all on the spinning thread for nodes
that ask for it); an ``Inline()`` subscription (``nodes/core/delivery.py``) and an ``inline=True`` service run
on Zenoh's thread without the lock.
"""

from __future__ import annotations

import functools
import time
import warnings
from collections.abc import Callable
from typing import Any

import msgpack
import zenoh

import msgs
from msgs.rcl_interfaces import Log
from msgs.rosgraph_msgs import Clock
from msgs.std_msgs import Header
from nodes.core import graph, names
from nodes.core.action import ActionClient, ActionServer
from nodes.core.clock import NodeClock
from nodes.core.delivery import Decoded, Delivery, Inline, legacy_subscription_options
from nodes.core.endpoints import Client, Publisher, Ros2Client, ServiceServer, Subscription
from nodes.core.executor import Executor, Timer
from nodes.core.factory import EndpointFactory
from nodes.core.log import Logger
from nodes.core.log_services import LoggerLevelServices
from nodes.core.node_parameters import NodeParameters
from nodes.core.parameter_events import ParameterEvents
from nodes.core.presence import GraphPresence
from nodes.core.ros_parameters import CoreParameterBackend, RosParameterServices
from nodes.core.session import open_peer


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
        self._remap = dict(remap or {})
        self._closed = False
        self.presence = GraphPresence(self.session, self.fully_qualified_name, self.logger)
        self.session_id = self.presence.session_id
        self._endpoints = EndpointFactory(self, self.resolve)
        self.parameters = NodeParameters(params)
        self.parameter_events = ParameterEvents(functools.partial(Node.create_publisher, self),
                                                self.fully_qualified_name, self._event_stamp)
        self.parameters.listener = self.parameter_events.core_listener(self.parameters.descriptor,
                                                                       self.parameters.get)
        self.use_sim_time = bool(self.declare_parameter(
            "use_sim_time", False, description="follow sim/clock instead of the wall clock",
            read_only="the clock is chosen at start-up: restart the node with --param use_sim_time:=..."))
        self.clock = NodeClock(self.use_sim_time, self.executor, self.logger)
        self._rosout = Publisher(self, Log, "rosout")
        self.logger.set_sink(self._publish_log)
        if self.use_sim_time:
            self.create_subscription(Clock, "/sim/clock", self.clock.on_clock, delivery=Inline())
        self.parameters.serve(self.create_service)
        # rcl_interfaces' six, on the ROS 2 wire only (our keys of the same names keep the two above)
        self.ros_parameters = RosParameterServices(functools.partial(Node.create_service, self),
                                                   self.destroy_entity, CoreParameterBackend(self.parameters),
                                                   self.fully_qualified_name, self.logger)
        LoggerLevelServices(self.logger, (self.name, self.fully_qualified_name)).serve(self.create_service)
        # the launcher's liveness probe, answered here on Zenoh's thread (a flood of requests does not delay
        # it); the mark it queues shows, at the next probe, whether the spinner still takes work
        self._alive = self.session.declare_queryable(graph.alive_key(self.fully_qualified_name), self._on_alive)

    def _event_stamp(self) -> Any:
        """Now on the node clock (wall time while the constructor has not made the clock yet)."""
        clock = self.__dict__.get("clock")
        return clock.stamp(time.time()) if clock is not None else msgs.time_from_sec(time.time())

    def _on_alive(self, query: zenoh.Query) -> None:
        stalled = self.executor.stalled_for()
        self.executor.mark()
        query.reply(query.key_expr, msgpack.packb({"stalled_for": stalled}))

    # ------------------------------------------------------------ names, logging
    def resolve(self, name: str, *, wildcards: bool = False) -> str:
        resolved = names.resolve(name, self.namespace, self.name, wildcards=wildcards)
        return names.apply_remap(resolved, self._remap, self.namespace, self.name)

    @property
    def closed(self) -> bool:
        """True once ``destroy`` has begun (publishers called from in-flight callbacks do nothing then)."""
        return self._closed

    def _publish_log(self, level: int, name: str, text: str, wall: float) -> None:
        if self._closed:
            return
        # droppable: a log flood on a congested link must never block the caller (the physics loop, the
        # controller manager's hardware cycle); the line is on stdout and in the node's log file anyway
        self._rosout.publish_raw(msgs.encode(Log(stamp=self.clock.stamp(wall), level=level, name=name, msg=text)),
                                 droppable=True)

    # ------------------------------------------------------------ parameters (nodes/core/node_parameters.py)
    def declare_parameter(self, name: str, default: Any, *, description: str = "", type: type | None = None,
                          min_value: float | None = None, max_value: float | None = None,
                          choices: list[Any] | tuple[Any, ...] | None = None,
                          validator: Callable[[Any], str | None] | None = None,
                          read_only: bool | str = False) -> Any:
        """Declare a typed parameter and return its value (override from launch/CLI, else default).

        ``read_only`` (True, or the reason as text) refuses changes at run time: use it for every parameter
        the node only reads at start-up, so ``zenroid param set`` says so instead of pretending."""
        return self.parameters.declare(name, default, description=description, type=type, min_value=min_value,
                                       max_value=max_value, choices=choices, validator=validator,
                                       read_only=read_only)

    def get_parameter(self, name: str) -> Any:
        return self.parameters.get(name)

    def has_parameter_override(self, name: str) -> bool:
        return self.parameters.has_override(name)

    def parameter_overrides(self) -> dict[str, Any]:
        """Every value given from outside (launch, params file, --param), declared or not."""
        return self.parameters.overrides()

    def set_parameter(self, name: str, value: Any) -> Any:
        return self.parameters.set(name, value)

    def add_on_set_parameter_callback(self, callback: Callable[[str, Any], str | None]) -> None:
        """``callback(name, value)`` may veto a change by returning a reason."""
        self.parameters.add_on_set_callback(callback)

    # ------------------------------------------------------------ endpoints (nodes/core/factory.py)
    def create_publisher(self, msg_type: Any, topic: str, *, reliable: bool = True,
                         priority: zenoh.Priority | None = None, express: bool = False,
                         latched: bool = False, depth: int = 1, lifespan: float | None = None,
                         ros2_qos: Any = None) -> Any:
        """``latched=True``: the last ``depth`` messages are also answered as a queryable on the key, so late
        joiners get them with ``fetch_latched`` (the newest) or ``fetch_latched_history`` (ROS "transient
        local", as for robot_description and tf_static), each for ``lifespan`` s after it was published (None:
        for ever). ``ros2_qos`` (``ros2.names.Qos``): the QoS its ROS 2 twin announces."""
        return self._endpoints.publisher(msg_type, topic, reliable=reliable, priority=priority, express=express,
                                         latched=latched, depth=depth, lifespan=lifespan, ros2_qos=ros2_qos)

    def fetch_latched(self, msg_type: Any, topic: str, timeout: float = 2.0) -> Any | None:
        """The newest message of a latched topic (None when nobody answers within ``timeout`` s)."""
        return self._endpoints.fetch_latched(msg_type, topic, timeout)

    def fetch_latched_history(self, msg_type: Any, topic: str, timeout: float = 2.0) -> list[Any]:
        """Every message a latched topic's publisher keeps, oldest first ([]: nobody answered in time)."""
        return self._endpoints.fetch_latched_history(msg_type, topic, timeout)

    def create_subscription(self, msg_type: Any, topic: str, callback: Callable[..., None], *,
                            delivery: Delivery | None = None, message: Decoded | None = None,
                            ros2_qos: Any = None, **legacy: Any) -> Subscription:
        """``callback`` gets each message of ``topic``. ``delivery`` (``nodes.core.delivery``) says where and
        when it runs: ``Executed()`` by default (with the node's other callbacks), ``Inline()`` on Zenoh's
        thread, ``Batched(max_rate)`` at most that many wake-ups a second, ``Pulled(backlog)`` when the node's
        thread calls the subscription's ``take_pending()`` or ``wait(timeout)``. ``message`` says what it
        gets: ``Decoded()`` by default, ``Raw()`` the bytes (``objects=True``: in a container, the object
        another node published); both take ``with_key=True`` (``callback(msg, key)``) and
        ``with_source=True``."""
        if legacy:
            raise TypeError(f"create_subscription('{topic}'): {legacy_subscription_options(legacy)}")
        return self._endpoints.subscription(msg_type, topic, callback, delivery=delivery, message=message,
                                            ros2_qos=ros2_qos)

    def create_service(self, srv_type: Any, name: str, handler: Callable[[Any], Any], *,
                       inline: bool = False, ros2_only: bool = False) -> ServiceServer:
        """``ros2_only=True``: the service exists on the ROS 2 wire only (nothing while that is off), so
        its name may be one that a zenroid service of another type already uses on our key."""
        return self._endpoints.service(srv_type, name, handler, inline=inline, ros2_only=ros2_only)

    def create_client(self, srv_type: Any, name: str) -> Client:
        return self._endpoints.client(srv_type, name)

    def create_ros2_client(self, srv_type: Any, name: str) -> Ros2Client:
        """A client of a service on the ROS 2 wire (CDR): a ROS 2 node's, or one of ours offered there only
        (rcl_interfaces' parameter services). RuntimeError when the wire is off (``ZENROID_ROS2=0``)."""
        return self._endpoints.ros2_client(srv_type, name)

    def create_action_server(self, action_type: Any, name: str, **kwargs: Any) -> ActionServer:
        return self._endpoints.action_server(action_type, name, **kwargs)

    def create_action_client(self, action_type: Any, name: str) -> ActionClient:
        return self._endpoints.action_client(action_type, name)

    def destroy_entity(self, entity: Any) -> None:
        """Undeclare one publisher/subscription/service/client/action endpoint of this node."""
        self._endpoints.destroy(entity)

    def create_timer(self, period: float, callback: Callable[[], None], *, sim_time: bool | None = None) -> Timer:
        """Call ``callback`` every ``period`` s on the node clock (sim time when ``use_sim_time``)."""
        use_sim = self.use_sim_time if sim_time is None else sim_time
        timer = Timer(period, callback, use_sim, self.now if use_sim else time.monotonic)
        self.executor.add_timer(timer)
        return timer

    # ------------------------------------------------------------ clock (nodes/core/clock.py)
    def now(self) -> float:
        """Seconds on the node clock: sim time when ``use_sim_time`` (0 before the first clock), else wall."""
        return self.clock.now()

    def now_msg(self) -> Any:
        return msgs.time_from_sec(self.clock.now())

    def header(self, frame_id: str = "") -> Any:
        return Header(stamp=self.now_msg(), frame_id=frame_id)

    # ------------------------------------------------------------ executor
    def call_soon(self, fn: Callable[[], None], where: str = "callback") -> None:
        """Run ``fn`` on the spinning thread (from any thread), after what is already queued."""
        self.executor.call_soon(fn, where=where)

    def spin_once(self, timeout: float | None = None) -> bool:
        """Run due timers and at most one queued callback, waiting up to ``timeout`` s. True if work ran."""
        return self.executor.spin_once(timeout)

    def spin(self) -> None:
        """Process callbacks until ``request_shutdown()`` / SIGINT / SIGTERM."""
        while not self.executor.shutdown_requested:
            self.executor.spin_once(0.1)

    def request_shutdown(self) -> None:
        """Ask ``spin()`` to return (safe from signal handlers and other threads)."""
        self.executor.request_shutdown()

    @property
    def ok(self) -> bool:
        return not self.executor.shutdown_requested

    def on_process_exit(self) -> None:
        """The shutdown hook: ``run_node`` calls it once ``spin()`` has returned (SIGINT, SIGTERM or
        ``request_shutdown()``), on the executor like a callback and before ``destroy()``, so endpoints still
        work (end running goals, say goodbye on rosout, save state). Override it; the default does nothing."""

    def destroy(self) -> None:
        """Undeclare everything and close the session (if this node opened it)."""
        if self._closed:
            return
        self._closed = True  # first: publishers called from in-flight callbacks become no-ops
        self.request_shutdown()
        self.logger.set_sink(None)
        self._endpoints.destroy_all()
        if getattr(self, "_alive", None) is not None:
            self._alive.undeclare()
        self.presence.close()
        if self._owns_session:
            self.session.close()

    def shutdown(self) -> None:
        """Deprecated spelling of ``destroy()`` (a "shutdown" that closes the node, unlike ``request_shutdown``)."""
        warnings.warn("Node.shutdown() is deprecated: use Node.destroy()", DeprecationWarning, stacklevel=2)
        self.destroy()

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()

