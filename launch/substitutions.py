"""Launch substitutions: ``$(var NAME)``, ``$(env NAME [default])``, ``$(dirname)``, ``$(robot NAME)``,
``$(config NAME)``.

Pure text replacement, never evaluation. Substitutions nest; ``$$(`` is a literal ``$(``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from launch.yaml_source import LaunchError, Source

KINDS = ("var", "env", "dirname", "robot", "config")


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
    raise LaunchError(f"unknown substitution '$({kind})' (known: {', '.join(KINDS)})", source)


def has_substitution(text: str) -> bool:
    return "$(" in text


def substitute(text: str, ctx: SubstitutionContext, source: Source) -> str:
    """Replace every ``$(...)`` in ``text`` (inner ones first: ``$(robot $(var robot))``); results are
    never re-scanned. Errors name the file and line of ``source``."""
    result, _ = _expand(text, 0, ctx, source, nested=False)
    return result


def _expand(text: str, pos: int, ctx: SubstitutionContext, source: Source, nested: bool) -> tuple[str, int]:
    out: list[str] = []
    while pos < len(text):
        if text.startswith("$$(", pos):  # "$$(" escapes a literal "$("
            out.append("$(")
            pos += 3
        elif text.startswith("$(", pos):
            inner, pos = _expand(text, pos + 2, ctx, source, nested=True)
            words = inner.split()
            if not words:
                raise LaunchError("empty substitution '$()'", source)
            out.append(_evaluate(words[0], words[1:], ctx, source))
        elif nested and text[pos] == ")":
            return "".join(out), pos + 1
        else:
            out.append(text[pos])
            pos += 1
    if nested:
        raise LaunchError(f"unterminated substitution in '{text}' (missing ')')", source)
    return "".join(out), pos
