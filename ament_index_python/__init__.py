"""zenroid's ``ament_index_python``: ROS's package lookup API answered from zenroid's package index
(``nodes.packages``: the workspace's src/, ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, Python distributions
with an ament index, and the packages zenroid serves). Where ROS 2 is sourced, the real module comes first
on PYTHONPATH."""

from ament_index_python.packages import (
    PackageNotFoundError,
    get_package_prefix,
    get_package_share_directory,
    get_package_share_path,
    get_packages_with_prefixes,
)
from ament_index_python.resources import (
    InvalidResourceNameError,
    InvalidResourceTypeNameError,
    get_resource,
    get_resource_types,
    get_resources,
    get_search_paths,
    has_resource,
)

__all__ = [
    "InvalidResourceNameError", "InvalidResourceTypeNameError", "PackageNotFoundError", "get_package_prefix",
    "get_package_share_directory", "get_package_share_path", "get_packages_with_prefixes", "get_resource",
    "get_resource_types", "get_resources", "get_search_paths", "has_resource",
]
