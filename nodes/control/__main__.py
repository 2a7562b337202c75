"""``python -m nodes.control --ns humanoid --params-file config/controllers.yaml``: the controller manager."""

from __future__ import annotations

import sys

from nodes.control.node import ControllerManagerNode
from nodes.core import run_node


def main(argv: list[str] | None = None) -> int:
    return run_node(ControllerManagerNode, argv)


if __name__ == "__main__":
    sys.exit(main())
