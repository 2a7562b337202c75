"""Text substitutions of launch files: ours (``$(var NAME)``, ``$(env NAME [default])``, ``$(dirname)``,
``$(robot NAME)``, ``$(config NAME)``, ``$(robot_controllers ROBOT FILE)``: the controllers file derived from a
robot, ``$(broadcasters CONTROLLERS_FILE)``: its sensor broadcasters, space-separated) and, for ROS's XML and YAML launch formats, ROS's frontend ones
(``$(find-pkg-share PKG)``, ``$(find-pkg-prefix PKG)``, ``$(find-exec NAME)``, ``$(exec-in-pkg EXE PKG)``,
``$(command 'CMD')``, ``$(eval 'EXPR')``, ``$(and A B)``, ``$(or A B)``, ``$(not A)``, ``$(equals A B)``,
``$(not-equals A B)``, ``$(anon NAME)``, ``$(filename)``), which call ``launch.substitutions``.

Our own kinds are pure text replacement. ``$(eval)`` evaluates Python and ``$(command)`` runs a program, as
in ROS: a launch file is code its author wrote; they are never applied to anything received over the wire.
Substitutions nest; ``$$(`` is a literal ``$(``; ``'...'`` quotes an argument.
"""

from __future__ import annotations

import os
import shlex
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from launch.yaml_source import LaunchError, Source

KINDS = ("var", "env", "dirname", "robot", "config", "robot_controllers", "broadcasters")
ROS_KINDS = ("find-pkg-share", "find-pkg-prefix", "find-exec", "exec-in-pkg", "command", "eval", "and", "or", "not",
             "equals", "not-equals", "anon", "filename")


@dataclass
class SubstitutionContext:
    """What substitutions can see: the launch arguments in scope and the current file."""

    variables: Mapping[str, str]
    current_file: Path
    environ: Mapping[str, str] | None = None
    robot_resolver: Callable[[str], Path] | None = None


def _default_robot_resolver(name: str) -> Path:
    from nodes.share import robot_file

    return robot_file(name)


def _evaluate(kind: str, words: list[str], ctx: SubstitutionContext, source: Source) -> str:
    if kind == "var":
        if len(words) != 1:
            raise LaunchError(f"$(var) takes one argument name, got {len(words)}", source)
        name = words[0]
        if name not in ctx.variables:
            known = ", ".join(sorted(ctx.variables)) or "none"
            raise LaunchError(f"$(var {name}): no launch argument '{name}' is declared (declared: {known})",
                              source)
        return ctx.variables[name]
    if kind == "env":
        if len(words) not in (1, 2):
            raise LaunchError("$(env NAME [default]) takes a name and an optional default", source)
        environ = os.environ if ctx.environ is None else ctx.environ
        if words[0] in environ:
            return environ[words[0]]
        if len(words) == 2:
            return words[1]
        raise LaunchError(f"$(env {words[0]}): environment variable '{words[0]}' is not set "
                          "and no default was given", source)
    if kind == "dirname":
        if words:
            raise LaunchError("$(dirname) takes no arguments", source)
        return str(ctx.current_file.resolve().parent)
    if kind == "robot":
        if len(words) != 1:
            raise LaunchError("$(robot NAME) takes one robot name", source)
        resolver = ctx.robot_resolver or _default_robot_resolver
        try:
            return str(resolver(words[0]))
        except FileNotFoundError as exc:
            raise LaunchError(f"$(robot {words[0]}): {exc}", source) from None
    if kind == "config":
        from nodes.share import config_file

        if len(words) != 1:
            raise LaunchError("$(config NAME) takes one file name", source)
        try:
            return str(config_file(words[0]))
        except FileNotFoundError as exc:
            raise LaunchError(f"$(config {words[0]}): {exc}", source) from None
    if kind in ("robot_controllers", "broadcasters"):
        return _robot_setup(kind, words, source)
    if kind in ROS_KINDS:
        return _evaluate_ros(kind, words, ctx, source)
    raise LaunchError(f"unknown substitution '$({kind})' (known: {', '.join(KINDS + ROS_KINDS)})", source)


class RobotFileError(LaunchError):
    """The launch's robot cannot run (its file, xacro, meshes, inertias): the launch ends at once with status 1,
    as a robot that fails to spawn would end it, instead of the usage status 2."""


