"""nodes.core.cpu: the stepping thread alone on its CPU, every other thread (also later ones) off it.

Run in a child process: claiming and sweeping change the affinity of every thread of the process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

CHILD = r"""
import json, os, threading
from nodes.core.cpu import ExclusiveCpu
exclusive = ExclusiveCpu.from_environment()
idle = threading.Event()
early = threading.Thread(target=idle.wait, name="early")     # exists before the claim
early.start()
out = {}
def stepping():
    exclusive.claim()
    late = threading.Thread(target=idle.wait, name="late")   # started by the claimed thread: inherits its CPU
    late.start()
    out["late_before_sweep"] = sorted(os.sched_getaffinity(late.native_id))
    exclusive.sweep()
    out["late_after_sweep"] = sorted(os.sched_getaffinity(late.native_id))
    out["stepping"] = sorted(os.sched_getaffinity(0))
    out["early"] = sorted(os.sched_getaffinity(early.native_id))
    out["main"] = sorted(os.sched_getaffinity(os.getpid()))
    idle.set()
    late.join()
worker = threading.Thread(target=stepping)
worker.start(); worker.join(); early.join()
print(json.dumps(out))
"""


def run_child(value: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), ZENROID_EXCLUSIVE_CPU=value)
    return subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, timeout=60)


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="needs two CPUs to keep one")
def test_claim_keeps_the_cpu_for_the_claiming_thread_and_sweep_moves_later_threads_off() -> None:
    cpus = sorted(os.sched_getaffinity(0))
    kept, rest = cpus[-1], cpus[:-1]
    done = run_child(str(kept))
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out["stepping"] == [kept]
    assert out["early"] == rest and out["main"] == rest
    assert out["late_before_sweep"] == [kept]          # why the simulator sweeps once a second
    assert out["late_after_sweep"] == rest


def test_a_bad_cpu_in_the_environment_is_a_clear_error() -> None:
    for value, fragment in (("two", "must be a CPU number, got 'two'"), ("4096", "this machine has CPUs 0..")):
        done = run_child(value)
        assert done.returncode != 0 and fragment in done.stderr, done.stderr


def test_a_second_process_does_not_get_the_reservation_until_the_first_ends() -> None:
    # (in child processes: the test process itself must not hold it, integration tests launch lockstep jobs)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    holder = subprocess.Popen([sys.executable, "-c", "import sys; from nodes.core.cpu import hold_reservation; "
                               "print(hold_reservation(), flush=True); sys.stdin.read()"],
                              env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "True"
        probe = [sys.executable, "-c", "from nodes.core.cpu import hold_reservation; print(hold_reservation())"]
        assert subprocess.run(probe, env=env, capture_output=True, text=True, timeout=60).stdout.strip() == "False"
    finally:
        holder.stdin.close()
        holder.wait(30)
    assert subprocess.run(probe, env=env, capture_output=True, text=True, timeout=60).stdout.strip() == "True"
