"""``launch.actions`` of the ROS launch API.

Each action owns its three parts, as launch_ros's ``@expose_action`` actions do: its Python constructor (what a
``.launch.py`` calls), ``parse(entity)`` (its ROS XML / ROS YAML spelling, ``launch.frontend``) and
``resolve(resolver, scope)`` (what it becomes in the launch plan: processes, arguments, handlers; the
resolver in ``launch.resolve`` calls it). Nothing runs here: the supervisor runs the plan.
"""

from __future__ import annotations

import os
import shlex
import shutil
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from launch.context import Action, Condition, LaunchContext, LaunchDescription, caller_source, normalize
from launch.yaml_source import LaunchError

__all__ = [
    "Action", "AppendEnvironmentVariable", "DeclareLaunchArgument", "EmitEvent", "ExecuteProcess", "GroupAction",
    "IncludeLaunchDescription", "LogInfo", "OpaqueFunction", "RegisterEventHandler", "SetEnvironmentVariable",
    "SetLaunchConfiguration", "Shutdown", "TimerAction", "UnsetEnvironmentVariable",
]


class LocatedAction(Action):
    """An action that remembers the launch-file line that built it (errors name it)."""

    def __init__(self, *, condition: Condition | None = None, **unknown: Any) -> None:
        if unknown:
            raise TypeError(f"{type(self).__name__}() got unexpected keyword argument(s): {', '.join(unknown)}")
        super().__init__(condition=condition)
        self.source = caller_source()


