"""``launch.conditions`` of the ROS launch API: ``condition=`` of an action, evaluated when it is resolved."""

from __future__ import annotations

from typing import Any

from launch.context import Condition, LaunchContext, normalize, perform_substitutions
from launch.substitutions import SubstitutionFailure

__all__ = ["Condition", "IfCondition", "InvalidConditionExpressionError", "LaunchConfigurationEquals",
           "LaunchConfigurationNotEquals", "UnlessCondition"]


class InvalidConditionExpressionError(SubstitutionFailure):
    """A condition whose text is not true/false/1/0."""


def evaluate_condition_expression(context: LaunchContext, expression: list[Any]) -> bool:
    text = perform_substitutions(context, expression)
    lowered = text.strip().lower()
    if lowered in ("true", "1"):
        return True
    if lowered in ("false", "0"):
        return False
    raise InvalidConditionExpressionError(f"condition expression '{text}' is not one of true, false, 1, 0")


class IfCondition(Condition):
    def __init__(self, predicate_expression: Any) -> None:
        self.predicate_expression = normalize(predicate_expression)
        super().__init__()

    def evaluate(self, context: LaunchContext) -> bool:
        return evaluate_condition_expression(context, self.predicate_expression)


class UnlessCondition(IfCondition):
    def evaluate(self, context: LaunchContext) -> bool:
        return not super().evaluate(context)


class LaunchConfigurationEquals(Condition):
    def __init__(self, launch_configuration_name: str, expected_value: Any) -> None:
        self.name = launch_configuration_name
        self.expected = None if expected_value is None else normalize(expected_value)
        super().__init__()

    def evaluate(self, context: LaunchContext) -> bool:
        expected = None if self.expected is None else perform_substitutions(context, self.expected)
        if self.name not in context.launch_configurations:
            if expected is None:
                return True
            raise SubstitutionFailure(f"launch configuration '{self.name}' does not exist")
        return context.launch_configurations[self.name] == expected


class LaunchConfigurationNotEquals(LaunchConfigurationEquals):
    def evaluate(self, context: LaunchContext) -> bool:
        return not super().evaluate(context)
