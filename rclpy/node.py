"""``rclpy.node.Node``: rclpy's node as a face of a ``nodes.core`` node.

The rclpy node holds a ``nodes.core`` node (``self._zr``) whose callbacks all wait for the spinning thread
(rclpy's model): same session as the other nodes of its context, same keys, graph tokens and ROS 2 twin as
every zenroid node. Everything the user's subclass may name (``self.logger``, ``self.clock``, ``self.timer``)
stays free: the face keeps its own state in ``_zr*`` attributes.
"""

from __future__ import annotations

import math
import re
import threading
from collections.abc import Callable, Iterable
from typing import Any

import msgs

# As rclpy.node does, import the modules programs then reach as ``rclpy.executors.ExternalShutdownException``
# & co. after ``from rclpy.node import Node`` alone.
import rclpy.client  # noqa: E402, F401
import rclpy.constants  # noqa: E402, F401
import rclpy.event_handler  # noqa: E402, F401
import rclpy.executors  # noqa: E402, F401
import rclpy.guard_condition  # noqa: E402, F401
import rclpy.publisher  # noqa: E402, F401
import rclpy.service  # noqa: E402, F401
import rclpy.subscription  # noqa: E402, F401
import rclpy.timer  # noqa: E402, F401
import rclpy.utilities  # noqa: E402, F401
from nodes.core import graph
from nodes.core.delivery import Executed, Inline, Raw, Spun
from nodes.core.latched import fetch_latched_history
from nodes.core.names import NameError_
from nodes.core.node import Node as CoreNode
from nodes.core.parameter_values import list_parameters as list_parameter_names
from rclpy._entities import (
    Client,
    GuardCondition,
    Publisher,
    Rate,
    Service,
    Subscription,
    Timer,
    _call_maybe_async,
    ros_name,
)
from rclpy._qos_events import SubscriptionEvents, wire_qos
from rclpy._qos_timing import seconds
from rclpy.callback_groups import CallbackGroup, MutuallyExclusiveCallbackGroup
from rclpy.clock import Clock, ROSClock
from rclpy.context import Context, get_default_context
from rclpy.exceptions import (
    InvalidNodeNameException,
    InvalidParameterTypeException,
    InvalidParameterValueException,
    InvalidTopicNameException,
    NotInitializedException,
    ParameterAlreadyDeclaredException,
    ParameterNotDeclaredException,
    ParameterUninitializedException,
    not_implemented,
)
from rclpy.logging import RcutilsLogger, _register
from rclpy.parameter import Parameter
from rclpy.parameter_service import ParameterService
from rclpy.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
    latched_depth,
    qos_profile_from_depth,
    qos_profile_services_default,
    queue_depth,
)

_NODE_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class _CoreNode(CoreNode):
    """The ``nodes.core`` node under an rclpy node: every callback waits for the thread that spins."""

    callbacks_on_spin_thread = True


def _rcl(type_name: str, /, **fields: Any) -> Any:
    """An rcl_interfaces message (``msg/SetParametersResult`` ...), or a plain stand-in when the package lacks
    it."""
    try:
        cls = msgs.get_type(f"rcl_interfaces/msg/{type_name}")
    except Exception:  # noqa: BLE001 - an older definitions set: a stand-in with the same fields
        return _Plain(**fields)
    return cls(**fields)


class _Plain:
    def __init__(self, **fields: Any) -> None:
        self.__dict__.update(fields)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in self.__dict__.items())})"


def ParameterDescriptor(**fields: Any) -> Any:  # noqa: N802 - the rcl_interfaces message's name
    defaults = dict(name="", type=0, description="", additional_constraints="", read_only=False,
                    dynamic_typing=False, floating_point_range=[], integer_range=[])
    defaults.update(fields)
    return _rcl("ParameterDescriptor", **defaults)


def SetParametersResult(successful: bool = True, reason: str = "") -> Any:  # noqa: N802
    return _rcl("SetParametersResult", successful=successful, reason=reason)


