"""nodes.core.realtime: ros2_control's thread_priority for a whole process (each case in a child process, as
it changes how the kernel schedules the process)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from nodes.core import realtime

ROOT = Path(__file__).resolve().parents[2]
CHILD = """
import json, os, sys, threading
from nodes.core import cpu, realtime
if sys.argv[1] == "unprivileged":
    os.setgid(65534); os.setuid(65534)   # nobody: no CAP_SYS_NICE, RLIMIT_RTPRIO 0
stop = threading.Event()
before = threading.Thread(target=stop.wait); before.start()
problem = realtime.raise_process(7)
after = threading.Thread(target=stop.wait); after.start()
threads = cpu.thread_ids()
policies = sorted({realtime.policy_of(tid) for tid in threads})
stop.set()
print(json.dumps({"problem": problem, "policies": policies, "threads": len(threads)}))
"""


def _run_child(mode: str) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, mode], cwd=ROOT, capture_output=True, text=True, timeout=60,
                         env=dict(os.environ, PYTHONPATH=str(ROOT)), check=True)
    return json.loads(out.stdout)


pytestmark = pytest.mark.skipif(not realtime.supported(), reason="SCHED_FIFO and /proc: Linux only")


def test_every_thread_and_every_later_one_runs_at_the_priority_when_permitted() -> None:
    result = _run_child("as is")
    assert result["threads"] == 3   # main, one started before, one after
    if os.geteuid() != 0 and os.getrlimit(os.RLIMIT_RTPRIO)[0] < 7:   # this user may not: refused, unchanged
        assert "Operation not permitted" in result["problem"] and result["policies"] == [["other", 0]]
        return
    assert result["problem"] is None
    assert result["threads"] == 3   # main, one started before, one after
    assert result["policies"] == [["fifo", 7]]


def test_a_refusal_says_why_and_changes_nothing() -> None:
    if os.geteuid() != 0:
        pytest.skip("needs root to drop to an unprivileged user in the child")
    result = _run_child("unprivileged")
    assert result["problem"].startswith("Operation not permitted"), result
    assert "CAP_SYS_NICE" in result["problem"] and "RLIMIT_RTPRIO of at least 7" in result["problem"]
    assert result["policies"] == [["other", 0]]


def test_priority_outside_1_to_99_is_refused() -> None:
    for bad in (0, 100, -5):
        with pytest.raises(ValueError, match="within 1..99"):
            realtime.raise_process(bad)
