"""Callback groups: ``nodes.core.executor.CallbackGroup`` under rclpy's names."""

from __future__ import annotations

from typing import Any

from nodes.core.executor import CallbackGroup as _CoreGroup


class CallbackGroup(_CoreGroup):
    def __init__(self, exclusive: bool = True) -> None:
        super().__init__(exclusive)
        self.entities: list[Any] = []

    def add_entity(self, entity: Any) -> None:
        self.entities.append(entity)

    def has_entity(self, entity: Any) -> bool:
        return entity in self.entities

    def can_execute(self, entity: Any) -> bool:
        return not (self.exclusive and self._busy)

    def beginning_execution(self, entity: Any) -> bool:
        return self.can_execute(entity)

    def ending_execution(self, entity: Any) -> None:
        return None


class MutuallyExclusiveCallbackGroup(CallbackGroup):
    """Callbacks of this group never run at the same time."""

    def __init__(self) -> None:
        super().__init__(exclusive=True)


class ReentrantCallbackGroup(CallbackGroup):
    """Callbacks of this group may run at the same time (on a MultiThreadedExecutor)."""

    def __init__(self) -> None:
        super().__init__(exclusive=False)