class Node:
    PARAM_REL_TOL = 1e-6
    _zr_core_class: type[CoreNode] = _CoreNode

    def __init__(self, node_name: str, *, context: Context | None = None, cli_args: list[str] | None = None,
                 namespace: str | None = None, use_global_arguments: bool = True, enable_rosout: bool = True,
                 rosout_qos_profile: Any = None, start_parameter_services: bool = True,
                 parameter_overrides: list[Parameter] | None = None, allow_undeclared_parameters: bool = False,
                 automatically_declare_parameters_from_overrides: bool = False,
                 enable_logger_service: bool = False) -> None:
        from rclpy.arguments import RosArguments, parse

        self._zr_context = context or get_default_context()
        if not self._zr_context.ok():
            raise NotInitializedException()
        args = self._zr_context.arguments if use_global_arguments else RosArguments()
        if cli_args:
            args = args.merged(parse(list(cli_args))[0])
        name = args.node_name or node_name
        if not _NODE_NAME.match(name or ""):
            raise InvalidNodeNameException(
                f"Invalid node name: node name must not contain characters other than alphanumerics or '_', and "
                f"must not start with a number: '{name}'")
        ns = args.namespace if args.namespace is not None else (namespace or "")
        overrides = args.node_params(name, ns)
        for parameter in parameter_overrides or []:
            overrides[parameter.name] = parameter.value
        level = args.log_levels.get(name) or args.log_levels.get("") or "info"
        self._zr = self._zr_core_class(name, namespace=ns, params=overrides, remap=args.node_remaps(name),
                             session=self._zr_context.session, log_level=level)
        self._zr.executor.propagate_errors = True
        self._zr_default_group: CallbackGroup = MutuallyExclusiveCallbackGroup()
        self._zr.executor.default_group = self._zr_default_group
        self._zr_groups: list[CallbackGroup] = [self._zr_default_group]
        self._zr_executor: Any = None
        self._zr_entities: dict[str, list[Any]] = {k: [] for k in (
            "publishers", "subscriptions", "clients", "services", "timers", "guards", "waitables")}
        self._zr_logger = RcutilsLogger(self._zr.logger.name, self._zr.logger)
        _register(self._zr.logger.name, self._zr_logger)
        self._zr_clock = ROSClock()
        self._zr_lock = threading.RLock()
        self._zr_overrides = dict(overrides)
        self._zr_allow_undeclared = allow_undeclared_parameters
        self._zr_parameters: dict[str, Parameter] = {}
        self._zr_descriptors: dict[str, Any] = {}
        self._zr_pre_set: list[Callable[[list[Parameter]], list[Parameter]]] = []
        self._zr_on_set: list[Callable[[list[Parameter]], Any]] = []
        self._zr_post_set: list[Callable[[list[Parameter]], None]] = []
        self._zr_applying = False
        self._zr_destroyed = False
        self._zr_parameters["use_sim_time"] = Parameter("use_sim_time", value=bool(self._zr.use_sim_time))
        self._zr_descriptors["use_sim_time"] = ParameterDescriptor(name="use_sim_time", type=1)
        if self._zr.use_sim_time:
            self._zr_clock._sim_source = self._zr_sim_now
        self._zr.parameters.add_on_set_callback(self._zr_on_core_set)
        # /parameter_events: this node's own, as rclpy publishes them (not the core node's for its stores)
        self._zr.parameters.listener = None
        self._zr_events = self._zr.parameter_events
        if start_parameter_services:   # the ROS 2 wire's six services answer from this node (rclpy's)
            self._zr.ros_parameters.backend = ParameterService(self)
        else:
            self._zr.ros_parameters.close()
        self._zr_context._add_node(self)
        if automatically_declare_parameters_from_overrides:
            for pname, value in overrides.items():
                if pname not in self._zr_parameters and not isinstance(value, dict):
                    self.declare_parameter(pname, value)

    # ------------------------------------------------------------------ identity
    def get_name(self) -> str:
        return self._zr.name

    def get_namespace(self) -> str:
        return "/" + self._zr.namespace

    def get_fully_qualified_name(self) -> str:
        return self._zr.fully_qualified_name

    @property
    def context(self) -> Context:
        return self._zr_context

    @property
    def default_callback_group(self) -> CallbackGroup:
        return self._zr_default_group

    @property
    def executor(self) -> Any:
        return self._zr_executor

    @executor.setter
    def executor(self, new_executor: Any) -> None:
        current = self._zr_executor
        if current is new_executor:
            return
        if current is not None and self in current.get_nodes():
            current.remove_node(self)
        self._zr_executor = new_executor
        if new_executor is not None and self not in new_executor.get_nodes():
            new_executor.add_node(self)

    @property
    def handle(self) -> Any:
        raise not_implemented("Node.handle")

    publishers = property(lambda self: iter(list(self._zr_entities["publishers"])))
    subscriptions = property(lambda self: iter(list(self._zr_entities["subscriptions"])))
    clients = property(lambda self: iter(list(self._zr_entities["clients"])))
    services = property(lambda self: iter(list(self._zr_entities["services"])))
    timers = property(lambda self: iter(list(self._zr_entities["timers"])))
    guards = property(lambda self: iter(list(self._zr_entities["guards"])))
    waitables = property(lambda self: iter(list(self._zr_entities["waitables"])))
    callback_groups = property(lambda self: list(self._zr_groups))

    def get_logger(self) -> RcutilsLogger:
        return self._zr_logger

    def get_clock(self) -> ROSClock:
        return self._zr_clock

    def _zr_sim_now(self) -> float:
        return self._zr.clock.sim_now

    def resolve_topic_name(self, topic: str, *, only_expand: bool = False) -> str:
        return ros_name(self._zr_resolve(topic, only_expand=only_expand))

    def resolve_service_name(self, service: str, *, only_expand: bool = False) -> str:
        return ros_name(self._zr_resolve(service, only_expand=only_expand))

    def _zr_resolve(self, name: str, *, only_expand: bool = False) -> str:
        from nodes.core import names

        try:
            if only_expand:
                return names.resolve(name, self._zr.namespace, self._zr.name)
            return self._zr.resolve(name)
        except NameError_ as exc:
            raise InvalidTopicNameException(str(exc)) from None

    def add_waitable(self, waitable: Any) -> None:
        raise not_implemented("Node.add_waitable")

    def remove_waitable(self, waitable: Any) -> None:
        raise not_implemented("Node.remove_waitable")

    def create_callback_group(self, *args: Any, **kwargs: Any) -> Any:
        raise not_implemented("Node.create_callback_group (create MutuallyExclusiveCallbackGroup() or "
                              "ReentrantCallbackGroup() directly)")

    def _zr_group(self, group: CallbackGroup | None) -> CallbackGroup:
        group = group or self._zr_default_group
        if group not in self._zr_groups:
            self._zr_groups.append(group)
        return group

    def _zr_check_type(self, kind: str, cls: Any) -> None:
        if not hasattr(cls, "_type"):
            raise TypeError(f"{kind} type must be a message class (e.g. std_msgs.msg.String), got {cls!r}")

    # ------------------------------------------------------------------ publishers, subscriptions
    def create_publisher(self, msg_type: Any, topic: str, qos_profile: QoSProfile | int, *,
                         callback_group: CallbackGroup | None = None, event_callbacks: Any = None,
                         qos_overriding_options: Any = None, publisher_class: Any = None) -> Publisher:
        self._zr_check_type("message", msg_type)
        qos = qos_profile_from_depth(qos_profile)
        key = self._zr_resolve(topic)
        core = self._zr.create_publisher(
            msg_type, "/" + key, reliable=qos.reliability != ReliabilityPolicy.BEST_EFFORT,
            latched=qos.durability == DurabilityPolicy.TRANSIENT_LOCAL, depth=latched_depth(qos),
            lifespan=seconds(qos.lifespan), ros2_qos=wire_qos(qos))
        cls = publisher_class or Publisher
        publisher = cls(self, core, msg_type, qos, self._zr_group(callback_group), event_callbacks)
        self._zr_entities["publishers"].append(publisher)
        return publisher

    def create_subscription(self, msg_type: Any, topic: str, callback: Callable[[Any], None],
                            qos_profile: QoSProfile | int, *, callback_group: CallbackGroup | None = None,
                            event_callbacks: Any = None, qos_overriding_options: Any = None,
                            raw: bool = False) -> Subscription:
        self._zr_check_type("message", msg_type)
        if not callable(callback):
            raise TypeError(f"create_subscription('{topic}'): callback must be callable, got {callback!r}")
        qos = qos_profile_from_depth(qos_profile)
        key = self._zr_resolve(topic)
        group = self._zr_group(callback_group)
        run = _call_maybe_async(self, callback)
        events = SubscriptionEvents(self, key, msg_type._type, qos, event_callbacks, group) \
            if SubscriptionEvents.needed(qos, event_callbacks) else None
        depth = queue_depth(qos)
        if events is not None:
            delivery: Executed = events.delivery(depth)
        else:   # KEEP_LAST waits in Zenoh's ring for the spinning thread; KEEP_ALL in an unbounded queue
            delivery = Executed() if depth is None else Spun(depth)
        core = self._zr.create_subscription(msg_type, "/" + key, run if events is None else events.callback(run),
                                            delivery=delivery, message=Raw() if raw else None,
                                            ros2_qos=wire_qos(qos))
        core.group = group
        subscription = Subscription(self, core, msg_type, callback, qos, group, event_callbacks, raw, events)
        self._zr_entities["subscriptions"].append(subscription)
        if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:
            threading.Thread(target=self._zr_fetch_latched, args=(core, msg_type, key, raw, latched_depth(qos)),
                             daemon=True, name=f"latched:{key}").start()
        return subscription

    def _zr_fetch_latched(self, core: Any, msg_type: Any, key: str, raw: bool, depth: int) -> None:
        """TRANSIENT_LOCAL: the last messages a latched publisher keeps (at most this subscription's depth),
        oldest first, delivered like any other."""
        try:
            history = fetch_latched_history(self._zr.session, msg_type, key, timeout=2.0)
        except Exception:  # noqa: BLE001 - nobody latched anything decodable: only live messages then
            return
        for msg in history[-depth:]:
            if core.closed:
                return
            core.delivery.run(msgs.encode(msg) if raw else msg)

    # ------------------------------------------------------------------ services
    def create_service(self, srv_type: Any, srv_name: str, callback: Callable[[Any, Any], Any], *,
                       qos_profile: QoSProfile = qos_profile_services_default,
                       callback_group: CallbackGroup | None = None) -> Service:
        self._zr_check_type("service", srv_type)
        key = self._zr_resolve(srv_name)
        executor = self._zr.executor

        def handler(request: Any) -> Any:
            try:
                response = callback(request, srv_type.Response())
            except Exception as exc:
                executor.put((_raise, (exc,), "service callback", None))   # ends spin, as rclpy does
                raise
            if response is None:
                raise TypeError(f"the callback of service '/{key}' returned None: return the response")
            return response

        core = self._zr.create_service(srv_type, "/" + key, handler)
        group = self._zr_group(callback_group)
        core.group = group
        service = Service(self, core, srv_type, callback, qos_profile, group)
        self._zr_entities["services"].append(service)
        return service

    def create_client(self, srv_type: Any, srv_name: str, *,
                      qos_profile: QoSProfile = qos_profile_services_default,
                      callback_group: CallbackGroup | None = None) -> Client:
        self._zr_check_type("service", srv_type)
        key = self._zr_resolve(srv_name)
        core = self._zr.create_client(srv_type, "/" + key)
        client = Client(self, core, srv_type, qos_profile, self._zr_group(callback_group))
        self._zr_entities["clients"].append(client)
        return client

    # ------------------------------------------------------------------ timers, rates, guard conditions
    def create_timer(self, timer_period_sec: float, callback: Callable[[], Any] | None,
                     callback_group: CallbackGroup | None = None, clock: Clock | None = None,
                     autostart: bool = True) -> Timer:
        clock = clock or self._zr_clock
        sim = isinstance(clock, ROSClock) and clock.ros_time_is_active
        group = self._zr_group(callback_group)
        run = _call_maybe_async(self, callback) if callback is not None else (lambda: None)
        core = self._zr.create_timer(float(timer_period_sec), run, sim_time=sim)
        core.group = group
        if not autostart:
            core.cancel()
        timer = Timer(self, core, callback, group, clock)
        self._zr_entities["timers"].append(timer)
        return timer

    def create_rate(self, frequency: float, clock: Clock | None = None) -> Rate:
        return Rate(self, frequency, clock or self._zr_clock)

    def create_guard_condition(self, callback: Callable[[], Any], callback_group: CallbackGroup | None = None
                               ) -> GuardCondition:
        guard = GuardCondition(self, callback, self._zr_group(callback_group))
        self._zr_entities["guards"].append(guard)
        return guard

    # ------------------------------------------------------------------ destroy
    def _zr_drop(self, kind: str, entity: Any) -> bool:
        items = self._zr_entities[kind]
        if entity not in items:
            return False
        items.remove(entity)
        return True

    def destroy_publisher(self, publisher: Publisher) -> bool:
        if self._zr_drop("publishers", publisher):
            publisher._close_events()
            self._zr.destroy_entity(publisher._core)
            return True
        return False

    def destroy_subscription(self, subscription: Subscription) -> bool:
        if self._zr_drop("subscriptions", subscription):
            subscription._close_events()
            self._zr.destroy_entity(subscription._core)
            return True
        return False

    def destroy_service(self, service: Service) -> bool:
        if self._zr_drop("services", service):
            self._zr.destroy_entity(service._core)
            return True
        return False

    def destroy_client(self, client: Client) -> bool:
        if self._zr_drop("clients", client):
            self._zr.destroy_entity(client._core)
            return True
        return False

    def destroy_timer(self, timer: Timer) -> bool:
        if self._zr_drop("timers", timer):
            timer._core.cancel()
            return True
        return False

    def destroy_rate(self, rate: Rate) -> bool:
        rate.destroy()
        return True

    def destroy_guard_condition(self, guard: GuardCondition) -> bool:
        return self._zr_drop("guards", guard)

    def destroy_node(self) -> None:
        """Undeclare every entity of this node (the context's session stays open for its other nodes)."""
        executor = self._zr_executor
        if executor is not None:
            executor.remove_node(self)
        self._close_core()

    def _close_core(self) -> None:
        if self._zr_destroyed:
            return
        self._zr_destroyed = True
        for timer in self._zr_entities["timers"]:
            timer._core.cancel()
        for entity in [*self._zr_entities["publishers"], *self._zr_entities["subscriptions"]]:
            entity._close_events()
        for items in self._zr_entities.values():
            items.clear()
        self._zr.destroy()

    # ------------------------------------------------------------------ graph
    def _zr_graph(self) -> list[Any]:
        return graph.snapshot(self._zr.session, 0.3)

    def _zr_names_and_types(self, kinds: tuple[str, ...], node: str | None = None) -> list[tuple[str, list[str]]]:
        found: dict[str, set[str]] = {}
        for entry in self._zr_graph():
            if entry.kind in kinds and entry.name and (node is None or entry.node == node):
                found.setdefault(ros_name(entry.name), set()).add(entry.type_name)
        return sorted((name, sorted(types)) for name, types in found.items())

    def get_topic_names_and_types(self, no_demangle: bool = False) -> list[tuple[str, list[str]]]:
        return self._zr_names_and_types(("pub", "sub"))

    def get_service_names_and_types(self) -> list[tuple[str, list[str]]]:
        return self._zr_names_and_types(("srv",))

    def _zr_fq(self, node_name: str, node_namespace: str) -> str:
        return "/" + "/".join(p for p in (node_namespace.strip("/"), node_name) if p)

    def get_publisher_names_and_types_by_node(self, node_name: str, node_namespace: str,
                                              no_demangle: bool = False) -> list[tuple[str, list[str]]]:
        return self._zr_names_and_types(("pub",), self._zr_fq(node_name, node_namespace))

    def get_subscriber_names_and_types_by_node(self, node_name: str, node_namespace: str,
                                               no_demangle: bool = False) -> list[tuple[str, list[str]]]:
        return self._zr_names_and_types(("sub",), self._zr_fq(node_name, node_namespace))

    def get_service_names_and_types_by_node(self, node_name: str, node_namespace: str
                                            ) -> list[tuple[str, list[str]]]:
        return self._zr_names_and_types(("srv",), self._zr_fq(node_name, node_namespace))

    def get_client_names_and_types_by_node(self, node_name: str, node_namespace: str
                                           ) -> list[tuple[str, list[str]]]:
        return self._zr_names_and_types(("cli",), self._zr_fq(node_name, node_namespace))

    def get_node_names_and_namespaces(self) -> list[tuple[str, str]]:
        out = set()
        for entry in self._zr_graph():
            if entry.kind == "node":
                ns, _, name = entry.node.rpartition("/")
                out.add((name, ns or "/"))
        return sorted(out)

    def get_node_names(self) -> list[str]:
        return [name for name, _ in self.get_node_names_and_namespaces()]

    def get_fully_qualified_node_names(self) -> list[str]:
        return sorted({e.node for e in self._zr_graph() if e.kind == "node"})

    def _zr_count(self, kind: str, topic: str) -> int:
        key = self._zr_resolve(topic)
        return sum(1 for e in self._zr_graph() if e.kind == kind and e.name == key)

    def count_publishers(self, topic_name: str) -> int:
        return self._zr_count("pub", topic_name)

    def count_subscribers(self, topic_name: str) -> int:
        return self._zr_count("sub", topic_name)

    def count_clients(self, service_name: str) -> int:
        return self._zr_count("cli", service_name)

    def count_services(self, service_name: str) -> int:
        return self._zr_count("srv", service_name)

    def get_publishers_info_by_topic(self, topic_name: str, no_mangle: bool = False) -> list[Any]:
        from rclpy._graph_info import topic_info

        return topic_info(self._zr.session, self._zr_resolve(topic_name), publishers=True)

    def get_subscriptions_info_by_topic(self, topic_name: str, no_mangle: bool = False) -> list[Any]:
        from rclpy._graph_info import topic_info

        return topic_info(self._zr.session, self._zr_resolve(topic_name), publishers=False)

    def wait_for_node(self, fully_qualified_node_name: str, timeout: float) -> bool:
        import time

        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if fully_qualified_node_name in self.get_fully_qualified_node_names():
                return True
            time.sleep(0.1)
        return False

    # ------------------------------------------------------------------ parameters
    def _zr_descriptor_for(self, name: str, value: Any, descriptor: Any) -> Any:
        if descriptor is None:
            descriptor = ParameterDescriptor()
        try:
            descriptor.name = name
        except Exception:  # noqa: BLE001 - a frozen stand-in keeps its own
            pass
        return descriptor

    def declare_parameter(self, name: str, value: Any = None, descriptor: Any = None,
                          ignore_override: bool = False) -> Parameter:
        return self.declare_parameters("", [(name, value, descriptor)], ignore_override)[0]

    def declare_parameters(self, namespace: str, parameters: Iterable[tuple[Any, ...]],
                           ignore_override: bool = False) -> list[Parameter]:
        declared = []
        for entry in parameters:
            if not isinstance(entry, tuple) or not 1 <= len(entry) <= 3:
                raise TypeError("declare_parameters takes tuples (name,), (name, value) or (name, value, "
                                "descriptor)")
            name = f"{namespace}.{entry[0]}" if namespace else entry[0]
            value = entry[1] if len(entry) > 1 else None
            descriptor = entry[2] if len(entry) > 2 else None
            declared.append(self._zr_declare(name, value, descriptor, ignore_override))
        return declared

    def _zr_declare(self, name: str, value: Any, descriptor: Any, ignore_override: bool) -> Parameter:
        if not isinstance(name, str) or not name:
            raise TypeError("parameter name must be a non-empty string")
        with self._zr_lock:
            if name in self._zr_parameters:
                raise ParameterAlreadyDeclaredException(name)
            descriptor = self._zr_descriptor_for(name, value, descriptor)
            ptype: Parameter.Type | None = None
            if isinstance(value, Parameter.Type):   # statically typed, no default
                ptype, value = value, None
            if value is not None or ptype is None:
                ptype = Parameter.Type.from_parameter_value(value)
            if not getattr(descriptor, "dynamic_typing", False) and ptype != Parameter.Type.NOT_SET:
                try:
                    descriptor.type = ptype.value
                except Exception:  # noqa: BLE001
                    pass
            if not ignore_override and name in self._zr_overrides:
                value = self._zr_overrides[name]
                if ptype == Parameter.Type.DOUBLE and isinstance(value, int) and not isinstance(value, bool):
                    value = float(value)
                if ptype != Parameter.Type.NOT_SET and not getattr(descriptor, "dynamic_typing", False) \
                        and not ptype.check(value):
                    raise InvalidParameterTypeException(Parameter(name, ptype, None) if value is None else
                                                        _Plain(name=name), type(value).__name__)
            parameter = Parameter(name, value=value) if value is not None or ptype == Parameter.Type.NOT_SET \
                else _Uninitialized(name, ptype)
            if value is not None:
                result = self._zr_run_on_set([parameter])
                if not result.successful:
                    raise InvalidParameterValueException(name, value, result.reason)
                problem = _range_problem(descriptor, value)
                if problem:
                    raise InvalidParameterValueException(name, value, problem)
            self._zr_parameters[name] = parameter
            self._zr_descriptors[name] = descriptor
            self._zr_store(name, value)
            self._zr_events.publish(new=[_parameter_msg(parameter)])
        return parameter

    def _zr_store(self, name: str, value: Any) -> None:
        self._zr_applying = True
        try:
            self._zr.parameters.store(name, value)
        finally:
            self._zr_applying = False

    def undeclare_parameter(self, name: str) -> None:
        with self._zr_lock:
            if name not in self._zr_parameters:
                raise ParameterNotDeclaredException(name)
            if getattr(self._zr_descriptors[name], "read_only", False):
                from rclpy.exceptions import ParameterImmutableException

                raise ParameterImmutableException(name)
            del self._zr_parameters[name]
            del self._zr_descriptors[name]
            self._zr.parameters.undeclare(name)

    def has_parameter(self, name: str) -> bool:
        return name in self._zr_parameters

    def get_parameter(self, name: str) -> Parameter:
        parameter = self._zr_parameters.get(name)
        if parameter is None:
            if self._zr_allow_undeclared:
                return Parameter(name, Parameter.Type.NOT_SET, None)
            raise ParameterNotDeclaredException(name)
        if isinstance(parameter, _Uninitialized):
            raise ParameterUninitializedException(name)
        return parameter

    def get_parameter_or(self, name: str, alternative_value: Parameter | None = None) -> Parameter:
        if alternative_value is None:
            alternative_value = Parameter(name, Parameter.Type.NOT_SET)
        parameter = self._zr_parameters.get(name)
        return parameter if parameter is not None and not isinstance(parameter, _Uninitialized) \
            else alternative_value

    def get_parameters(self, names: list[str]) -> list[Parameter]:
        return [self.get_parameter(n) for n in names]

    def get_parameters_by_prefix(self, prefix: str) -> dict[str, Parameter]:
        prefix = f"{prefix}." if prefix else ""
        return {name[len(prefix):]: p for name, p in self._zr_parameters.items()
                if name.startswith(prefix) and not isinstance(p, _Uninitialized)}

    def get_parameter_types(self, names: list[str]) -> list[Parameter.Type]:
        return [self._zr_parameters[n].type_ if n in self._zr_parameters else Parameter.Type.NOT_SET
                for n in names]

    def describe_parameter(self, name: str) -> Any:
        if name not in self._zr_descriptors:
            if self._zr_allow_undeclared:
                return ParameterDescriptor(name=name)
            raise ParameterNotDeclaredException(name)
        return self._zr_descriptors[name]

    def describe_parameters(self, names: list[str]) -> list[Any]:
        return [self.describe_parameter(n) for n in names]

    def set_descriptor(self, name: str, descriptor: Any, alternative_value: Any = None) -> Any:
        if name not in self._zr_descriptors:
            raise ParameterNotDeclaredException(name)
        self._zr_descriptors[name] = self._zr_descriptor_for(name, None, descriptor)
        return self.get_parameter(name).get_parameter_value()

    def list_parameters(self, prefixes: list[str], depth: int) -> Any:
        if not isinstance(prefixes, list) or not all(isinstance(p, str) for p in prefixes):
            raise TypeError("The prefixes argument must be a list of str")
        if not isinstance(depth, int):
            raise TypeError("The depth must be instance of type int")
        if depth < 0:
            raise ValueError("The depth must be greater than or equal to zero")
        return list_parameter_names(list(self._zr_parameters), prefixes, depth)

    def add_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], Any]) -> Any:
        self._zr_on_set.insert(0, callback)
        return callback

    def remove_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], Any]) -> None:
        self._zr_on_set.remove(callback)

    def add_pre_set_parameters_callback(self, callback: Callable[[list[Parameter]], list[Parameter]]) -> Any:
        self._zr_pre_set.insert(0, callback)
        return callback

    def remove_pre_set_parameters_callback(self, callback: Any) -> None:
        self._zr_pre_set.remove(callback)

    def add_post_set_parameters_callback(self, callback: Callable[[list[Parameter]], None]) -> Any:
        self._zr_post_set.insert(0, callback)
        return callback

    def remove_post_set_parameters_callback(self, callback: Any) -> None:
        self._zr_post_set.remove(callback)

    def _zr_run_on_set(self, parameters: list[Parameter]) -> Any:
        for callback in list(self._zr_on_set):
            result = callback(parameters)
            if not getattr(result, "successful", False):
                return result
        return SetParametersResult(True, "")

    def set_parameters(self, parameter_list: list[Parameter]) -> list[Any]:
        parameter_list = self._zr_pre(parameter_list)
        if not parameter_list:
            return [SetParametersResult(False, "parameter list cannot be empty, this might be due to "
                                        "pre_set_parameters_callback modifying the original parameters list.")]
        return [self._zr_set_atomically([p]) for p in parameter_list]

    def set_parameters_atomically(self, parameter_list: list[Parameter]) -> Any:
        parameter_list = self._zr_pre(parameter_list)
        if not parameter_list:
            return SetParametersResult(False, "parameter list cannot be empty, this might be due to "
                                       "pre_set_parameters_callback modifying the original parameters list.")
        return self._zr_set_atomically(parameter_list)

    def _zr_pre(self, parameter_list: list[Parameter]) -> list[Parameter]:
        for callback in list(self._zr_pre_set):
            parameter_list = callback(parameter_list)
        return list(parameter_list)

    def _zr_set_atomically(self, parameters: list[Parameter]) -> Any:
        with self._zr_lock:
            for p in parameters:
                if p.name not in self._zr_parameters:
                    if not self._zr_allow_undeclared:
                        raise ParameterNotDeclaredException(p.name)
                    continue
                descriptor = self._zr_descriptors[p.name]
                if getattr(descriptor, "read_only", False):
                    return SetParametersResult(False, f"Trying to set a read-only parameter: {p.name}.")
                if p.name == "use_sim_time" and p.value != self._zr_parameters["use_sim_time"].value:
                    problem = self._zr_switch_sim_time(p.value)
                    if problem:
                        return SetParametersResult(False, problem)
                old = self._zr_parameters[p.name]
                if p.type_ == Parameter.Type.NOT_SET and not getattr(descriptor, "dynamic_typing", False):
                    return SetParametersResult(False, "Static parameter cannot be undeclared")
                if not getattr(descriptor, "dynamic_typing", False) and old.type_ != Parameter.Type.NOT_SET \
                        and p.type_ != old.type_ and p.type_ != Parameter.Type.NOT_SET:
                    return SetParametersResult(
                        False, f"Wrong parameter type, parameter {{{p.name}}} is of type {{{_type_name(old)}}}, "
                        f"setting it to {{{_type_name(p)}}} is not allowed.")
                problem = _range_problem(descriptor, p.value)
                if problem:
                    return SetParametersResult(False, problem)
            result = self._zr_run_on_set(parameters)
            if not result.successful:
                return result
            event: dict[str, list[Any]] = {"new": [], "changed": [], "deleted": []}
            for p in parameters:
                if p.type_ == Parameter.Type.NOT_SET:   # deleted, whatever it was (rclpy's)
                    event["deleted"].append(p.to_parameter_msg())
                    if p.name in self._zr_parameters:
                        del self._zr_parameters[p.name]
                        self._zr_descriptors.pop(p.name, None)
                        self._zr.parameters.undeclare(p.name)
                    continue
                if p.name not in self._zr_descriptors:
                    self._zr_descriptors[p.name] = ParameterDescriptor(name=p.name)
                old = self._zr_parameters.get(p.name)
                kind = "new" if old is None or old.value is None else "changed"   # had no value: new
                event[kind].append(p.to_parameter_msg())
                self._zr_parameters[p.name] = p
                self._zr_store(p.name, p.value)
            self._zr_events.publish(**event)
        for callback in list(self._zr_post_set):
            callback(parameters)
        return result

    def _zr_switch_sim_time(self, enabled: Any) -> str | None:
        """``use_sim_time`` at run time: the node clock follows ``sim/clock`` from now on (timers made before
        keep the clock they were made with)."""
        if not isinstance(enabled, bool):
            return "use_sim_time must be a bool"
        core = self._zr
        if enabled and not getattr(self, "_zr_clock_sub", None):
            from msgs.rosgraph_msgs import Clock as ClockMsg

            self._zr_clock_sub = core.create_subscription(ClockMsg, "/sim/clock", core.clock.on_clock,
                                                          delivery=Inline())
        core.clock.use_sim_time = enabled
        core.use_sim_time = enabled
        self._zr_clock._sim_source = self._zr_sim_now if enabled else None
        return None

    def _zr_on_core_set(self, name: str, value: Any) -> str | None:
        """A change from outside (``zenroid param set``, the parameter services): rclpy's callbacks decide."""
        if self._zr_applying:
            return None
        current = self._zr_parameters.get(name)
        if current is not None and current.type_ == Parameter.Type.DOUBLE and isinstance(value, int) \
                and not isinstance(value, bool):
            value = float(value)
        try:
            parameter = Parameter(name, value=value)
            result = self.set_parameters_atomically([parameter])
        except Exception as exc:  # noqa: BLE001 - the reason goes back to the caller
            return f"{type(exc).__name__}: {exc}"
        return None if result.successful else (result.reason or "rejected by the node")

    # ------------------------------------------------------------------ misc
    def get_namespace_and_name(self) -> tuple[str, str]:
        return self.get_namespace(), self.get_name()

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy_node()

    def __repr__(self) -> str:
        return f"<rclpy (zenroid) node {self.get_fully_qualified_name()}>"