class DeclareLaunchArgument(LocatedAction):
    def __init__(self, name: str, *, default_value: Any = None, description: str | None = None,
                 choices: list[str] | None = None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name = name
        self.default_value = None if default_value is None else normalize(default_value)
        self.description = description or ""
        self.choices = None if choices is None else [str(c) for c in choices]

    @classmethod
    def parse(cls, entity: Any) -> DeclareLaunchArgument:
        choices = [c.get("value") for c in entity.children_of("choice")] or None
        return cls(entity.get("name", text=True), default_value=entity.sub("default", optional=True),
                   description=entity.get("description", optional=True, text=True), choices=choices,
                   **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.declare_value(self.name, self.default_value, self.choices, scope, self.source)


class SetLaunchConfiguration(LocatedAction):
    def __init__(self, name: Any, value: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name, self.value = normalize(name), normalize(value)

    @classmethod
    def parse(cls, entity: Any) -> SetLaunchConfiguration:
        return cls(entity.sub("name"), entity.sub("value"), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        name = resolver.perform(self.name, scope, self.source, "SetLaunchConfiguration name")
        scope.variables[name] = resolver.perform(self.value, scope, self.source, f"SetLaunchConfiguration {name}")


class SetEnvironmentVariable(LocatedAction):
    def __init__(self, name: Any, value: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name, self.value = normalize(name), normalize(value)

    @classmethod
    def parse(cls, entity: Any) -> SetEnvironmentVariable:
        return cls(entity.sub("name"), entity.sub("value"), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        name = resolver.perform(self.name, scope, self.source, "environment variable name")
        scope.env[name] = resolver.perform(self.value, scope, self.source, f"environment variable {name}")


class AppendEnvironmentVariable(SetEnvironmentVariable):
    def __init__(self, name: Any, value: Any, *, prepend: bool = False, separator: str = os.pathsep,
                 **kwargs: Any) -> None:
        super().__init__(name, value, **kwargs)
        self.prepend, self.separator = prepend, separator

    def resolve(self, resolver: Any, scope: Any) -> None:
        name = resolver.perform(self.name, scope, self.source, "environment variable name")
        value = resolver.perform(self.value, scope, self.source, f"environment variable {name}")
        old = scope.env.get(name, os.environ.get(name, ""))
        parts = [value, old] if self.prepend else [old, value]
        scope.env[name] = self.separator.join(p for p in parts if p)


class UnsetEnvironmentVariable(LocatedAction):
    def __init__(self, name: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name = normalize(name)

    @classmethod
    def parse(cls, entity: Any) -> UnsetEnvironmentVariable:
        return cls(entity.sub("name"), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        scope.env[resolver.perform(self.name, scope, self.source, "environment variable name")] = None


class LogInfo(LocatedAction):
    def __init__(self, *, msg: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.msg = normalize(msg)

    @classmethod
    def parse(cls, entity: Any) -> LogInfo:
        return cls(msg=entity.sub("message"), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.log(resolver.perform(self.msg, scope, self.source, "LogInfo msg"))


class Shutdown(LocatedAction):
    def __init__(self, *, reason: Any = "reason not given", **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.reason = normalize(reason)

    @classmethod
    def parse(cls, entity: Any) -> Shutdown:
        return cls(reason=entity.sub("reason", optional=True) or "reason not given", **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.shutdown(f"Shutdown action ({resolver.perform(self.reason, scope, self.source, 'reason')})")


class EmitEvent(LocatedAction):
    """``Shutdown`` ends the launch; an event with an ``emit`` method (launch_ros' lifecycle ``ChangeState``)
    does what it says; any other is reported and ignored."""

    def __init__(self, *, event: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.event = event

    def resolve(self, resolver: Any, scope: Any) -> None:
        from launch.events import Shutdown as ShutdownEvent

        if isinstance(self.event, ShutdownEvent):
            resolver.shutdown(f"Shutdown event ({self.event.reason})")
        elif callable(getattr(self.event, "emit", None)):
            self.event.emit(resolver, scope, self.source)
        else:
            resolver.log(f"{self.source}: EmitEvent({type(self.event).__name__}) is not supported by this launcher; "
                         "ignored", level="WARN")


class OpaqueFunction(LocatedAction):
    """``function(context, *args, **kwargs)`` is called when the launch is resolved; the actions it returns
    are resolved in the same scope (ROS's way to compute values from launch configurations in Python)."""

    def __init__(self, *, function: Callable[..., Any], args: Iterable[Any] | None = None,
                 kwargs: dict[str, Any] | None = None, **rest: Any) -> None:
        super().__init__(**rest)
        if not callable(function):
            raise TypeError("OpaqueFunction: 'function' must be callable")
        self.function, self.args, self.kwargs = function, list(args or []), dict(kwargs or {})

    def resolve(self, resolver: Any, scope: Any) -> None:
        context = scope.context()
        returned = resolver.call_launch_code(lambda: self.function(context, *self.args, **self.kwargs), self.source)
        if returned:
            resolver.walk(list(returned), scope)


class TimerAction(LocatedAction):
    def __init__(self, *, period: Any, actions: Iterable[Any], cancel_on_shutdown: Any = True,
                 **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.period = normalize(period)
        self.actions = list(actions)

    @classmethod
    def parse(cls, entity: Any) -> TimerAction:
        return cls(period=entity.sub("period"), actions=entity.actions(), **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        text = resolver.perform(self.period, scope, self.source, "TimerAction period")
        try:
            period = float(text)
        except ValueError:
            raise LaunchError(f"TimerAction period must be a number of seconds, got '{text}'", self.source) from None
        resolver.add_timer(period, self.actions, scope, self.source)


class GroupAction(LocatedAction):
    """Actions in a scope of their own: launch configurations, environment, namespace, parameters and
    remappings set inside stay inside (``scoped``); ``forwarding=False`` starts from ``launch_configurations``
    only."""

    def __init__(self, actions: Iterable[Any], *, scoped: bool = True, forwarding: bool = True,
                 launch_configurations: dict[Any, Any] | None = None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.actions = list(actions)
        self.scoped, self.forwarding = scoped, forwarding
        self.launch_configurations = dict(launch_configurations or {})

    @classmethod
    def parse(cls, entity: Any) -> GroupAction:
        actions = entity.actions()
        scoped = entity.get("scoped", optional=True, text=True)
        return cls(actions, scoped=scoped is None or scoped.lower() == "true", **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        inner = scope.child() if self.scoped else scope
        if not self.forwarding:
            inner.variables.clear()
        for key, value in self.launch_configurations.items():
            name = resolver.perform(normalize(key), scope, self.source, "GroupAction launch configuration")
            inner.variables[name] = resolver.perform(normalize(value), scope, self.source, name)
        resolver.walk(self.actions, inner)

    def get_sub_entities(self) -> list[Any]:
        return list(self.actions)


class IncludeLaunchDescription(LocatedAction):
    def __init__(self, launch_description_source: Any, *, launch_arguments: Iterable[Any] | None = None,
                 **kwargs: Any) -> None:
        super().__init__(**kwargs)
        from launch.launch_description_sources import LaunchDescriptionSource

        if isinstance(launch_description_source, LaunchDescription):
            launch_description_source = LaunchDescriptionSource(launch_description_source)
        elif not isinstance(launch_description_source, LaunchDescriptionSource):
            launch_description_source = LaunchDescriptionSource(launch_description_source)
        self.launch_description_source = launch_description_source
        pairs = launch_arguments.items() if isinstance(launch_arguments, dict) else (launch_arguments or [])
        self.launch_arguments = [(normalize(k), normalize(v)) for k, v in pairs]

    @classmethod
    def parse(cls, entity: Any) -> IncludeLaunchDescription:
        from launch.launch_description_sources import AnyLaunchDescriptionSource

        args = [(a.sub("name"), a.sub("value")) for a in entity.children_of("arg")]
        return cls(AnyLaunchDescriptionSource(entity.sub("file")), launch_arguments=args, **entity.condition())

    def resolve(self, resolver: Any, scope: Any) -> None:
        given = {resolver.perform(k, scope, self.source, "include argument name"):
                 resolver.perform(v, scope, self.source, "include argument value") for k, v in self.launch_arguments}
        source = self.launch_description_source
        if source.description is not None:   # a LaunchDescription object built in Python
            resolver.include_description(source.description, given, scope, self.source)
            return
        location = resolver.perform(source.location, scope, self.source, "included launch file")
        resolver.include_path(location, given, scope, self.source)


class ExecuteProcess(LocatedAction):
    """A program (no shell): ``cmd`` is its argv, each item one argument (``shell=True`` splits the text as
    a POSIX shell would, still without a shell)."""

    def __init__(self, *, cmd: Iterable[Any], name: Any = None, cwd: Any = None, env: dict[Any, Any] | None = None,
                 additional_env: dict[Any, Any] | None = None, shell: bool = False, output: Any = "screen",
                 respawn: Any = False, respawn_delay: float | None = None, prefix: Any = None,
                 sigterm_timeout: Any = None, sigkill_timeout: Any = None, emulate_tty: bool = False,
                 log_cmd: bool = False, cached_output: bool = False, on_exit: Any = None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.cmd = [normalize(item) for item in cmd]
        self.name = None if name is None else normalize(name)
        self.cwd = None if cwd is None else normalize(cwd)
        self.env = None if env is None else [(normalize(k), normalize(v)) for k, v in env.items()]
        self.additional_env = [(normalize(k), normalize(v)) for k, v in (additional_env or {}).items()]
        self.shell = shell
        self.output = normalize(output)
        self.respawn = normalize(respawn)
        self.respawn_delay = respawn_delay
        self.prefix = None if prefix is None else normalize(prefix)
        self.on_exit = on_exit
        self.labels: list[str] = []   # the process names this action became (for event handlers)

    @classmethod
    def parse(cls, entity: Any) -> ExecuteProcess:
        cmd = entity.sub("cmd")
        entity.get("shell", optional=True)   # the text is always split as a shell would (never run by one)
        return cls(cmd=[cmd], shell=True, name=entity.sub("name", optional=True), cwd=entity.sub("cwd", optional=True),
                   prefix=entity.sub("launch-prefix", optional=True),
                   additional_env={e.sub("name"): e.sub("value") for e in entity.children_of("env")},
                   output=entity.sub("output", optional=True) or "screen",
                   respawn=entity.sub("respawn", optional=True) or "false", **entity.condition())

    def command(self, resolver: Any, scope: Any) -> list[str]:
        argv = [resolver.perform(item, scope, self.source, "ExecuteProcess cmd") for item in self.cmd]
        if self.shell:
            argv = [word for item in argv for word in shlex.split(item)]
        if self.prefix is not None:
            argv = shlex.split(resolver.perform(self.prefix, scope, self.source, "prefix")) + argv
        if not argv or not argv[0]:
            raise LaunchError("ExecuteProcess: empty cmd", self.source)
        argv[0] = find_program(argv[0], self.source)
        return argv

    def resolve(self, resolver: Any, scope: Any) -> None:
        argv = self.command(resolver, scope)
        name = resolver.perform(self.name, scope, self.source, "name") if self.name is not None else None
        resolver.add_ros_process(self, scope, argv=argv, label=name or Path(argv[0]).name, node_name=None,
                                 style="plain")
        register_on_exit(self, resolver, scope)


class _OnOwnExit:
    """``on_exit=`` of a process action: its own exit handler (OnProcessExit targeting it)."""

    kind = "exit"

    def __init__(self, action: Any) -> None:
        self.target_action = action

    def matches(self, action: Any) -> bool:
        return action is self.target_action

    def actions_for(self, event: Any, context: LaunchContext) -> list[Any]:
        return run_callable_or_actions(self.target_action.on_exit, event, context)


def register_on_exit(action: Any, resolver: Any, scope: Any) -> None:
    if getattr(action, "on_exit", None) is not None:
        resolver.add_handler(_OnOwnExit(action), scope, action.source)


def find_program(program: str, source: Any) -> str:
    """A program by path or on the PATH (also beside this Python: the console scripts of this environment,
    ``ros2`` among them, when the environment is not activated)."""
    if os.sep in program:
        if os.access(program, os.X_OK) and Path(program).is_file():
            return program
        raise LaunchError(f"ExecuteProcess: program '{program}' not found or not executable", source)
    if program in ("python", "python3"):
        return sys.executable
    found = shutil.which(program)
    if found is None:
        beside = Path(sys.executable).parent / program
        if beside.is_file() and os.access(beside, os.X_OK):
            return str(beside)
        raise LaunchError(f"ExecuteProcess: executable '{program}' not found (searched PATH and "
                          f"{Path(sys.executable).parent})", source)
    return found


class RegisterEventHandler(LocatedAction):
    def __init__(self, event_handler: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.event_handler = event_handler

    def resolve(self, resolver: Any, scope: Any) -> None:
        self.event_handler.register(resolver, scope, self.source)


class UnregisterEventHandler(LocatedAction):
    def __init__(self, event_handler: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.event_handler = event_handler

    def resolve(self, resolver: Any, scope: Any) -> None:
        resolver.unregister(self.event_handler)


def run_callable_or_actions(value: Any, event: Any, context: LaunchContext) -> list[Any]:
    """An event handler's reaction: a list of actions, one action, or ``callable(event, context)``."""
    if value is None:
        return []
    if callable(value) and not isinstance(value, Action):
        import inspect

        try:
            takes = len(inspect.signature(value).parameters)
        except (TypeError, ValueError):
            takes = 2
        returned = value(event, context) if takes >= 2 else value(event)
        if returned is None:
            return []
        return list(returned) if isinstance(returned, (list, tuple)) else [returned]
    return list(value) if isinstance(value, (list, tuple)) else [value]
