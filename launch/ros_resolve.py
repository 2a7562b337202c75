"""What the resolver (``launch.resolve``) offers the ROS launch actions when they resolve themselves: values
performed, arguments declared, files included, processes, containers, timers and event handlers added to the
plan. The actions (``launch.actions``, ``launch_ros.actions``) decide what they become; this is the plumbing."""

from __future__ import annotations

import shlex
from collections.abc import Callable
from pathlib import Path
from typing import Any

from launch.actions import find_program, register_on_exit
from launch.code_errors import launch_code_error
from launch.context import LaunchDescription as RosLaunchDescription
from launch.context import Substitution, normalize, perform_substitutions
from launch.plan import (
    CONTAINER_MODULE,
    ComposedNodeSpec,
    Expansion,
    LaunchPlan,
    NodeSpec,
    Trigger,
    check_module,
    check_namespace,
    join_namespace,
    parse_bool,
    typed_value,
)
from launch.substitutions import SubstitutionFailure
from launch.yaml_source import LaunchError, Source


def _label(text: str) -> str:
    stem = Path(text).name
    for suffix in (".py", ".sh"):
        stem = stem.removesuffix(suffix)
    cleaned = "".join(c if c.isalnum() or c == "_" else "_" for c in stem).strip("_") or "process"
    return cleaned if not cleaned[0].isdigit() else f"p_{cleaned}"


