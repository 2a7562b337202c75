"""``python -m nodes.sim``: the simulator process (see nodes/sim/node.py)."""

from __future__ import annotations

import sys

from nodes.core import run_node
from nodes.sim.node import SimulatorNode


def main(argv: list[str] | None = None) -> int:
    return run_node(SimulatorNode, argv)


if __name__ == "__main__":
    sys.exit(main())
