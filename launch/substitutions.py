"""``launch.substitutions`` of the ROS launch API: values performed when the launch is resolved.

Our YAML format's ``$(var ...)`` text substitutions live in ``launch._yaml_substitutions``; the XML and ROS
YAML front ends' ``$(find-pkg-share ...)``, ``$(command ...)`` and ``$(eval ...)`` call the classes here.

``PythonExpression`` evaluates Python, as ROS's does: a ``.launch.py`` (and ``$(eval ...)`` of a ROS XML or
YAML launch file) is code chosen by whoever wrote the launch file, and launching it runs it. It is the
launcher's only ``eval``; nothing received over the wire ever reaches it.
"""

from __future__ import annotations

import importlib
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from launch.context import LaunchContext, Substitution, normalize, perform_substitutions

__all__ = [
    "AndSubstitution", "AnonName", "Command", "EnvironmentVariable", "EqualsSubstitution", "FindExecutable",
    "LaunchConfiguration", "NotEqualsSubstitution", "NotSubstitution", "OrSubstitution", "PathJoinSubstitution",
    "PathSubstitution", "PythonExpression", "Substitution", "SubstitutionFailure", "TextSubstitution",
    "ThisLaunchFile", "ThisLaunchFileDir",
]

_TRUE = ("true", "1")
_FALSE = ("false", "0")


class SubstitutionFailure(Exception):
    """A substitution that cannot be performed (missing configuration, failed command, ...)."""


class TextSubstitution(Substitution):
    def __init__(self, *, text: str) -> None:
        self.text = str(text)

    def perform(self, context: LaunchContext) -> str:
        return self.text

    def describe(self) -> str:
        return repr(self.text)


class PathOperators:
    """``/`` joins paths, as ROS's PathSubstitution and PathJoinSubstitution do."""

    def __truediv__(self, other: Any) -> PathJoinSubstitution:
        return PathJoinSubstitution([self, other])


class PathJoinSubstitution(PathOperators, Substitution):
    def __init__(self, substitutions: Any) -> None:
        # each item is one path component (itself a string, a substitution or a list of them)
        self.substitutions = [normalize(item) for item in substitutions]

    def perform(self, context: LaunchContext) -> str:
        return os.path.join(*[perform_substitutions(context, part) for part in self.substitutions]) \
            if self.substitutions else ""

    def describe(self) -> str:
        return f"PathJoin({self.substitutions!r})"


class PathSubstitution(PathOperators, Substitution):
    def __init__(self, path: Any) -> None:
        self.path = normalize(str(path) if isinstance(path, Path) else path)

    def perform(self, context: LaunchContext) -> str:
        return perform_substitutions(context, self.path)


class LaunchConfiguration(Substitution):
    def __init__(self, variable_name: Any, *, default: Any = None) -> None:
        self.variable_name = normalize(variable_name)
        self.default = None if default is None else normalize(default)

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.variable_name)
        if name in context.launch_configurations:
            return context.launch_configurations[name]
        if self.default is not None:
            return perform_substitutions(context, self.default)
        known = ", ".join(sorted(context.launch_configurations)) or "none"
        raise SubstitutionFailure(f"launch configuration '{name}' does not exist (set: {known}; declare it with "
                                  f"DeclareLaunchArgument or give it as {name}:=VALUE)")

    def describe(self) -> str:
        return f"LaunchConfiguration({''.join(map(str, self.variable_name))!r})"


class EnvironmentVariable(Substitution):
    def __init__(self, name: Any, *, default_value: Any = None) -> None:
        self.name = normalize(name)
        self.default_value = None if default_value is None else normalize(default_value)

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.name)
        if name in context.environment:
            return context.environment[name]
        if self.default_value is not None:
            return perform_substitutions(context, self.default_value)
        raise SubstitutionFailure(f"environment variable '{name}' is not set and no default_value was given")


class ThisLaunchFileDir(PathOperators, Substitution):
    def perform(self, context: LaunchContext) -> str:
        return context.locals.current_launch_file_directory


class ThisLaunchFile(Substitution):
    def perform(self, context: LaunchContext) -> str:
        return str(context.current_file.resolve()) if context.current_file else ""


class FindExecutable(Substitution):
    def __init__(self, *, name: Any) -> None:
        self.name = normalize(name)

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.name)
        found = shutil.which(name, path=context.environment.get("PATH"))
        beside = Path(sys.executable).parent / name   # this environment's console scripts (ros2, xacro)
        if found is None and beside.is_file() and os.access(beside, os.X_OK):
            found = str(beside)
        if found is None:
            raise SubstitutionFailure(f"executable '{name}' not found on the PATH or in {beside.parent}")
        return found


