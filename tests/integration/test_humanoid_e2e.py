"""The main job end to end, as a user's own program sees it: ``python -m launch humanoid.yaml`` headless,
observed by a subscriber written with zenoh-python and msgpack alone (no project imports)."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import msgpack
import pytest
import zenoh

from bench.common import Launch, alive

HUMANOID_JOINTS = {
    "left_hip_yaw", "left_hip_roll", "left_hip_pitch", "left_knee", "left_ankle_pitch", "left_ankle_roll",
    "right_hip_yaw", "right_hip_roll", "right_hip_pitch", "right_knee", "right_ankle_pitch", "right_ankle_roll",
    "waist_yaw", "neck_pitch", "left_shoulder_pitch", "left_shoulder_roll", "left_shoulder_yaw", "left_elbow",
    "right_shoulder_pitch", "right_shoulder_roll", "right_shoulder_yaw", "right_elbow",
}
STANDING_PELVIS_HEIGHT = 0.910  # robots/humanoid.urdf: soles flat on the ground at the zero pose
TOLERANCE = 0.05


class Observer:
    """Collects knee angles from humanoid/joint_states and the pelvis height from sim/model_states."""

    def __init__(self, session: zenoh.Session) -> None:
        self.lock = threading.Lock()
        self.first_joint_states: float | None = None
        self.joint_names: set[str] = set()
        self.knees: dict[str, list[float]] = {"left_knee": [], "right_knee": []}
        self.pelvis_z: list[float] = []
        self.bad: list[str] = []
        self.subs = [session.declare_subscriber("humanoid/joint_states", self.on_joint_states),
                     session.declare_subscriber("sim/model_states", self.on_model_states)]

    def on_joint_states(self, sample: zenoh.Sample) -> None:
        msg = msgpack.unpackb(sample.payload.to_bytes())
        with self.lock:
            if self.first_joint_states is None:
                self.first_joint_states = time.monotonic()
            if len(msg["name"]) != len(msg["position"]):
                self.bad.append(f"joint_states with {len(msg['name'])} names, {len(msg['position'])} positions")
            self.joint_names.update(msg["name"])
            for knee, series in self.knees.items():
                if knee in msg["name"]:
                    series.append(msg["position"][msg["name"].index(knee)])

    def on_model_states(self, sample: zenoh.Sample) -> None:
        msg = msgpack.unpackb(sample.payload.to_bytes())
        if "humanoid" in msg["name"]:
            with self.lock:
                self.pelvis_z.append(msg["pose"][msg["name"].index("humanoid")]["position"]["z"])

    def close(self) -> None:
        for sub in self.subs:
            sub.undeclare()


def phases(series: list[float]) -> list[str]:
    """The series as runs of 'stand' (≈0) and 'bend' (≈0.4), in-between samples dropped."""
    runs: list[str] = []
    for q in series:
        label = "stand" if abs(q) <= TOLERANCE else "bend" if abs(q - 0.4) <= TOLERANCE else None
        if label and (not runs or runs[-1] != label):
            runs.append(label)
    return runs


def alternates(series: list[float]) -> bool:
    runs = phases(series)
    return "bend" in runs and len(runs) >= 3


@pytest.mark.slow
def test_humanoid_launch_end_to_end(zenoh_port: int, tmp_path: Path) -> None:
    started = time.monotonic()
    launch = Launch("humanoid.yaml", "mode:=lockstep", log_dir=tmp_path, port=zenoh_port)
    observer = None
    try:
        # The router lives in the launcher; a peer as any Zenoh program would write it connects once it listens.
        observer = Observer(launch.peer(30))

        deadline = started + 90  # generous: 5 other engineers share these 2 cores
        while time.monotonic() < deadline:
            launch.pids()
            with observer.lock:
                done = (observer.first_joint_states is not None and observer.pelvis_z
                        and all(alternates(s) for s in observer.knees.values()))
            if done:
                break
            launch.check()
            time.sleep(0.2)
        with observer.lock:
            first = observer.first_joint_states
            names = set(observer.joint_names)
            knees = {k: list(v) for k, v in observer.knees.items()}
            pelvis = list(observer.pelvis_z)
            bad = list(observer.bad)
        log = launch.output()
        assert first is not None, "no humanoid/joint_states at all:\n" + log
        assert first - started < 15.0, f"first joint_states after {first - started:.1f} s (limit 15 s)"
        assert names == HUMANOID_JOINTS, f"joints: missing {HUMANOID_JOINTS - names}, extra {names - HUMANOID_JOINTS}"
        assert not bad, bad
        for knee, series in knees.items():
            assert alternates(series), f"{knee} did not alternate 0 <-> 0.4: runs {phases(series)}"
        assert pelvis, "no sim/model_states entry for 'humanoid'"
        assert min(pelvis) > 0.9 * STANDING_PELVIS_HEIGHT, f"pelvis fell to {min(pelvis):.3f} m"
        assert "Sent command (pose 1)" in log
    finally:
        if observer is not None:
            observer.close()
        launch.pids()
        status = launch.close(timeout=10.0)
        stop_deadline = time.monotonic() + 10.0
        while time.monotonic() < stop_deadline and any(alive(p) for p in launch.seen_pids):
            time.sleep(0.05)
        survivors = [p for p in launch.seen_pids if alive(p)]
        for pid in survivors:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    assert len(launch.seen_pids) >= 5, f"expected the launcher and its nodes, saw {sorted(launch.seen_pids)}"
    assert not survivors, f"processes still alive 10 s after SIGINT: {survivors}\n{launch.output()}"
    assert status == 0, launch.output()
