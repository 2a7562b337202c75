"""``from std_msgs.msg import String`` with no ROS: interface packages under the names ROS gives them.

Installed at interpreter start by ``zenroid-interfaces.pth`` (setup.py puts it beside the installed packages,
editable installs included), and by ``import msgs``. It is a meta path finder asked *last*: a module the
regular import system finds (a sourced ROS 2's real ``std_msgs`` on PYTHONPATH) always wins, as it should.

For a name no one else found, ``<pkg>``, ``<pkg>.msg``, ``<pkg>.srv`` and ``<pkg>.action`` are made when
``<pkg>`` is an interface package that ``msgs`` knows: one of its definitions, a folder on ``ZENROID_MSG_PATH``
or ``msgs.add_search_path``, or a package of the package index (the workspace's ``src/``, ROS_PACKAGE_PATH,
AMENT_PREFIX_PATH) holding ``msg/``, ``srv/`` or ``action/``. The names in ``<pkg>.msg`` are the very classes
of ``msgs.<pkg>`` (``msgs.get_type``), so ``isinstance`` holds both ways.

This module only uses the standard library at start-up; ``msgs`` is imported when a type is first looked up.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import os
import sys
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import Any

KINDS = ("msg", "srv", "action")
# never interface packages; site imports sitecustomize and usercustomize at every start-up, and asking the
# package index about them would import ``nodes`` before a test's or a program's sys.path is set up
NOT_INTERFACES = ("msgs", "nodes", "launch", "rclpy", "sitecustomize", "usercustomize")
ENV_PATH = "ZENROID_MSG_PATH"


def _builtin_definitions() -> str | None:
    """msgs/definitions, found without importing msgs."""
    try:
        spec = importlib.util.find_spec("msgs")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return os.path.join(list(spec.submodule_search_locations)[0], "definitions")


def _roots() -> list[str]:
    roots = [p for p in os.environ.get(ENV_PATH, "").split(os.pathsep) if p]
    search_paths = getattr(sys.modules.get("msgs.registry"), "search_paths", None)
    if search_paths is not None:   # msgs.add_search_path folders, once msgs is loaded
        roots += [str(p) for p in search_paths()]
    else:
        builtin = _builtin_definitions()
        roots += [builtin] if builtin else []
    return roots


def _in_index(name: str) -> bool:
    try:
        from nodes.packages import index
    except ImportError:
        return False
    lock = getattr(index, "_lock", None)
    if lock is not None and lock.locked():
        # a scan is under way, maybe on this very thread, importing something nobody has: asking the index
        # again would wait for itself
        return False
    package = index.list_packages().get(name)
    return package is not None and any(os.path.isdir(os.path.join(package.share, k)) for k in KINDS)


def is_interface_package(name: str) -> bool:
    """True when ``name`` is an interface package msgs can load (cheap folder checks first, then the index)."""
    if not name.isidentifier() or name in NOT_INTERFACES:
        return False
    for root in _roots():
        if any(os.path.isdir(os.path.join(root, name, kind)) for kind in KINDS):
            return True
    return _in_index(name)


def _types_of(package: str, kind: str) -> list[str]:
    import msgs

    prefix = f"{package}/{kind}/"
    return [t[len(prefix):] for t in msgs.list_types() if t.startswith(prefix)]


def _kind_getattr(package: str, kind: str) -> Callable[[str], Any]:
    def __getattr__(name: str) -> Any:
        if name == "__all__":
            return _types_of(package, kind)
        if name.startswith("_"):
            raise AttributeError(f"module '{package}.{kind}' has no attribute '{name}'")
        import msgs

        try:
            return msgs.get_type(f"{package}/{kind}/{name}")
        except KeyError:
            raise AttributeError(f"module '{package}.{kind}' has no {package}/{kind}/{name} definition (known: "
                                 f"{', '.join(_types_of(package, kind)) or 'none'})") from None

    return __getattr__


def _package_getattr(package: str) -> Callable[[str], Any]:
    def __getattr__(name: str) -> Any:
        if name in KINDS:
            return importlib.import_module(f"{package}.{name}")
        raise AttributeError(f"module '{package}' has no attribute '{name}'")

    return __getattr__


class InterfaceFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """``<pkg>``, ``<pkg>.msg``/``.srv``/``.action`` for the interface packages nobody else provides."""

    def find_spec(self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None) -> Any:
        package, dot, kind = fullname.partition(".")
        if dot and kind not in KINDS:
            return None
        if dot and package not in sys.modules:
            return None   # the parent is imported first; if it is not ours, neither is this
        if dot and not isinstance(getattr(sys.modules[package], "__loader__", None), InterfaceFinder):
            return None
        try:
            if not dot and not is_interface_package(package):
                return None
        except Exception:  # noqa: BLE001 - asked for every name nobody else has: it must never break an import
            return None
        return importlib.util.spec_from_loader(fullname, self, origin=f"zenroid interface package {package}",
                                               is_package=not dot)

    def create_module(self, spec: Any) -> None:
        return None   # the default module object

    def exec_module(self, module: ModuleType) -> None:
        package, dot, kind = module.__name__.partition(".")
        if dot:
            module.__doc__ = f"The {kind} types of the ROS package {package} (the classes of msgs.{package})."
            module.__getattr__ = _kind_getattr(package, kind)  # type: ignore[attr-defined]
        else:
            module.__doc__ = f"The ROS interface package {package}, served by zenroid (msgs)."
            module.__getattr__ = _package_getattr(package)  # type: ignore[attr-defined]


def install() -> None:
    """Append the finder to ``sys.meta_path`` once (a ``.pth`` line runs this; it must never fail start-up)."""
    try:
        if not any(isinstance(finder, InterfaceFinder) for finder in sys.meta_path):
            sys.meta_path.append(InterfaceFinder())
    except Exception:  # noqa: BLE001, S110 - an interpreter must start whatever happens here
        pass