class Command(Substitution):
    """Runs a program (no shell: the text is split as a POSIX shell would) and gives its stdout."""

    def __init__(self, command: Any, *, on_stderr: Any = "fail") -> None:
        self.command = normalize(command)
        self.on_stderr = normalize(on_stderr)

    def perform(self, context: LaunchContext) -> str:
        text = perform_substitutions(context, self.command)
        on_stderr = perform_substitutions(context, self.on_stderr)
        argv = shlex.split(text)
        if not argv:
            raise SubstitutionFailure("Command: empty command")
        try:
            done = subprocess.run(argv, capture_output=True, text=True, env=context.environment, check=False)
        except FileNotFoundError:
            raise SubstitutionFailure(f"Command: executable '{argv[0]}' not found (command: {text})") from None
        except OSError as exc:
            raise SubstitutionFailure(f"Command: cannot run '{text}': {exc}") from None
        if done.returncode != 0:
            raise SubstitutionFailure(f"Command '{text}' failed with status {done.returncode}: "
                                      f"{done.stderr.strip() or done.stdout.strip()}")
        if done.stderr.strip():
            if on_stderr == "fail":
                raise SubstitutionFailure(f"Command '{text}' wrote to stderr: {done.stderr.strip()}")
            if on_stderr == "capture":
                return done.stdout + done.stderr
            if on_stderr == "warn":
                print(f"[launch] [WARN] Command '{text}': {done.stderr.strip()}", flush=True)
        return done.stdout

    def describe(self) -> str:
        return f"Command({self.command!r})"


class PythonExpression(Substitution):
    """Evaluates the text as Python (with ``math`` and the ``python_modules`` given), as ROS does: this is
    launch-file code, run because the user launched the file."""

    def __init__(self, expression: Any, python_modules: Any = ("math",)) -> None:
        self.expression = normalize(expression)
        self.python_modules = normalize(python_modules)

    def perform(self, context: LaunchContext) -> str:
        text = perform_substitutions(context, self.expression)
        namespace: dict[str, Any] = {}
        for module in self.python_modules:
            name = module if isinstance(module, str) else module.perform(context)
            imported = importlib.import_module(name)
            namespace[name.split(".")[0]] = importlib.import_module(name.split(".")[0])
            if name == "math":
                namespace.update({k: v for k, v in vars(imported).items() if not k.startswith("_")})
        try:
            return str(eval(text, namespace))  # noqa: S307 - launch-file code by design (see the module docstring)
        except Exception as exc:
            raise SubstitutionFailure(f"PythonExpression '{text}' raised {type(exc).__name__}: {exc}") from None

    def describe(self) -> str:
        return f"PythonExpression({self.expression!r})"


def _bool(text: str, what: str) -> bool:
    lowered = text.strip().lower()
    if lowered in _TRUE:
        return True
    if lowered in _FALSE:
        return False
    raise SubstitutionFailure(f"{what}: '{text}' is not a boolean (true, false, 1 or 0)")


def _text(value: bool) -> str:
    return "true" if value else "false"


class AndSubstitution(Substitution):
    def __init__(self, left: Any, right: Any) -> None:
        self.left, self.right = normalize(left), normalize(right)

    def perform(self, context: LaunchContext) -> str:
        return _text(_bool(perform_substitutions(context, self.left), "AndSubstitution")
                     and _bool(perform_substitutions(context, self.right), "AndSubstitution"))


class OrSubstitution(AndSubstitution):
    def perform(self, context: LaunchContext) -> str:
        return _text(_bool(perform_substitutions(context, self.left), "OrSubstitution")
                     or _bool(perform_substitutions(context, self.right), "OrSubstitution"))


class NotSubstitution(Substitution):
    def __init__(self, value: Any) -> None:
        self.value = normalize(value)

    def perform(self, context: LaunchContext) -> str:
        return _text(not _bool(perform_substitutions(context, self.value), "NotSubstitution"))


def _comparable(text: str) -> Any:
    lowered = text.strip().lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    try:
        return float(text)
    except ValueError:
        return text


class EqualsSubstitution(Substitution):
    """'true' when both sides are equal, as booleans, numbers or text (as ROS compares them)."""

    def __init__(self, left: Any, right: Any) -> None:
        self.left, self.right = normalize(left), normalize(right)

    def perform(self, context: LaunchContext) -> str:
        return _text(_comparable(perform_substitutions(context, self.left))
                     == _comparable(perform_substitutions(context, self.right)))


class NotEqualsSubstitution(EqualsSubstitution):
    def perform(self, context: LaunchContext) -> str:
        return _text(super().perform(context) == "false")


class AnonName(Substitution):
    """A unique name for this launch (``name`` plus the launcher's pid)."""

    def __init__(self, name: Any) -> None:
        self.name = normalize(name)

    def perform(self, context: LaunchContext) -> str:
        return f"{perform_substitutions(context, self.name)}_{os.getpid()}"
