"""Managed (lifecycle) nodes: unconfigured → inactive → active → finalized, with the ROS 2 services."""

from __future__ import annotations

from typing import Any

from msgs.lifecycle_msgs import ChangeState, GetState, State
from nodes.core.node import Node

UNCONFIGURED, INACTIVE, ACTIVE, FINALIZED = 1, 2, 3, 4
STATE_LABELS = {0: "unknown", 1: "unconfigured", 2: "inactive", 3: "active", 4: "finalized"}
# transition id -> (label, from states, hook name, state on success)
TRANSITIONS: dict[int, tuple[str, tuple[int, ...], str, int]] = {
    1: ("configure", (UNCONFIGURED,), "on_configure", INACTIVE),
    2: ("cleanup", (INACTIVE,), "on_cleanup", UNCONFIGURED),
    3: ("activate", (INACTIVE,), "on_activate", ACTIVE),
    4: ("deactivate", (ACTIVE,), "on_deactivate", INACTIVE),
    5: ("shutdown", (UNCONFIGURED,), "on_shutdown", FINALIZED),
    6: ("shutdown", (INACTIVE,), "on_shutdown", FINALIZED),
    7: ("shutdown", (ACTIVE,), "on_shutdown", FINALIZED),
}


class LifecycleNode(Node):
    """Override ``on_configure``/``on_activate``/``on_deactivate``/``on_cleanup``/``on_shutdown``;
    each returns True (success) or False (failure: the state does not change)."""

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.state = UNCONFIGURED
        self.create_service(GetState, "~/get_state", self._srv_get_state)
        self.create_service(ChangeState, "~/change_state", self._srv_change_state)

    @property
    def state_label(self) -> str:
        return STATE_LABELS[self.state]

    def on_configure(self) -> bool:
        return True

    def on_activate(self) -> bool:
        return True

    def on_deactivate(self) -> bool:
        return True

    def on_cleanup(self) -> bool:
        return True

    def on_shutdown(self) -> bool:
        return True

    def trigger(self, transition: int | str) -> bool:
        """Run a transition by id or label ("configure", "activate", ...). False if refused or failed."""
        if isinstance(transition, str):
            matches = [tid for tid, t in TRANSITIONS.items() if t[0] == transition and self.state in t[1]]
            if not matches:
                self.logger.warn(f"transition '{transition}' is not valid from state '{self.state_label}'")
                return False
            transition = matches[0]
        spec = TRANSITIONS.get(transition)
        if spec is None or self.state not in spec[1]:
            self.logger.warn(f"transition {transition} is not valid from state '{self.state_label}'")
            return False
        label, _, hook, target = spec
        try:
            ok = getattr(self, hook)()
        except Exception as exc:  # noqa: BLE001 - a failing hook is an error transition
            self.logger.error(f"{hook} raised {type(exc).__name__}: {exc}")
            ok = False
        if ok is False:
            self.logger.warn(f"transition '{label}' failed in state '{self.state_label}'")
            return False
        self.state = target
        self.logger.info(f"transition '{label}' → {self.state_label}")
        return True

    def _srv_get_state(self, request: Any) -> Any:
        return GetState.Response(current_state=State(id=self.state, label=self.state_label))

    def _srv_change_state(self, request: Any) -> Any:
        tid = request.transition.id
        label = request.transition.label
        ok = self.trigger(label if (tid == 0 and label) else tid)
        return ChangeState.Response(success=ok)
