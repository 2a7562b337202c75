"""``launch_ros.actions``: ROS nodes as processes of the launch, containers, and the scope actions
(namespace, global parameters and remappings). Each owns its Python constructor, its ROS XML / YAML
spelling (``parse``) and what it resolves to (``resolve``), as ``launch.actions`` do."""

from __future__ import annotations

import sys
from typing import Any

from launch.actions import ExecuteProcess, LocatedAction
from launch.context import normalize
from launch.yaml_source import LaunchError

__all__ = ["ComposableNodeContainer", "LifecycleNode", "LoadComposableNodes", "Node", "PushROSNamespace",
           "PushRosNamespace", "SetParameter", "SetParametersFromFile", "SetRemap"]


class Node(LocatedAction):
    def __init__(self, *, executable: Any, package: Any = None, name: Any = None, namespace: Any = None,
                 exec_name: Any = None, parameters: list[Any] | None = None, remappings: list[Any] | None = None,
                 ros_arguments: list[Any] | None = None, arguments: list[Any] | None = None,
                 output: Any = "screen", respawn: Any = False, respawn_delay: float | None = None,
                 additional_env: dict[Any, Any] | None = None, env: dict[Any, Any] | None = None,
                 emulate_tty: bool = False, sigterm_timeout: Any = None, sigkill_timeout: Any = None,
                 prefix: Any = None, cwd: Any = None, on_exit: Any = None, log_cmd: bool = False,
                 node_name: Any = None, node_namespace: Any = None, node_executable: Any = None,
                 split_arguments: bool = False, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.package = None if package is None else normalize(package)
        self.executable = normalize(executable or node_executable)
        name = name if name is not None else node_name
        namespace = namespace if namespace is not None else node_namespace
        self.node_name = None if name is None else normalize(name)
        self.node_namespace = None if namespace is None else normalize(namespace)
        self.parameters = list(parameters or [])
        self.remappings = [(normalize(a), normalize(b)) for a, b in (remappings or [])]
        self.ros_arguments = [normalize(a) for a in (ros_arguments or [])]
        self.arguments = [normalize(a) for a in (arguments or [])]
        self.output = normalize(output)
        self.respawn = normalize(respawn)
        self.respawn_delay = respawn_delay
        self.additional_env = [(normalize(k), normalize(v)) for k, v in (additional_env or {}).items()]
        self.env = None if env is None else [(normalize(k), normalize(v)) for k, v in env.items()]
        self.on_exit = on_exit
        self.prefix = None if prefix is None else normalize(prefix)
        self.cwd = None if cwd is None else normalize(cwd)
        self.split_arguments = split_arguments   # the front ends' `args` text, split as a shell would
        self.labels: list[str] = []

    @classmethod
    def parse(cls, entity: Any) -> Node:
        params: list[Any] = []
        for param in entity.children_of("param"):
            if param.has("from"):
                params.append(param.sub("from"))
            else:
                params.append({param.sub("name"): param.value("value")})
        remaps = [(r.sub("from"), r.sub("to")) for r in entity.children_of("remap")]
        args = entity.sub("args", optional=True)
        ros_args = entity.sub("ros_args", optional=True)
        return cls(package=entity.sub("pkg"), executable=entity.sub("exec"), name=entity.sub("name", optional=True),
                   namespace=entity.sub("namespace", optional=True), parameters=params, remappings=remaps,
                   arguments=[args] if args is not None else None, ros_arguments=[ros_args] if ros_args else None,
                   output=entity.sub("output", optional=True) or "screen",
                   respawn=entity.sub("respawn", optional=True) or "false",
                   respawn_delay=_seconds(entity.get("respawn_delay", optional=True, text=True), entity),
                   prefix=entity.sub("launch-prefix", optional=True),
                   additional_env={e.sub("name"): e.sub("value") for e in entity.children_of("env")},
                   split_arguments=args is not None, **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.add_ros_node(self, scope)


def _seconds(text: str | None, entity: Any) -> float | None:
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        raise LaunchError(f"respawn_delay must be a number of seconds, got '{text}'", entity.source) from None


class LifecycleNode(Node):
    """A managed node: started as any node; ``EmitEvent(ChangeState(...))`` in the launch file or
    ``ros2 lifecycle set`` drive its transitions (launch_ros.events.lifecycle)."""

    def __init__(self, *, name: Any, namespace: Any, autostart: Any = False, **kwargs: Any) -> None:
        super().__init__(name=name, namespace=namespace, **kwargs)
        self.autostart = normalize(autostart) if not isinstance(autostart, bool) else autostart
        self.fully_qualified_names: list[str] = []

    def resolve(self, resolver: Any, scope: Any) -> None:
        from launch.plan import parse_bool

        super().resolve(resolver, scope)
        spec = resolver.plan.nodes[-1]
        fqn = "/" + "/".join(p for p in (spec.namespace.strip("/"), spec.node_name) if p)
        self.fully_qualified_names.append(fqn)
        resolver.lifecycle_nodes.append(self)
        autostart = self.autostart if isinstance(self.autostart, bool) else parse_bool(
            resolver.perform(self.autostart, scope, self.source, "autostart"), "autostart", self.source)
        if autostart:   # launch_ros' autostart: configured, then activated, once it is up
            helper = LifecycleChangeProcess(self, fqn, "configure", "activate")
            helper.source = self.source
            resolver.walk([helper], scope)


class LifecycleChangeProcess(ExecuteProcess):
    """The helper process of a ChangeState event for one lifecycle node (launch_ros.lifecycle_change)."""

    def __init__(self, node: LifecycleNode, fqn: str, *transitions: str) -> None:
        super().__init__(cmd=[sys.executable, "-m", "launch_ros.lifecycle_change", fqn, *transitions],
                         name=f"change_state_{'_'.join(transitions)}", output="log")
        self.node = node


class PushRosNamespace(LocatedAction):
    def __init__(self, namespace: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.namespace = normalize(namespace)

    @classmethod
    def parse(cls, entity: Any) -> PushRosNamespace:
        return cls(entity.sub("namespace"), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.push_namespace(scope, resolver.perform(self.namespace, scope, self.source, "PushRosNamespace"),
                                self.source)


PushROSNamespace = PushRosNamespace


class SetParameter(LocatedAction):
    """A parameter every node resolved after it in this scope gets."""

    def __init__(self, name: Any, value: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name, self.value = normalize(name), value

    @classmethod
    def parse(cls, entity: Any) -> SetParameter:
        return cls(entity.sub("name"), entity.value("value"), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        name = resolver.perform(self.name, scope, self.source, "SetParameter name")
        scope.params[name] = resolver.parameter_value(self.value, scope, self.source)


class SetParametersFromFile(LocatedAction):
    def __init__(self, filename: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.filename = normalize(filename)

    def resolve(self, resolver: Any, scope: Any) -> None:
        scope.param_files.append(resolver.perform(self.filename, scope, self.source, "SetParametersFromFile"))


class SetRemap(LocatedAction):
    def __init__(self, src: Any, dst: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.src, self.dst = normalize(src), normalize(dst)

    @classmethod
    def parse(cls, entity: Any) -> SetRemap:
        return cls(entity.sub("from"), entity.sub("to"), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        scope.remaps.append((resolver.perform(self.src, scope, self.source, "SetRemap src"),
                             resolver.perform(self.dst, scope, self.source, "SetRemap dst")))


class ComposableNodeContainer(Node):
    """One process (our component container) running Python nodes given as ``python.module::NodeClass``."""

    def __init__(self, *, name: Any, namespace: Any, package: Any = "rclcpp_components",
                 executable: Any = "component_container", composable_node_descriptions: list[Any] | None = None,
                 **kwargs: Any) -> None:
        super().__init__(name=name, namespace=namespace, package=package, executable=executable, **kwargs)
        self.composable_node_descriptions = list(composable_node_descriptions or [])

    @classmethod
    def parse(cls, entity: Any) -> ComposableNodeContainer:
        from launch_ros.descriptions import ComposableNode

        return cls(name=entity.sub("name"), namespace=entity.sub("namespace", optional=True) or "",
                   package=entity.sub("pkg", optional=True) or "rclcpp_components",
                   executable=entity.sub("exec", optional=True) or "component_container",
                   composable_node_descriptions=[ComposableNode.parse(c) for c in entity.children_of("composable_node")],
                   output=entity.sub("output", optional=True) or "screen", **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.add_ros_container(self, scope)


class LoadComposableNodes(LocatedAction):
    """Nodes added to a container this launch starts (``target_container``: the container or its name)."""

    def __init__(self, *, composable_node_descriptions: list[Any], target_container: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.composable_node_descriptions = list(composable_node_descriptions)
        self.target_container = target_container

    @classmethod
    def parse(cls, entity: Any) -> LoadComposableNodes:
        from launch_ros.descriptions import ComposableNode

        return cls(target_container=entity.sub("target"),
                   composable_node_descriptions=[ComposableNode.parse(c) for c in entity.children_of("composable_node")],
                   **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        target = self.target_container
        if isinstance(target, ComposableNodeContainer):
            labels = target.labels
        else:
            name = resolver.perform(normalize(target), scope, self.source, "target_container").strip("/")
            labels = [name.rpartition("/")[2]]
        resolver.load_composables(labels, self.composable_node_descriptions, scope, self.source)