def _robot_setup(kind: str, words: list[str], source: Source) -> str:
    """A robot's controllers: the file (written when derived, said on the log) or its sensor broadcasters.
    A robot that cannot run (xacro error, a mesh resolving nowhere, ...) fails the launch here, named."""
    import sys

    import yaml

    from nodes.packages.index import add_own_package
    from nodes.share import robot_file
    from nodes.share.controllers import broadcasters
    from nodes.sim.robot_files import ConfigError, controllers_for

    if kind == "robot_controllers":
        if len(words) != 2:
            raise LaunchError("$(robot_controllers ROBOT FILE) takes a robot name and its file", source)
        try:
            added = add_own_package(robot_file(words[1]))
        except FileNotFoundError:
            added = None   # controllers_for names the file that is not there
        if added:
            print(f"[launch] [INFO] {added}", file=sys.stderr, flush=True)
        try:
            path, generated = controllers_for(*words)
        except ConfigError as exc:
            raise RobotFileError(f"robot {words[1]}: {exc}", source) from None
        if generated:
            print(f"[launch] [INFO] {generated}", file=sys.stderr, flush=True)
        return str(path)
    if len(words) != 1:
        raise LaunchError("$(broadcasters CONTROLLERS_FILE) takes one file", source)
    try:
        config = yaml.safe_load(Path(words[0]).read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise LaunchError(f"$(broadcasters {words[0]}): {exc}", source) from None
    return " ".join(broadcasters(config)) if isinstance(config, dict) else ""


_ARITY = {"find-pkg-share": 1, "find-pkg-prefix": 1, "find-exec": 1, "exec-in-pkg": 2, "command": 1, "eval": 1,
          "and": 2, "or": 2, "not": 1, "equals": 2, "not-equals": 2, "anon": 1, "filename": 0}


def _evaluate_ros(kind: str, words: list[str], ctx: SubstitutionContext, source: Source) -> str:
    """ROS's frontend substitutions, performed by the classes of ``launch.substitutions``."""
    from launch import substitutions as subs
    from launch.context import LaunchContext

    count = _ARITY[kind]
    if kind == "command" and len(words) == 2:   # $(command 'CMD' on_stderr)
        count = 2
    if len(words) != count:
        raise LaunchError(f"$({kind}) takes {count} argument(s), got {len(words)}: {words}", source)
    context = LaunchContext(ctx.variables, current_file=ctx.current_file, environment=ctx.environ)
    if kind in ("find-pkg-share", "find-pkg-prefix"):
        from launch_ros.substitutions import FindPackagePrefix, FindPackageShare

        substitution: Any = (FindPackageShare if kind == "find-pkg-share" else FindPackagePrefix)(words[0])
    elif kind == "exec-in-pkg":
        from launch_ros.substitutions import ExecutableInPackage

        substitution = ExecutableInPackage(words[0], words[1])
    else:
        substitution = {
            "find-exec": lambda: subs.FindExecutable(name=words[0]),
            "command": lambda: subs.Command(words[0], on_stderr=words[1] if len(words) > 1 else "fail"),
            "eval": lambda: subs.PythonExpression(words[0]),
            "and": lambda: subs.AndSubstitution(*words), "or": lambda: subs.OrSubstitution(*words),
            "not": lambda: subs.NotSubstitution(words[0]), "equals": lambda: subs.EqualsSubstitution(*words),
            "not-equals": lambda: subs.NotEqualsSubstitution(*words), "anon": lambda: subs.AnonName(words[0]),
            "filename": lambda: subs.ThisLaunchFile(),
        }[kind]()
    try:
        return substitution.perform(context)
    except subs.SubstitutionFailure as exc:
        raise LaunchError(f"$({kind}): {exc}", source) from None


def _words(inner: str, source: Source) -> list[str]:
    """A substitution's words; ROS's quoting ('...' or "...") keeps spaces inside one argument."""
    kind, _, rest = inner.strip().partition(" ")
    if kind not in ROS_KINDS or not any(q in rest for q in "'\""):
        return inner.split()
    try:
        return [kind, *shlex.split(rest)]
    except ValueError as exc:
        raise LaunchError(f"$({kind} ...): {exc}", source) from None


def has_substitution(text: str) -> bool:
    return "$(" in text


def substitute(text: str, ctx: SubstitutionContext, source: Source) -> str:
    """Replace every ``$(...)`` in ``text`` (inner ones first: ``$(robot $(var robot))``); results are
    never re-scanned. Errors name the file and line of ``source``."""
    result, _ = _expand(text, 0, ctx, source, nested=False)
    return result


def _expand(text: str, pos: int, ctx: SubstitutionContext, source: Source, nested: bool) -> tuple[str, int]:
    out: list[str] = []
    quote: str | None = None
    while pos < len(text):
        if text.startswith("$$(", pos):  # "$$(" escapes a literal "$("
            out.append("$(")
            pos += 3
        elif text.startswith("$(", pos):
            inner, pos = _expand(text, pos + 2, ctx, source, nested=True)
            words = _words(inner, source)
            if not words:
                raise LaunchError("empty substitution '$()'", source)
            out.append(_evaluate(words[0], words[1:], ctx, source))
        elif nested and text[pos] == ")" and quote is None:
            return "".join(out), pos + 1
        else:
            if nested and text[pos] in "'\"":   # a ')' inside quotes does not end the substitution
                quote = None if quote == text[pos] else (text[pos] if quote is None else quote)
            out.append(text[pos])
            pos += 1
    if nested:
        raise LaunchError(f"unterminated substitution in '{text}' (missing ')')", source)
    return "".join(out), pos
