"""zenroid's ``launch_ros``: the ROS-specific launch actions (``Node``, containers, namespaces, parameters)
and substitutions (``FindPackageShare``) over the launcher in ``launch`` (docs/ros-launch.md)."""

from launch_ros import actions, descriptions, parameter_descriptions, substitutions  # noqa: F401
