"""Seed 000's exercises as shipped launches, in lockstep with real processes: the squat commander on the
humanoid, and the 20-DOF variant whose 2 rad/s and 50 Nm limits hold while a too-fast trajectory runs."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import msgpack
import pytest

from tests.integration.test_launch_scenarios import Scenario

ROOT = Path(__file__).resolve().parents[2]
DEPTH = 0.785
ARM_JOINTS = [f"{side}_{j}" for side in ("left", "right")
              for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow")]
LEG_JOINTS = [f"{side}_{j}" for side in ("left", "right")
              for j in ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")]


def stamp(msg: dict) -> float:
    return msg["header"]["stamp"]["sec"] + msg["header"]["stamp"]["nanosec"] * 1e-9


def series(samples: list[dict], joint: str, field: str = "position") -> list[tuple[float, float]]:
    return [(stamp(m), m[field][m["name"].index(joint)]) for m in samples if joint in m["name"]]


def squat_peaks(knee: list[tuple[float, float]]) -> list[float]:
    """The deepest knee angle of each excursion above half the depth."""
    peaks: list[float] = []
    current: float | None = None
    for _, q in knee:
        if q > DEPTH / 2:
            current = q if current is None else max(current, q)
        elif current is not None:
            peaks.append(current)
            current = None
    return peaks


@pytest.mark.slow
def test_squat_three_cycles_balanced_and_a_too_deep_squat_is_refused(tmp_path: Path, zenoh_port: int) -> None:
    scenario = Scenario(tmp_path, zenoh_port, "humanoid.yaml", "mode:=lockstep", "commander:=squat")
    try:
        scenario.connect("humanoid/joint_states", "sim/model_states", "humanoid/humanoid_state",
                         "humanoid/joint_trajectory_controller/joint_trajectory", "rosout")

        def cycles_done() -> int:
            return len(squat_peaks(series(scenario.snapshot("humanoid/joint_states"), "left_knee")))

        scenario.wait_for(lambda: cycles_done() >= 3, 300, "three squat cycles")
        joint_states = scenario.snapshot("humanoid/joint_states")
        for knee in ("left_knee", "right_knee"):
            peaks = squat_peaks(series(joint_states, knee))
            assert len(peaks) >= 3
            assert all(abs(p - DEPTH) <= 0.02 for p in peaks[:3]), (knee, peaks)
        end = series(joint_states, "left_knee")[-1][0]

        # the pelvis goes down and comes back up each cycle, and never falls
        # (sim/model_states carries no stamp: take the samples received after the first squat was sent)
        first_sent = scenario.snapshot("humanoid/joint_trajectory_controller/joint_trajectory")[0]["_received"]
        settled = [(m["_received"], m["pose"][m["name"].index("humanoid")]["position"]["z"])
                   for m in scenario.snapshot("sim/model_states") if "humanoid" in m["name"]
                   and m["_received"] >= first_sent]
        heights = [z for _, z in settled]
        assert min(heights) > 0.8, "the robot fell"
        assert min(heights) < 0.87 and max(heights) > 0.9       # 0.91 standing, ~0.855 at the bottom
        lows = highs = 0
        low = False
        for _, z in settled:
            if not low and z < 0.87:
                low, lows = True, lows + 1
            elif low and z > 0.9:
                low, highs = False, highs + 1
        assert lows >= 3 and highs >= 2                          # down and back up, cycle after cycle

        # balanced the whole time (once the robot has landed from its spawn height)
        states = [m for m in scenario.snapshot("humanoid/humanoid_state") if 0.5 <= stamp(m) <= end]
        assert len(states) > 100
        unbalanced = [(round(stamp(m), 3), m["zmp_x"], len(m["support_polygon"])) for m in states
                      if not m["is_balanced"]]
        assert not unbalanced, unbalanced

        # every trajectory it sent: positions + velocities, within the knee limit
        sent = scenario.snapshot("humanoid/joint_trajectory_controller/joint_trajectory")
        assert len(sent) >= 3
        knee = sent[0]["joint_names"].index("left_knee")
        assert all(p["velocities"] and p["positions"][knee] <= DEPTH + 1e-9 for m in sent for p in m["points"])
        before = len(sent)

        # a depth beyond the knee's 2.4 rad limit is refused, naming the joint, before anything is sent
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        env.pop("ZENOH_CONNECT", None)
        refused = subprocess.run(
            [sys.executable, "-m", "nodes.commanders.squat", "--ns", "humanoid", "--name", "deep_squat",
             "--param", "depth:=2.6", "--zenoh-port", str(zenoh_port)],
            cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
        assert refused.returncode == 2, refused.stdout + refused.stderr
        assert "joint 'left_knee' would reach 2.6 rad (squat), above its upper limit 2.4 rad" in refused.stderr
        time.sleep(1.0)
        logged = [m["msg"] for m in scenario.snapshot("rosout") if m["name"].endswith("deep_squat")]
        assert any("squat refused" in line and "left_knee" in line for line in logged), logged
        # the same depth set live on the running squat: refused with the reason, the squat goes on unchanged
        live = subprocess.run(
            [sys.executable, "-m", "nodes.tools", "param", "set", "/humanoid/squat", "depth", "2.6",
             "--zenoh-port", str(zenoh_port)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
        assert live.returncode == 1 and "left_knee" in live.stdout and "upper limit 2.4" in live.stdout, live
        got = subprocess.run(
            [sys.executable, "-m", "nodes.tools", "param", "get", "/humanoid/squat", "depth",
             "--zenoh-port", str(zenoh_port)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
        assert got.stdout.splitlines()[0] == "0.785", got
        after = scenario.snapshot("humanoid/joint_trajectory_controller/joint_trajectory")
        assert all(p["positions"][knee] <= DEPTH + 1e-9 for m in after[before:] for p in m["points"])
    finally:
        scenario.close()


@pytest.mark.slow
def test_20dof_variant_holds_2_rad_s_and_50_nm_while_a_too_fast_trajectory_runs(tmp_path: Path,
                                                                                 zenoh_port: int) -> None:
    scenario = Scenario(tmp_path, zenoh_port, "humanoid_20dof.yaml", "mode:=lockstep", "commander:=none")
    ns = "humanoid_20dof"
    try:
        scenario.connect(f"{ns}/joint_states", f"{ns}/hardware/state", "sim/model_states", "rosout")
        scenario.wait_for(lambda: "Configured and activated joint_trajectory_controller" in scenario.output(),
                          120, "the trajectory controller")
        scenario.wait_for(lambda: len(scenario.snapshot(f"{ns}/joint_states")) > 10, 60, "joint_states")
        names = scenario.snapshot(f"{ns}/joint_states")[-1]["name"]
        assert sorted(names) == sorted(LEG_JOINTS + ARM_JOINTS)       # the 20 commanded joints, no waist/neck

        # arms swung 1.5 rad in 0.1 s (15 rad/s asked) and a knee bend in 0.05 s: far past 2 rad/s
        targets = {"left_shoulder_pitch": -1.5, "right_shoulder_pitch": -1.5, "left_elbow": -1.2,
                   "right_elbow": -1.2, "left_hip_pitch": -0.2, "left_knee": 0.4, "left_ankle_pitch": -0.2,
                   "right_hip_pitch": -0.2, "right_knee": 0.4, "right_ankle_pitch": -0.2}
        start = len(scenario.snapshot(f"{ns}/hardware/state"))
        scenario.session.put(f"{ns}/joint_trajectory_controller/joint_trajectory", msgpack.packb({
            "joint_names": list(targets),
            "points": [{"positions": list(targets.values()), "time_from_start": {"sec": 0, "nanosec": 100_000_000}}],
        }))
        scenario.wait_for(lambda: "slowed down" in scenario.output(), 60, "the controller's slow-down warning")
        assert "joint 'left_shoulder_pitch' would need 15 rad/s, its velocity limit is 2 rad/s" in scenario.output()

        def arrived() -> bool:
            last = scenario.snapshot(f"{ns}/joint_states")[-1]
            return abs(last["position"][last["name"].index("left_shoulder_pitch")] + 1.5) < 0.05
        scenario.wait_for(arrived, 120, "the arms at the target")
        time.sleep(1.0)
        frames = scenario.snapshot(f"{ns}/hardware/state")[start:]
        assert len(frames) > 500
        velocity = max(abs(v) for f in frames for v in f["velocity"])
        effort = max(abs(e) for f in frames for e in f["effort"])
        assert velocity <= 2.0 + 1e-9, velocity
        assert effort <= 50.0 + 1e-9, effort
        assert velocity > 1.9 and effort > 45.0        # the limits were reached, not just stayed clear of
        # 1.5 rad at 2 rad/s takes 0.75 s of sim time, not the 0.1 s asked
        shoulder = [(f["stamp"]["sec"] + f["stamp"]["nanosec"] * 1e-9, f["position"][f["name"].index("left_shoulder_pitch")]) for f in frames]
        t_start = next(t for t, q in shoulder if q < -0.05)
        t_end = next(t for t, q in shoulder if q < -1.45)
        assert t_end - t_start > 0.6
        pelvis = [m["pose"][m["name"].index(ns)]["position"]["z"] for m in scenario.snapshot("sim/model_states")
                  if ns in m["name"]]
        assert pelvis[-1] > 0.8, "the 20-DOF humanoid fell"
    finally:
        scenario.close()
