"""The ROS launch API's core objects: ``LaunchContext``, ``Substitution``, ``Condition``, ``Action`` and
``LaunchDescription`` (as ``launch`` of ROS 2 spells them).

Here they are *descriptions*: a ``.launch.py`` builds them, ``launch.python_source`` turns them into the
launcher's inert description (``launch.description``), and the launcher resolves and supervises that, the
same as for a YAML file. Substitutions and conditions are evaluated by the resolver with a ``LaunchContext``
that holds the launch configurations in scope.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any


class LaunchContext:
    """What substitutions see: the launch configurations in scope, the environment, the current file."""

    def __init__(self, launch_configurations: Mapping[str, str] | None = None, *,
                 current_file: Path | None = None, environment: Mapping[str, str] | None = None,
                 argv: list[str] | None = None) -> None:
        self.launch_configurations: dict[str, str] = dict(launch_configurations or {})
        self.current_file = current_file
        self.environment: dict[str, str] = dict(os.environ if environment is None else environment)
        self.argv = list(argv or [])
        self.locals = _Locals(self)

    def perform_substitution(self, substitution: Any) -> str:
        return perform_substitutions(self, normalize(substitution))

    def get_locals_as_dict(self) -> dict[str, Any]:
        return {"launch_configurations": self.launch_configurations,
                "current_launch_file_directory": str(self.current_file.parent) if self.current_file else ""}


class _Locals:
    """``context.locals.current_launch_file_directory`` (as ROS's context locals)."""

    def __init__(self, context: LaunchContext) -> None:
        self._context = context

    @property
    def current_launch_file_directory(self) -> str:
        file = self._context.current_file
        return str(file.resolve().parent) if file else os.getcwd()

    @property
    def launch_configurations(self) -> dict[str, str]:
        return self._context.launch_configurations


class Substitution:
    """A value computed when the launch runs (``perform(context) -> str``)."""

    def perform(self, context: LaunchContext) -> str:
        raise NotImplementedError

    def describe(self) -> str:
        return f"{type(self).__name__}(...)"

    def __repr__(self) -> str:
        return self.describe()


class Condition:
    """``condition=`` of an action: ``evaluate(context) -> bool``."""

    def __init__(self, *, predicate: Any = None) -> None:
        self._predicate = predicate

    def evaluate(self, context: LaunchContext) -> bool:
        return bool(self._predicate(context)) if self._predicate is not None else True


class LaunchDescriptionEntity:
    """Base of what a LaunchDescription holds."""

    def describe(self) -> str:
        return type(self).__name__


class Action(LaunchDescriptionEntity):
    """Base of every ROS launch action: an optional ``condition``."""

    def __init__(self, *, condition: Condition | None = None) -> None:
        self.condition = condition

    # ROS's API: the condition object
    def get_condition(self) -> Condition | None:
        return self.condition

    def execute(self, context: LaunchContext) -> Any:
        """Actions are descriptions here: the launcher runs them, not the file."""
        raise RuntimeError(f"{type(self).__name__}.execute is not available: the launcher runs the description")

    def visit(self, context: LaunchContext) -> Any:
        return self.execute(context)


class LaunchDescription(LaunchDescriptionEntity):
    """What ``generate_launch_description()`` returns: a list of actions."""

    def __init__(self, initial_entities: Iterable[Any] | None = None, *,
                 deprecated_reason: str | None = None) -> None:
        self.entities: list[Any] = list(initial_entities or [])
        self.deprecated_reason = deprecated_reason

    def add_action(self, action: Any) -> None:
        self.entities.append(action)

    def add_entity(self, entity: Any) -> None:
        self.entities.append(entity)

    def get_launch_arguments(self, conditional_inclusion: bool = False) -> list[Any]:
        return [e for e in self.entities if type(e).__name__ == "DeclareLaunchArgument"]

    def describe_sub_entities(self) -> list[Any]:
        return list(self.entities)


def normalize(value: Any) -> list[Any]:
    """ROS's SomeSubstitutionsType: a string, a Substitution, or an iterable of either."""
    if value is None:
        return []
    if isinstance(value, (str, Substitution)):
        return [value]
    if isinstance(value, Path):
        return [str(value)]
    if isinstance(value, (int, float, bool)):
        return [str(value).lower() if isinstance(value, bool) else str(value)]
    if isinstance(value, Iterable):
        out: list[Any] = []
        for item in value:
            out.extend(normalize(item))
        return out
    raise TypeError(f"expected a string or a substitution, got {type(value).__name__}: {value!r}")


def is_substitution_value(value: Any) -> bool:
    """A value the resolver must perform (a Substitution, or a list holding one)."""
    if isinstance(value, Substitution):
        return True
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, (str, Substitution)) for v in value):
        return any(isinstance(v, Substitution) for v in value)
    return False


def perform_substitutions(context: LaunchContext, substitutions: Iterable[Any]) -> str:
    return "".join(s if isinstance(s, str) else s.perform(context) for s in substitutions)


_API_DIRS = (str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parent.parent / "launch_ros"))


def caller_source() -> Any:
    """Where the launch file built an action (the first frame outside launch/ and launch_ros/): errors name it."""
    import sys

    from launch.yaml_source import Source

    frame = sys._getframe(1)
    while frame is not None:
        filename = frame.f_code.co_filename
        if filename.endswith(".launch.py") or not (filename.startswith(_API_DIRS) or filename.startswith("<frozen")):
            return Source(Path(filename), frame.f_lineno)
        frame = frame.f_back
    return Source(Path("<launch>"), 0)
