"""What an action client and an action server share: a callback group, a place among the node's waitables,
their action type, and being destroyed through the node."""

from __future__ import annotations

from typing import Any


class ActionEndpoint:
    _node: Any
    _action_type: Any
    _core: Any

    def _attach(self, callback_group: Any) -> None:
        """Join the node: the callback group ``callback_group`` (the node's default when None) and its waitables."""
        self.callback_group = self._node._zr_group(callback_group)
        self._node._zr_entities["waitables"].append(self)

    @property
    def action_type(self) -> Any:
        return self._action_type

    def destroy(self) -> None:
        if self in self._node._zr_entities["waitables"]:
            self._node._zr_entities["waitables"].remove(self)
            self._node._zr.destroy_entity(self._core)
