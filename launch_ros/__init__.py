"""zenroid's ``launch_ros``: the ROS-specific launch actions (``Node``, containers, namespaces, parameters)
and substitutions (``FindPackageShare``) over the launcher in ``launch`` (docs/ros-launch.md)."""

from launch_ros import (  # noqa: F401
    actions,
    descriptions,
    event_handlers,
    events,
    parameter_descriptions,
    substitutions,
)
