"""``from msgs.sensor_msgs import JointState``: a module per ROS message package, made when imported.

The modules are not files: a finder answers ``msgs.<pkg>`` for every package on the definition search
paths (user packages added with ``msgs.add_search_path`` included), and each module looks its names up in
the registry, so a package never needs a hand-written module of its own.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import Any

from msgs.registry import get_type, package_names

PARENT = "msgs"


def _package_getattr(package: str):  # noqa: ANN202 - a module-level __getattr__
    def __getattr__(name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        try:
            return get_type(f"{package}/{name}")
        except KeyError as exc:
            raise AttributeError(str(exc)) from None
    return __getattr__


class PackageFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds ``msgs.<pkg>`` for message packages; asked last, after the real modules of ``msgs``."""

    def find_spec(self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None) -> Any:
        parent, dot, package = fullname.partition(".")
        if parent != PARENT or not dot or "." in package or package not in package_names():
            return None
        return importlib.util.spec_from_loader(fullname, self, origin=f"message package {package}")

    def create_module(self, spec: Any) -> None:
        return None  # the default module object

    def exec_module(self, module: ModuleType) -> None:
        package = module.__name__.rpartition(".")[2]
        module.__doc__ = f"Message types of the ROS package ``{package}`` (``from {module.__name__} import Name``)."
        module.__getattr__ = _package_getattr(package)  # type: ignore[attr-defined]


def install() -> None:
    if not any(isinstance(finder, PackageFinder) for finder in sys.meta_path):
        sys.meta_path.append(PackageFinder())
