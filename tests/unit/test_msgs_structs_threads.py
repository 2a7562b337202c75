"""msgspec's fast decoders used from many threads at once, first use included (msgs.structs): each of 8 threads
decodes a fresh process's very first JointTrajectory messages together. Without the lock around msgspec, about
one process in four crashed with a segfault in msgspec's decoder (a struct's type information read half-built),
as a controller manager did when four trajectory controllers received their first trajectories at once."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FIRST_DECODES_AT_ONCE = """
import sys, threading
sys.setswitchinterval(1e-6)   # hand the GIL over as often as possible
import msgs
from msgs import codec
JointTrajectory = msgs.get_type("trajectory_msgs/msg/JointTrajectory")
message = msgs.from_dict(JointTrajectory, {"joint_names": ["a"], "header": {"frame_id": "x"}, "points": [
    {"positions": [1.0], "velocities": [0.5], "time_from_start": {"sec": 1, "nanosec": 0}}]})
payload = msgs.encode(message)
start = threading.Barrier(8)
results = []

def decode_three() -> None:
    start.wait()
    results.extend(codec.decode(JointTrajectory, payload) == message for _ in range(3))

threads = [threading.Thread(target=decode_three) for _ in range(8)]
for thread in threads:
    thread.start()
for thread in threads:
    thread.join()
print(len(results), all(results))
"""


def test_first_decodes_from_eight_threads_at_once_never_crash_and_decode_right() -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    for _batch in range(6):   # 24 fresh processes, 4 at a time
        children = [subprocess.Popen([sys.executable, "-c", FIRST_DECODES_AT_ONCE], cwd=ROOT, env=env,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(4)]
        for child in children:
            out, err = child.communicate(timeout=60)
            assert child.returncode == 0, f"exit {child.returncode} (-11: segfault): {err[-2000:]}"
            assert out.split() == ["24", "True"]
