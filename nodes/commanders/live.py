"""Run-time parameter changes in the commanders: what applies at once, and the reason for what cannot.

Every commander applies its parameters live through ``Node.add_on_set_parameter_callback`` (``zenroid param
set /humanoid/joint_commander period 1.0`` takes effect at the next command) and declares the few it only
reads at start-up read-only with ``RESTART`` as the reason, so ``param set`` refuses them instead of
answering "successful" while nothing changes.
"""

from __future__ import annotations

from typing import Any

RESTART = "set at start-up: restart the node with --param {name}:=VALUE"


def restart(name: str) -> str:
    return RESTART.format(name=name)


def declare_controller(node: Any, description: str) -> str:
    """The ``controller`` parameter of a commander: the trajectory controller it commands, read at start-up."""
    return node.declare_parameter("controller", "joint_trajectory_controller", description=description,
                                  read_only=restart("controller"))
