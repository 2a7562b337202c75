"""``launch.events`` of the ROS launch API: what event handlers receive, and ``Shutdown`` for ``EmitEvent``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["Event", "ProcessExited", "ProcessIO", "ProcessStarted", "Shutdown"]


class Event:
    name = "launch.events.Event"


class Shutdown(Event):
    """``EmitEvent(event=Shutdown(reason=...))``: end the launch (as the ``Shutdown`` action does)."""

    name = "launch.events.Shutdown"

    def __init__(self, *, reason: str = "reason not given", due_to_sigint: bool = False) -> None:
        self.reason = reason
        self.due_to_sigint = due_to_sigint


@dataclass
class ProcessEvent(Event):
    """What OnProcessStart / OnProcessExit / OnProcessIO callbacks get (launch.events.process's fields)."""

    action: Any = None
    name: str = ""
    cmd: list[str] | None = None
    pid: int = 0

    @property
    def process_name(self) -> str:
        return self.name

    @property
    def execute_process_action(self) -> Any:
        return self.action


@dataclass
class ProcessStarted(ProcessEvent):
    pass


@dataclass
class ProcessExited(ProcessEvent):
    returncode: int = 0


@dataclass
class ProcessIO(ProcessEvent):
    text: bytes = b""
    fd: int = 1
