"""Orphan guard: a tiny process that kills the launcher's process groups if the launcher dies.

The launcher starts it first (before any thread exists) and writes ``+PGID`` / ``-PGID`` lines to its
stdin as node groups start and end. When stdin reaches EOF — the launcher exited, even by SIGKILL — the
groups still listed get SIGTERM and, 1.5 s later, SIGKILL: every node is gone within 2 s of its launcher
(no orphans holding ports).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

GRACE_S = 1.5


def _alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except (ProcessLookupError, PermissionError):
        return False


def _signal_all(groups: set[int], sig: int) -> None:
    for pgid in groups:
        try:
            os.killpg(pgid, sig)
        except (ProcessLookupError, PermissionError):
            pass


def main() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # only EOF on stdin ends the watch
    groups: set[int] = set()
    for raw in sys.stdin:
        line = raw.strip()
        if len(line) > 1 and line[1:].isdigit():
            pgid = int(line[1:])
            if line[0] == "+":
                groups.add(pgid)
            elif line[0] == "-":
                groups.discard(pgid)
    groups = {g for g in groups if _alive(g)}
    if not groups:
        return
    _signal_all(groups, signal.SIGTERM)
    deadline = time.monotonic() + GRACE_S
    while time.monotonic() < deadline and any(_alive(g) for g in groups):
        time.sleep(0.05)
    _signal_all({g for g in groups if _alive(g)}, signal.SIGKILL)


class Reaper:
    """The launcher's side: start the guard, tell it about groups, close it on a clean exit."""

    def __init__(self) -> None:
        self._proc = subprocess.Popen(
            [sys.executable, "-m", "launch.reaper"], stdin=subprocess.PIPE, start_new_session=True,
            cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
        )

    @property
    def pid(self) -> int:
        return self._proc.pid

    def _send(self, line: str) -> None:
        try:
            self._proc.stdin.write(line.encode() + b"\n")
            self._proc.stdin.flush()
        except (BrokenPipeError, ValueError, OSError):
            pass

    def watch(self, pgid: int) -> None:
        self._send(f"+{pgid}")

    def forget(self, pgid: int) -> None:
        self._send(f"-{pgid}")

    def close(self) -> None:
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        try:
            self._proc.wait(timeout=GRACE_S + 2)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()


if __name__ == "__main__":
    main()
