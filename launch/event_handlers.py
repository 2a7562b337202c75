"""``launch.event_handlers`` of the ROS launch API: reactions to processes starting, writing, exiting and to
the launch shutting down. ``register`` turns each into a trigger of the launch plan; the supervisor fires it
and the actions it yields are resolved then (``launch.resolve``)."""

from __future__ import annotations

from typing import Any

from launch.actions import run_callable_or_actions
from launch.context import Action

__all__ = ["EventHandler", "OnExecutionComplete", "OnProcessExit", "OnProcessIO", "OnProcessStart", "OnShutdown"]


class EventHandler:
    kind = ""   # the supervisor's event: start | exit | io | shutdown

    def __init__(self, *, target_action: Any = None, handler: Any = None, **_: Any) -> None:
        self.target_action = target_action
        self.handler = handler

    def matches(self, action: Any) -> bool:
        """Whether an event of ``action`` (the action object that became the process) is ours."""
        if self.target_action is None:
            return True
        if callable(self.target_action) and not isinstance(self.target_action, Action):
            return bool(self.target_action(action))
        return action is self.target_action

    def actions_for(self, event: Any, context: Any) -> list[Any]:
        return run_callable_or_actions(self.handler, event, context)

    def register(self, resolver: Any, scope: Any, source: Any) -> None:
        resolver.add_handler(self, scope, source)


class OnProcessStart(EventHandler):
    kind = "start"

    def __init__(self, *, target_action: Any = None, on_start: Any, **kwargs: Any) -> None:
        super().__init__(target_action=target_action, handler=on_start, **kwargs)


class OnProcessExit(EventHandler):
    kind = "exit"

    def __init__(self, *, target_action: Any = None, on_exit: Any, **kwargs: Any) -> None:
        super().__init__(target_action=target_action, handler=on_exit, **kwargs)


class OnExecutionComplete(EventHandler):
    """For a process: when it has exited. For any other action: as soon as the launch has started it."""

    kind = "exit"

    def __init__(self, *, target_action: Any = None, on_completion: Any, **kwargs: Any) -> None:
        super().__init__(target_action=target_action, handler=on_completion, **kwargs)

    def register(self, resolver: Any, scope: Any, source: Any) -> None:
        from launch.actions import ExecuteProcess

        if self.target_action is None or isinstance(self.target_action, ExecuteProcess):
            resolver.add_handler(self, scope, source)
        else:
            resolver.add_timer(0.0, lambda event, context: self.actions_for(event, context), scope, source)


class OnProcessIO(EventHandler):
    kind = "io"

    def __init__(self, *, target_action: Any = None, on_stdout: Any = None, on_stderr: Any = None,
                 on_stdin: Any = None, **kwargs: Any) -> None:
        # the launcher merges a process's stderr into its stdout: both callbacks see every line
        super().__init__(target_action=target_action, **kwargs)
        self.on_stdout, self.on_stderr = on_stdout, on_stderr

    def actions_for(self, event: Any, context: Any) -> list[Any]:
        out = run_callable_or_actions(self.on_stdout, event, context)
        if self.on_stderr is not None and self.on_stderr is not self.on_stdout:
            out += run_callable_or_actions(self.on_stderr, event, context)
        return out


class OnShutdown(EventHandler):
    kind = "shutdown"

    def __init__(self, *, on_shutdown: Any, **kwargs: Any) -> None:
        super().__init__(handler=on_shutdown, **kwargs)
