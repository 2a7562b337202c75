"""A launch file's own code raised: the error names the innermost launch-file line (file:line) and keeps the
traceback for the launcher to print (exit status 1)."""

from __future__ import annotations

import traceback
from pathlib import Path

from launch.yaml_source import LaunchError, Source


class LaunchCodeError(LaunchError):
    """A launch file's own code raised: the message names the innermost launch-file frame (file:line)."""

    def __init__(self, message: str, source: Source | None, details: str) -> None:
        super().__init__(message, source)
        self.details = details   # the traceback, for the launcher to print


def launch_code_error(exc: BaseException, fallback: Source | None, what: str = "") -> LaunchCodeError:
    frames = traceback.extract_tb(exc.__traceback__)
    # the innermost frame in a launch file (or in any file that is not the launcher's own code)
    ours = (str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parent.parent / "launch_ros"))
    where = fallback
    for frame in reversed(frames):
        if frame.filename.endswith(".launch.py") or not frame.filename.startswith(ours):
            where = Source(Path(frame.filename), frame.lineno or 0)
            break
    details = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    prefix = f"{what}: " if what else ""
    return LaunchCodeError(f"{prefix}{type(exc).__name__}: {exc}", where, details)
