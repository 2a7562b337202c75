"""``launch_xml.launch_description_sources``: as ``launch.launch_description_sources``."""

from launch.launch_description_sources import XMLLaunchDescriptionSource

__all__ = ["XMLLaunchDescriptionSource"]
