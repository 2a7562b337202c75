"""``launch.launch_description_sources`` of the ROS launch API: where an included launch description comes
from. Every source accepts every format the launcher reads (it recognises a file by its content)."""

from __future__ import annotations

from typing import Any

from launch.context import LaunchDescription, normalize

__all__ = ["AnyLaunchDescriptionSource", "FrontendLaunchDescriptionSource", "LaunchDescriptionSource",
           "PythonLaunchDescriptionSource", "XMLLaunchDescriptionSource", "YAMLLaunchDescriptionSource"]


class LaunchDescriptionSource:
    def __init__(self, launch_description: Any = None, location: Any = "<string>", method: str = "") -> None:
        if isinstance(launch_description, LaunchDescription):
            self.description: LaunchDescription | None = launch_description
            self.location = normalize(location)
        else:   # a path (string, substitution, list of them)
            self.description = None
            self.location = normalize(launch_description if launch_description is not None else location)
        self.method = method


class PythonLaunchDescriptionSource(LaunchDescriptionSource):
    def __init__(self, launch_file_path: Any) -> None:
        super().__init__(launch_file_path, method="interpreted python launch file")


class AnyLaunchDescriptionSource(LaunchDescriptionSource):
    def __init__(self, launch_file_path: Any) -> None:
        super().__init__(launch_file_path, method="launch file")


class FrontendLaunchDescriptionSource(AnyLaunchDescriptionSource):
    pass


class XMLLaunchDescriptionSource(AnyLaunchDescriptionSource):
    pass


class YAMLLaunchDescriptionSource(AnyLaunchDescriptionSource):
    pass
