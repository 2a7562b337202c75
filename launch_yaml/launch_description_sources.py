"""``launch_yaml.launch_description_sources``: as ``launch.launch_description_sources``."""

from launch.launch_description_sources import YAMLLaunchDescriptionSource

__all__ = ["YAMLLaunchDescriptionSource"]
