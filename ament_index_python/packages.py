"""``ament_index_python.packages`` as ROS spells it, from zenroid's package index."""

from __future__ import annotations

import warnings
from pathlib import Path

from nodes.packages.index import PackageNotFoundError, find_package, list_packages

__all__ = ["PackageNotFoundError", "get_package_prefix", "get_package_share_directory", "get_package_share_path",
           "get_packages_with_prefixes"]


def get_packages_with_prefixes() -> dict[str, str]:
    """Every known package name -> its prefix (a source package's own folder)."""
    return {name: str(package.prefix) for name, package in list_packages().items()}


def get_package_prefix(package_name: str) -> str:
    """The install prefix of ``package_name``; PackageNotFoundError names it and the paths searched."""
    if "/" in package_name or "\\" in package_name:
        raise ValueError(f"'{package_name}' is not a valid package name")
    return str(find_package(package_name).prefix)


def get_package_share_directory(package_name: str, print_warning: bool = True) -> str:
    """The share directory of ``package_name`` (``<prefix>/share/<pkg>``, or a source package's folder)."""
    if "/" in package_name or "\\" in package_name:
        raise ValueError(f"'{package_name}' is not a valid package name")
    share = find_package(package_name).share
    if print_warning and not share.is_dir():
        warnings.warn(f"Share directory for {package_name} ({share}) does not exist.", stacklevel=2)
    return str(share)


def get_package_share_path(package_name: str, print_warning: bool = True) -> Path:
    return Path(get_package_share_directory(package_name, print_warning=print_warning))
