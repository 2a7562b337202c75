"""bench/common.py's process groups: a script that dies by SIGTERM or SIGINT takes what it started with it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from bench.common import alive, child_env, wait_until
from tests.conftest import ROOT

# A stand-in for a bench: starts a long-running child the way a bench starts its launch, prints its pid,
# and waits to be ended. The child ignores nothing: SIGINT to its group ends it.
STARTS_A_CHILD = r"""
import sys, time
from bench.common import spawn
child = spawn([sys.executable, "-c", "import time; time.sleep(120)"])
print(child.pid, flush=True)
"""


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_script_ended_by_a_signal_stops_what_it_spawned(signum: int) -> None:
    script = subprocess.Popen([sys.executable, "-c", STARTS_A_CHILD + "time.sleep(120)\n"], cwd=ROOT, env=child_env(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        child = int(script.stdout.readline())
        assert alive(child)
        script.send_signal(signum)
        status = script.wait(30)
        # ended as the signal ends it (SIGINT: Python's KeyboardInterrupt, which exits by the signal too)
        assert status == -signum, (status, script.stderr.read()[-2000:])
        wait_until(lambda: not alive(child), 5, "the spawned child to end")
    finally:
        if script.poll() is None:
            os.killpg(script.pid, signal.SIGKILL)
            script.wait()


def test_a_script_that_returns_without_stopping_stops_what_it_spawned() -> None:
    result = subprocess.run([sys.executable, "-c", STARTS_A_CHILD], cwd=ROOT, env=child_env(), capture_output=True,
                            text=True, timeout=60)
    child = int(result.stdout.split()[0])
    assert result.returncode == 0, result.stderr
    assert not alive(child), "the child outlived the script that started it"
