"""ROS packages without a build: the index (where each package's share folder is), their executables, and
the packages the zenroid stack serves (docs/packages.md)."""

from nodes.packages.executables import Executable, ExecutableNotFoundError, executables, find_executable
from nodes.packages.index import (
    Package,
    PackageNotFoundError,
    UriError,
    find_package,
    find_share,
    list_packages,
    refresh,
    resolve_uri,
)

__all__ = ["Executable", "ExecutableNotFoundError", "Package", "PackageNotFoundError", "UriError", "executables",
           "find_executable", "find_package", "find_share", "list_packages", "refresh", "resolve_uri"]
