"""``zenroid launch FILE``: our launcher, also inside a sourced ROS 2 environment.

A sourced ROS 2 puts its own ``launch`` package (the one behind ``ros2 launch``) on PYTHONPATH, ahead of
site-packages, so ``import launch`` finds ROS's and ``python -m launch`` fails. This verb loads the
``launch`` package installed next to ``nodes`` (same distribution) under its own name before anything
imports ROS's, so ``zenroid launch`` works either way; ROS's package stays untouched on disk.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import nodes
from nodes.tools.errors import Failed

# Our launcher package sits beside ``nodes`` wherever the distribution lives (site-packages or a checkout).
OUR_LAUNCH = Path(nodes.__file__).resolve().parent.parent / "launch" / "__init__.py"


def _is_ours(module: ModuleType | None) -> bool:
    origin = getattr(module, "__file__", None)
    return origin is not None and Path(origin).resolve() == OUR_LAUNCH


def launcher() -> ModuleType:
    """``launch.cli`` of this distribution, whatever package named ``launch`` comes first on sys.path."""
    loaded = sys.modules.get("launch")
    if loaded is None:
        spec = importlib.util.find_spec("launch")
        if spec is not None and spec.origin is not None and Path(spec.origin).resolve() == OUR_LAUNCH:
            importlib.import_module("launch")
        else:  # another ``launch`` (ROS 2's) shadows ours: bind ours to the name in this process
            spec = importlib.util.spec_from_file_location("launch", OUR_LAUNCH,
                                                          submodule_search_locations=[str(OUR_LAUNCH.parent)])
            if spec is None or spec.loader is None:
                raise Failed(f"cannot load the launcher from {OUR_LAUNCH}")
            module = importlib.util.module_from_spec(spec)
            sys.modules["launch"] = module
            spec.loader.exec_module(module)
    elif not _is_ours(loaded):
        raise Failed(f"another 'launch' package is already imported ({loaded.__file__})")
    return importlib.import_module("launch.cli")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    launcher().add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    return launcher().run(args)
