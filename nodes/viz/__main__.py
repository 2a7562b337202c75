"""``python -m nodes.viz``: the viewer (shared node options plus --save / --serve / --spawn)."""

from __future__ import annotations

import argparse
import sys

from nodes.core import run_node

from .node import Viewer, add_arguments


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m nodes.viz", description=Viewer.__doc__)
    add_arguments(parser)
    return run_node(Viewer, argv, parser=parser)


if __name__ == "__main__":
    sys.exit(main())
