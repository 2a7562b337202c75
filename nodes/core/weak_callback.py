"""Callbacks handed to Zenoh that do not keep their object alive.

Zenoh drops an undeclared entity's callback on its own thread, some time after the undeclare. A bound method
handed to it keeps its object (an endpoint, a ROS 2 twin, and through them their owner's callbacks) alive
past ``destroy()``, in a cycle through native code that Python's cyclic GC cannot see: a deleted robot's
endpoints would then linger until Zenoh lets go."""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import Any


def weak_callback(method: Callable[..., Any]) -> Callable[..., None]:
    """``method`` (a bound method) called while its object lives; a no-op after."""
    ref = weakref.WeakMethod(method)

    def call(*args: Any) -> None:
        target = ref()
        if target is not None:
            target(*args)
    return call