class RosResolution:
    """Mixed into ``launch.resolve._Resolver``."""

    plan: Any
    include_stack: list[Path]
    declared: set[str]
    cli_args: dict[str, str]

    # -- values ---------------------------------------------------------------------------------
    def call_launch_code(self, function: Callable[[], Any], source: Source | None, what: str = "") -> Any:
        try:
            return function()
        except LaunchError:
            raise
        except SubstitutionFailure as exc:
            raise LaunchError(f"{what + ': ' if what else ''}{exc}", source) from None
        except Exception as exc:   # the launch file's code raised: name its line
            raise launch_code_error(exc, source, what) from None

    def perform(self, value: Any, scope: Any, source: Source | None, what: str) -> str:
        items = normalize(value)
        if all(isinstance(item, str) for item in items):
            return "".join(items)
        context = scope.context()
        return self.call_launch_code(lambda: perform_substitutions(context, items), source, what)

    def ros_condition(self, action: Any, scope: Any) -> bool:
        condition = getattr(action, "condition", None)
        if condition is None:
            return True
        context = scope.context()
        return bool(self.call_launch_code(lambda: condition.evaluate(context), getattr(action, "source", None),
                                          "condition"))

    def resolve_ros_action(self, action: Any, scope: Any) -> None:
        if isinstance(action, RosLaunchDescription):
            self.walk(action.entities, scope)
        elif not hasattr(action, "resolve"):
            raise LaunchError(f"not a launch action: {action!r} ({type(action).__name__})",
                              getattr(action, "source", None) or Source(scope.file, 0))
        elif self.ros_condition(action, scope):
            action.resolve(self, scope)

    # -- arguments and includes -----------------------------------------------------------------
    def declare_value(self, name: str, default: Any, choices: list[str] | None, scope: Any, source: Source) -> None:
        self.declared.add(name)
        if name in scope.variables:
            value = scope.variables[name]
        elif default is not None:
            value = self.perform(default, scope, source, f"default of argument '{name}'")
        else:
            raise LaunchError(f"missing required argument '{name}' (give it as {name}:=VALUE)", source)
        if choices is not None and value not in choices:
            raise LaunchError(f"argument '{name}' is '{value}', must be one of: {', '.join(choices)}", source)
        scope.variables[name] = value

    def include_path(self, location: str, given: dict[str, str], scope: Any, source: Source) -> None:
        from launch.formats import load_description

        path = Path(location).expanduser()
        if not path.is_absolute():
            path = scope.file.resolve().parent / path
        if not path.is_file():
            raise LaunchError(f"included launch file not found: {location}", source)
        if path.resolve() in self.include_stack:
            chain = " -> ".join(p.name for p in [*self.include_stack, path.resolve()])
            raise LaunchError(f"include cycle refused: {chain}", source)
        description = load_description(path)
        if description.format == "zenroid":
            self.include_ours(description, path, given, scope, source)
            return
        child = scope.child(file=path)
        child.variables.update(given)   # the includer's launch configurations, then the include's arguments
        self.include_stack.append(path.resolve())
        try:
            self.walk(description.actions, child)
        finally:
            self.include_stack.pop()

    def include_description(self, description: RosLaunchDescription, given: dict[str, str], scope: Any,
                            source: Source) -> None:
        child = scope.child()
        child.variables.update(given)
        self.walk(description.entities, child)

    def push_namespace(self, scope: Any, namespace: str, source: Source) -> None:
        scope.namespace = join_namespace(scope.namespace, namespace)
        check_namespace(scope.namespace, source)

    # -- processes ------------------------------------------------------------------------------
    def unique_label(self, wanted: str) -> str:
        label, n = wanted, 2
        while label in self.process_names:
            label, n = f"{wanted}_{n}", n + 1
        return label

    def process_options_ros(self, action: Any, scope: Any) -> dict[str, Any]:

        source = action.source
        env = {k: v for k, v in scope.env.items() if v is not None}
        for key, value in [*(action.env or []), *action.additional_env]:
            env[self.perform(key, scope, source, "env name")] = self.perform(value, scope, source, "env value")
        output = self.perform(action.output, scope, source, "output")
        respawn = parse_bool(self.perform(action.respawn, scope, source, "respawn"), "respawn", source)
        delay = float(action.respawn_delay) if action.respawn_delay is not None else 0.0
        return dict(env=env, respawn=respawn, respawn_delay=delay, respawn_max=1_000_000 if respawn else 0,
                    required=False, output="log" if output == "log" else "screen", wait_for=[], wait_timeout=60.0)

    def add_ros_process(self, action: Any, scope: Any, *, argv: list[str], label: str, node_name: str | None,
                        style: str, namespace: str = "", params: dict[str, Any] | None = None,
                        param_files: list[str] | None = None, remaps: list[tuple[str, str]] | None = None,
                        ros_args: list[str] | None = None) -> Any:

        label = self.unique_label(_label(label))
        cwd = None
        if getattr(action, "cwd", None) is not None:
            cwd = self.perform(action.cwd, scope, action.source, "cwd")
        spec = NodeSpec(name=label, namespace=namespace, module=None, executable=argv[0], args=argv[1:],
                        params=dict(params or {}), param_files=list(param_files or []), remaps=list(remaps or []),
                        source=str(action.source), style=style, node_name=node_name, ros_args=list(ros_args or []),
                        cwd=cwd, action=action, **self.process_options_ros(action, scope))
        self.process_names.add(label)
        action.labels.append(label)
        self.plan.nodes.append(spec)
        return spec

    def package_executable(self, package: str, executable: str, source: Source) -> Any:
        from nodes.packages import find_executable

        try:
            return find_executable(package, executable)
        except LookupError as exc:
            raise LaunchError(str(exc).strip('"'), source) from None

    def add_ros_node(self, node: Any, scope: Any) -> None:

        source = node.source
        executable = self.perform(node.executable, scope, source, "Node executable")
        name = self.perform(node.node_name, scope, source, "Node name") if node.node_name is not None else None
        given_ns = self.perform(node.node_namespace, scope, source, "Node namespace") \
            if node.node_namespace is not None else None
        namespace = join_namespace(scope.namespace, given_ns)
        check_namespace(namespace, source)
        if node.package is None:
            argv, style = [find_program(executable, source)], "ros"
        else:
            found = self.package_executable(self.perform(node.package, scope, source, "Node package"), executable,
                                            source)
            argv, style = list(found.argv), "node" if found.ros_node else "ros"
        if node.prefix is not None:   # launch-prefix: a wrapper program (gdb -ex run --args, nice, ...)
            argv = shlex.split(self.perform(node.prefix, scope, source, "prefix")) + argv
            argv[0] = find_program(argv[0], source)
        for item in node.arguments:
            text = self.perform(item, scope, source, "Node arguments")
            argv += shlex.split(text) if node.split_arguments else [text]
        params, files = self.ros_parameters(node.parameters, scope, source)
        remaps = [*scope.remaps, *((self.perform(a, scope, source, "remapping"), self.perform(b, scope, source,
                                                                                            "remapping"))
                                   for a, b in node.remappings)]
        ros_args = [word for item in node.ros_arguments
                    for word in shlex.split(self.perform(item, scope, source, "ros_arguments"))]
        self.add_ros_process(node, scope, argv=argv, label=name or executable, node_name=name, style=style,
                             namespace=namespace, params=params, param_files=files, remaps=remaps, ros_args=ros_args)
        register_on_exit(node, self, scope)

    # -- parameters -----------------------------------------------------------------------------
    def parameter_value(self, value: Any, scope: Any, source: Source) -> Any:
        from launch_ros.parameter_descriptions import ParameterValue

        if isinstance(value, ParameterValue):
            if value.value_type is str:
                return self.perform(value.value, scope, source, "ParameterValue")
            inner = self.parameter_value(value.value, scope, source)
            if value.value_type in (int, float, bool) and isinstance(inner, str):
                return typed_value(inner)
            return inner
        if isinstance(value, Substitution) or (isinstance(value, (list, tuple)) and value
                                               and any(isinstance(v, Substitution) for v in value)
                                               and all(isinstance(v, (str, Substitution)) for v in value)):
            return typed_value(self.perform(value, scope, source, "parameter"))
        if isinstance(value, (list, tuple)):
            return [self.parameter_value(v, scope, source) for v in value]
        if isinstance(value, Path):
            return str(value)
        return value

    def ros_parameters(self, items: list[Any], scope: Any, source: Source) -> tuple[dict[str, Any], list[str]]:
        """launch_ros's ``parameters=``: mappings (nested ones flattened to dotted names) and parameter files."""
        from launch_ros.parameter_descriptions import Parameter, ParameterFile

        params: dict[str, Any] = dict(scope.params)
        files: list[str] = list(scope.param_files)

        def add_mapping(mapping: dict[Any, Any], prefix: str) -> None:
            for key, value in mapping.items():
                name = prefix + (key if isinstance(key, str) else self.perform(key, scope, source, "parameter name"))
                if isinstance(value, dict):
                    add_mapping(value, name + ".")
                else:
                    params[name] = self.parameter_value(value, scope, source)

        for item in items:
            if isinstance(item, dict):
                add_mapping(item, "")
            elif isinstance(item, Parameter):
                params[self.perform(item.name, scope, source, "parameter name")] = \
                    self.parameter_value(item.value, scope, source)
            else:
                location = item.param_file if isinstance(item, ParameterFile) else item
                text = self.perform(str(location) if isinstance(location, Path) else location, scope, source,
                                    "parameter file")
                path = Path(text).expanduser()
                if not path.is_file():
                    raise LaunchError(f"parameter file not found: {text}", source)
                files.append(str(path.resolve()))
        return params, files

    # -- containers -----------------------------------------------------------------------------
    def add_ros_container(self, container: Any, scope: Any) -> None:

        source = container.source
        name = self.perform(container.node_name, scope, source, "container name")
        namespace = join_namespace(scope.namespace, self.perform(container.node_namespace, scope, source,
                                                                 "container namespace"))
        check_namespace(namespace, source)
        options = self.process_options_ros(container, scope)
        label = self.unique_label(_label(name))
        spec = NodeSpec(name=label, namespace=namespace, module=CONTAINER_MODULE, executable=None, args=[],
                        params={}, param_files=[], remaps=[], source=str(source), action=container, **options)
        spec.composed = [self.ros_composable(d, scope, namespace, source)
                         for d in container.composable_node_descriptions if self.ros_condition(d, scope)]
        if not spec.composed:
            raise LaunchError(f"container '{name}' has no composable nodes (LoadComposableNodes into a container "
                              "this launch starts goes with it)", source)
        self.process_names.add(label)
        container.labels.append(label)
        self.plan.nodes.append(spec)

    def ros_composable(self, description: Any, scope: Any, container_namespace: str, source: Source) -> Any:

        plugin = self.perform(description.plugin, scope, source, "ComposableNode plugin")
        module, separator, _ = plugin.partition("::")
        if not separator:
            raise LaunchError(f"ComposableNode plugin '{plugin}' must be python.module::NodeClass (this launcher "
                              "composes Python nodes)", source)
        check_module(module, source)
        name = self.perform(description.name, scope, source, "ComposableNode name") \
            if description.name is not None else plugin.rpartition("::")[2].lower()
        namespace = container_namespace
        if description.namespace is not None:
            namespace = join_namespace(scope.namespace, self.perform(description.namespace, scope, source,
                                                                     "ComposableNode namespace"))
        check_namespace(namespace, source)
        params, files = self.ros_parameters(description.parameters, scope, source)
        remaps = [*scope.remaps, *((self.perform(normalize(a), scope, source, "remapping"),
                                    self.perform(normalize(b), scope, source, "remapping"))
                                   for a, b in description.remappings)]
        return ComposedNodeSpec(name=name, namespace=namespace, plugin=plugin, params=params, param_files=files,
                                remaps=remaps, source=str(source))

    def load_composables(self, labels: list[str], descriptions: list[Any], scope: Any, source: Source) -> None:
        for spec in self.plan.nodes:
            if spec.name in labels and spec.module is not None and spec.composed:
                spec.composed += [self.ros_composable(d, scope, spec.namespace, source) for d in descriptions
                                  if self.ros_condition(d, scope)]
                return
        raise LaunchError(f"LoadComposableNodes: container {', '.join(labels) or '?'} is not started by this "
                          "launch (before this action)", source)

    # -- reactions ------------------------------------------------------------------------------
    def log(self, text: str, level: str = "INFO") -> None:
        self.plan.logs.append((level, text))

    def shutdown(self, reason: str) -> None:
        if self.plan.shutdown is None:
            self.plan.shutdown = reason

    def unregister(self, handler: Any) -> None:
        self.plan.triggers = [t for t in self.plan.triggers if t.handler is not handler]

    def expand(self, produce: Callable[[Any], list[Any]], scope: Any) -> Any:
        """Resolve actions now (a trigger fired): a fresh plan collects what they yield."""

        saved = self.plan
        self.plan = LaunchPlan(file=saved.file, args=saved.args)
        try:
            actions = produce(scope.context())
            self.walk(list(actions), scope)
            return Expansion(nodes=self.plan.nodes, logs=self.plan.logs, triggers=self.plan.triggers,
                             shutdown=self.plan.shutdown)
        finally:
            self.plan = saved

    def add_timer(self, period: float, actions: Any, scope: Any, source: Source) -> None:

        snapshot = scope.child()
        if callable(actions):
            def produce(context: Any) -> list[Any]:
                return self.call_launch_code(lambda: actions(None, context), source, "timer")
        else:
            def produce(context: Any) -> list[Any]:
                return actions
        self.plan.triggers.append(Trigger(kind="timer", after=period, source=str(source),
                                          fire=lambda event: self.expand(produce, snapshot)))

    def add_handler(self, handler: Any, scope: Any, source: Source) -> None:

        snapshot = scope.child()

        def fire(event: Any) -> Any:
            return self.expand(lambda context: self.call_launch_code(
                lambda: handler.actions_for(event, context), source, f"{type(handler).__name__} handler"), snapshot)

        def matches(spec: Any) -> bool:
            if handler.target_action is None:
                return True
            return spec.action is not None and handler.matches(spec.action)

        self.plan.triggers.append(Trigger(kind=handler.kind, fire=fire, matches=matches, source=str(source),
                                          handler=handler))
