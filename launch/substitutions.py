"""Launch substitutions: ``$(var NAME)``, ``$(env NAME [default])``, ``$(dirname)``, ``$(robot NAME)``.

Pure text replacement, never evaluation. Substitutions do not nest; ``$$(`` is a literal ``$(``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from launch.yaml_source import LaunchError, Source

KINDS = ("var", "env", "dirname", "robot")


@dataclass
class SubstitutionContext:
    """What substitutions can see: the launch arguments in scope and the current file."""

    variables: Mapping[str, str]
    current_file: Path
    environ: Mapping[str, str] | None = None
    robot_resolver: Callable[[str], Path] | None = None


def _default_robot_resolver(name: str) -> Path:
    from nodes.core.paths import robot_path

    return robot_path(name)


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
    raise LaunchError(f"unknown substitution '$({kind})' (known: {', '.join(KINDS)})", source)


def has_substitution(text: str) -> bool:
    return "$(" in text


def substitute(text: str, ctx: SubstitutionContext, source: Source) -> str:
    """Replace every ``$(...)`` in ``text``; errors name the file and line of ``source``."""
    out: list[str] = []
    i = 0
    while True:
        start = text.find("$(", i)
        if start < 0:
            out.append(text[i:])
            return "".join(out)
        if start > 0 and text[start - 1] == "$":  # "$$(" escapes a literal "$("
            out.append(text[i:start - 1] + "$(")
            i = start + 2
            continue
        end = text.find(")", start)
        if end < 0:
            raise LaunchError(f"unterminated substitution in '{text}' (missing ')')", source)
        inner = text[start + 2:end]
        if "$(" in inner:
            raise LaunchError(f"nested substitutions are not supported: '{text[start:end + 1]}'", source)
        words = inner.split()
        if not words:
            raise LaunchError("empty substitution '$()'", source)
        out.append(text[i:start])
        out.append(_evaluate(words[0], words[1:], ctx, source))
        i = end + 1
