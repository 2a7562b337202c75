"""The launcher (``python -m launch FILE``) and zenroid's face of the ROS launch API.

Our YAML launch files are parsed safely with file:line errors (``yaml_source``, ``description``), substituted
(``_yaml_substitutions``), resolved into a plan (``resolve``) and their processes supervised
(``supervisor``, ``readiness``, ``reaper``). ROS's formats (``formats``: Python, XML, ROS YAML) build the
ROS launch actions of ``actions``, ``substitutions``, ``conditions``, ``event_handlers`` and
``launch_description_sources`` (with ``launch_ros``), which resolve into the same plan (docs/ros-launch.md).
"""

from __future__ import annotations

import importlib
from typing import Any

# ROS's `import launch; launch.LaunchDescription(...)`, `launch.actions.X`: loaded on first use, so the
# launcher's own start (python -m launch humanoid.yaml) does not import the ROS API.
_FROM_CONTEXT = ("LaunchContext", "LaunchDescription", "LaunchDescriptionEntity", "Action", "Condition", "Substitution")
_SUBMODULES = ("actions", "conditions", "event_handlers", "events", "launch_description_sources", "substitutions",
               "frontend")


def __getattr__(name: str) -> Any:
    if name in _FROM_CONTEXT:
        return getattr(importlib.import_module("launch.context"), name)
    if name in _SUBMODULES:
        return importlib.import_module(f"launch.{name}")
    if name == "EventHandler":
        return importlib.import_module("launch.event_handlers").EventHandler
    if name == "LaunchDescriptionSource":
        return importlib.import_module("launch.launch_description_sources").LaunchDescriptionSource
    if name == "SomeSubstitutionsType":
        return Any
    raise AttributeError(f"module 'launch' has no attribute '{name}'")
