"""``launch.utilities`` of the ROS launch API: the helpers launch files call in their OpaqueFunctions."""

from __future__ import annotations

from typing import Any

from launch.context import LaunchContext, normalize, perform_substitutions

__all__ = ["normalize_to_list_of_substitutions", "perform_substitutions", "perform_typed_substitution"]


def normalize_to_list_of_substitutions(value: Any) -> list[Any]:
    from launch.substitutions import TextSubstitution

    return [TextSubstitution(text=v) if isinstance(v, str) else v for v in normalize(value)]


def perform_typed_substitution(context: LaunchContext, value: Any, data_type: Any = None) -> Any:
    text = perform_substitutions(context, normalize(value))
    return data_type(text) if data_type not in (None, str) else text