class _Uninitialized:
    """A statically typed parameter declared without a value (``declare_parameter('x', Parameter.Type.DOUBLE)``)."""

    def __init__(self, name: str, type_: Parameter.Type) -> None:
        self.name, self.type_, self.value = name, type_, None


def _parameter_msg(parameter: Any) -> Any:
    """rcl_interfaces/msg/Parameter of a declared parameter (NOT_SET while statically typed and unset)."""
    return Parameter(parameter.name).to_parameter_msg() if isinstance(parameter, _Uninitialized) \
        else parameter.to_parameter_msg()


def _type_name(parameter: Any) -> str:
    return {Parameter.Type.BOOL: "bool", Parameter.Type.INTEGER: "integer", Parameter.Type.DOUBLE: "double",
            Parameter.Type.STRING: "string", Parameter.Type.BYTE_ARRAY: "byte_array",
            Parameter.Type.BOOL_ARRAY: "bool_array", Parameter.Type.INTEGER_ARRAY: "integer_array",
            Parameter.Type.DOUBLE_ARRAY: "double_array", Parameter.Type.STRING_ARRAY: "string_array"}.get(
        parameter.type_, "not set")


def _range_problem(descriptor: Any, value: Any) -> str | None:
    for attr in ("floating_point_range", "integer_range"):
        ranges = getattr(descriptor, attr, None) or []
        if not ranges or isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        r = ranges[0]
        if value < r.from_value or value > r.to_value:
            return f"Parameter {{{descriptor.name}}} doesn't comply with {attr}: {value} not in " \
                   f"[{r.from_value}, {r.to_value}]"
        step = getattr(r, "step", 0)
        if step and not math.isclose((value - r.from_value) / step, round((value - r.from_value) / step),
                                     abs_tol=Node.PARAM_REL_TOL) and value != r.to_value:
            return f"Parameter {{{descriptor.name}}} doesn't comply with {attr} step {step}: {value}"
    return None


def _raise(exc: BaseException) -> None:
    raise exc
