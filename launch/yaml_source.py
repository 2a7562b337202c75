"""Safe YAML loading that remembers where every key and list item came from (for file:line errors).

Only plain YAML types are built (safe_load level): mappings become ``LocatedDict`` and sequences
``LocatedList``, which carry the 1-based line of the container and of each key / item.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml


@dataclass(frozen=True)
class Source:
    """A place in a launch file, printed as ``file:line``."""

    file: Path
    line: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}"


class LaunchError(Exception):
    """A bad launch description: one message naming the file and line; nothing is started."""

    def __init__(self, message: str, source: Source | None = None) -> None:
        self.message = message
        self.source = source
        super().__init__(f"{source}: {message}" if source else message)


class LocatedDict(dict):
    """A mapping that knows the line of itself and of each of its keys."""

    line: int = 0
    key_lines: dict[Any, int]

    def line_of(self, key: Any) -> int:
        return self.key_lines.get(key, self.line)


class LocatedList(list):
    """A sequence that knows the line of itself and of each item."""

    line: int = 0
    item_lines: list[int]

    def line_of(self, index: int) -> int:
        return self.item_lines[index] if 0 <= index < len(self.item_lines) else self.line


class _LocatingLoader(yaml.SafeLoader):
    """SafeLoader whose maps/lists record source lines and whose duplicate keys are errors."""


def _construct_mapping(loader: _LocatingLoader, node: yaml.MappingNode) -> LocatedDict:
    loader.flatten_mapping(node)  # resolves "<<" merge keys like SafeLoader does
    result = LocatedDict()
    result.line = node.start_mark.line + 1
    result.key_lines = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        line = key_node.start_mark.line + 1
        try:
            hash(key)
        except TypeError:
            raise LaunchError(f"a mapping key must be a scalar, not {type(key).__name__}",
                              Source(Path(loader.name), line)) from None
        if key in result:
            raise LaunchError(f"duplicate key '{key}' (first at line {result.key_lines[key]})",
                              Source(Path(loader.name), line))
        result[key] = loader.construct_object(value_node, deep=True)
        result.key_lines[key] = line
    return result


def _construct_sequence(loader: _LocatingLoader, node: yaml.SequenceNode) -> LocatedList:
    result = LocatedList(loader.construct_object(child, deep=True) for child in node.value)
    result.line = node.start_mark.line + 1
    result.item_lines = [child.start_mark.line + 1 for child in node.value]
    return result


_LocatingLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_LocatingLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def load_located(path: Path) -> Any:
    """Load one YAML document from ``path``; YAML syntax errors become ``LaunchError`` with the line."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise LaunchError(f"launch file not found: {path}") from None
    except OSError as exc:
        raise LaunchError(f"cannot read launch file {path}: {exc.strerror}") from None
    return loads_located(text, path)


def loads_located(text: str, path: Path) -> Any:
    loader = _LocatingLoader(text)
    loader.name = str(path)
    try:
        return loader.get_single_data()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else 0
        reason = exc.problem or exc.context or "invalid YAML"
        raise LaunchError(f"invalid YAML: {reason}", Source(path, line)) from None
    except yaml.YAMLError as exc:
        raise LaunchError(f"invalid YAML: {exc}", Source(path, 0)) from None
    finally:
        loader.dispose()
