"""Run a ROS 2 Python program file as ``python FILE`` would (``zenroid run FILE``, ``ros2 run``)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path


def run_file(path: str | Path, argv: list[str] | None = None) -> int:
    """Run ``path`` as ``__main__`` with ``sys.argv = [path, *argv]`` (so ``--ros-args ...`` reach
    ``rclpy.init``); its directory comes first on ``sys.path``, as for ``python FILE``. Returns the exit code."""
    file = Path(path)
    if not file.is_file():
        raise FileNotFoundError(f"no such program file: {file}")
    saved_argv, saved_path = sys.argv, list(sys.path)
    sys.argv = [str(file), *(argv or [])]
    sys.path.insert(0, str(file.resolve().parent))
    try:
        runpy.run_path(str(file), run_name="__main__")
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    finally:
        sys.argv, sys.path[:] = saved_argv, saved_path
    return 0
