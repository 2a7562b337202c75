"""``python -m nodes.render``: the CPU renderer of cameras, depth cameras, lidars and lasers (nodes/render/node.py)."""

from __future__ import annotations

import os
import sys

# numpy's matrix products on (N, 3) arrays would start OpenBLAS threads that spin on the core the physics
# needs (a frame's CPU time doubled): the renderer's parallelism is its own ray-casting threads
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from nodes.core import run_node  # noqa: E402 - after the thread setting above
from nodes.render.node import RendererNode  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    return run_node(RendererNode, argv)


if __name__ == "__main__":
    sys.exit(main())
