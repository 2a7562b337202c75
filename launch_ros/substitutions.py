"""``launch_ros.substitutions``: packages found through zenroid's package index (``nodes.packages``)."""

from __future__ import annotations

from typing import Any

from launch.context import LaunchContext, Substitution, normalize, perform_substitutions
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution, PathOperators, SubstitutionFailure

__all__ = ["ExecutableInPackage", "FindPackage", "FindPackagePrefix", "FindPackageShare", "LaunchConfiguration",
           "PathJoinSubstitution"]


def package_share(name: str) -> str:
    from nodes.packages import PackageNotFoundError, find_share

    try:
        return str(find_share(name))
    except PackageNotFoundError as exc:
        raise SubstitutionFailure(str(exc).strip('"')) from None


class FindPackageShare(PathOperators, Substitution):
    def __init__(self, package: Any) -> None:
        self.package = normalize(package)

    def find(self, name: str) -> str:
        return package_share(name)

    def perform(self, context: LaunchContext) -> str:
        return self.find(perform_substitutions(context, self.package))

    def describe(self) -> str:
        return f"FindPackageShare({self.package!r})"


class FindPackagePrefix(FindPackageShare):
    def find(self, name: str) -> str:
        from nodes.packages import PackageNotFoundError, find_package

        try:
            return str(find_package(name).prefix)
        except PackageNotFoundError as exc:
            raise SubstitutionFailure(str(exc).strip('"')) from None


FindPackage = FindPackagePrefix


class ExecutableInPackage(Substitution):
    def __init__(self, executable: Any, package: Any) -> None:
        self.executable, self.package = normalize(executable), normalize(package)

    def perform(self, context: LaunchContext) -> str:
        from nodes.packages import find_executable

        package, name = perform_substitutions(context, self.package), perform_substitutions(context, self.executable)
        try:
            found = find_executable(package, name)
        except LookupError as exc:
            raise SubstitutionFailure(str(exc).strip('"')) from None
        return str(found.path) if found.path is not None else found.argv[-1]
