"""The ament resource index API (``get_resource``, ``get_resources`` ...) over ``AMENT_PREFIX_PATH`` and the
prefixes of installed Python distributions; the ``packages`` resource type also knows every package the
zenroid index finds (source packages included)."""

from __future__ import annotations

import os
from pathlib import Path

from nodes.packages.index import MARKERS, PackageNotFoundError, find_package, list_packages, python_prefixes

RESOURCE_INDEX_SUBFOLDER = str(MARKERS)


class InvalidResourceTypeNameError(ValueError):
    pass


class InvalidResourceNameError(ValueError):
    pass


def get_search_paths() -> list[str]:
    """The prefixes searched for resources: ``AMENT_PREFIX_PATH``, then Python distributions' prefixes."""
    paths = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    paths += [str(p) for p in python_prefixes()]
    return [p for p in dict.fromkeys(paths) if os.path.isdir(p)]


def _check(resource_type: str, resource_name: str | None = None) -> None:
    if not resource_type or "/" in resource_type:
        raise InvalidResourceTypeNameError(f"invalid resource type name '{resource_type}'")
    if resource_name is not None and (not resource_name or "/" in resource_name):
        raise InvalidResourceNameError(f"invalid resource name '{resource_name}'")


def get_resources(resource_type: str) -> dict[str, str]:
    """resource name -> prefix path, for every resource of this type."""
    _check(resource_type)
    found: dict[str, str] = {}
    if resource_type == "packages":
        found.update({name: str(package.prefix) for name, package in list_packages().items()})
    for prefix in get_search_paths():
        folder = Path(prefix) / MARKERS / resource_type
        if folder.is_dir():
            for entry in sorted(folder.iterdir()):
                if not entry.name.startswith(".") and entry.is_file():
                    found.setdefault(entry.name, prefix)
    return found


def has_resource(resource_type: str, resource_name: str) -> str | None:
    """The prefix holding the resource, or None."""
    _check(resource_type, resource_name)
    return get_resources(resource_type).get(resource_name)


def get_resource(resource_type: str, resource_name: str) -> tuple[str, str]:
    """(content, prefix) of a resource; LookupError when there is none."""
    _check(resource_type, resource_name)
    for prefix in get_search_paths():
        marker = Path(prefix) / MARKERS / resource_type / resource_name
        if marker.is_file():
            return marker.read_text(encoding="utf-8"), prefix
    if resource_type == "packages":
        try:
            return "", str(find_package(resource_name).prefix)
        except PackageNotFoundError:
            pass
    raise LookupError(f"Could not find the resource '{resource_name}' of type '{resource_type}'")


def get_resource_types() -> set[str]:
    types: set[str] = {"packages"}
    for prefix in get_search_paths():
        folder = Path(prefix) / MARKERS
        if folder.is_dir():
            types.update(p.name for p in folder.iterdir() if p.is_dir())
    return types
