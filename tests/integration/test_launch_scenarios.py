"""Each tutorial launch file, headless on a free port, produces its scenario's key output."""

from __future__ import annotations

import math
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path

import msgpack
import pytest
import zenoh

from bench.common import Launch, alive, wait_until


class Scenario(Launch):
    """``python -m launch FILE gui:=false zenoh_port:=N`` plus a plain Zenoh subscriber on some keys."""

    def __init__(self, tmp_path: Path, port: int, launch_file: str, *args: str) -> None:
        super().__init__(launch_file, *args, log_dir=tmp_path, port=port)
        self.lock = threading.Lock()
        self.samples: dict[str, list[dict]] = defaultdict(list)
        self.session: zenoh.Session | None = None

    def connect(self, *keys: str) -> None:
        self.session = self.peer(30)
        for key in keys:
            self.session.declare_subscriber(key, self._collector(key))

    def _collector(self, key: str) -> Callable[[zenoh.Sample], None]:
        def on_sample(sample: zenoh.Sample) -> None:
            msg = msgpack.unpackb(sample.payload.to_bytes())
            msg["_received"] = time.monotonic()  # wall arrival time (pacing checks)
            with self.lock:
                self.samples[key].append(msg)
        return on_sample

    def snapshot(self, key: str) -> list[dict]:
        with self.lock:
            return list(self.samples[key])

    def wait_for(self, predicate: Callable[[], bool], timeout: float, what: str) -> None:
        self.wait(lambda: self.pids() and predicate(), timeout, what, interval=0.1)

    def close(self) -> int:
        status = super().close()
        wait_until(lambda: not any(alive(p) for p in self.seen_pids), 10, "every process of the launch to end")
        return status


def positions(samples: list[dict], joint: str) -> list[float]:
    return [m["position"][m["name"].index(joint)] for m in samples if joint in m["name"]]


@pytest.mark.slow
def test_lab_2_3_four_limbs_oscillate(tmp_path: Path, zenoh_port: int) -> None:
    # The tutorial's realtime mode. In lockstep the four-joint robot runs many times faster than the wall
    # clock, and a commander that falls behind on a loaded machine stamps trajectories from a clock read
    # out of a backed-up link; the controller then rightly refuses them as ending in the past.
    with Scenario(tmp_path, zenoh_port, "lab_2_3.yaml") as scenario:
        scenario.connect("lab_robot/joint_states")
        limbs = {"left_arm_joint": 1.0, "right_arm_joint": 1.0, "left_leg_joint": 0.5, "right_leg_joint": 0.5}

        def swinging() -> bool:
            states = scenario.snapshot("lab_robot/joint_states")
            return all(len(q := positions(states, j)) > 10 and max(q) > 0.6 * a and min(q) < -0.6 * a
                       for j, a in limbs.items())

        scenario.wait_for(swinging, 60, "all four limbs to swing both ways")
        states = scenario.snapshot("lab_robot/joint_states")
        for joint, amplitude in limbs.items():
            q = positions(states, joint)
            assert max(abs(v) for v in q) <= amplitude + 0.05, f"{joint} overshot its ±{amplitude} wave"
        # The spawner activates the four controllers one service call after another; sim time runs on
        # between those calls, so the phase is judged on the samples that follow, once every limb is driven.
        first = len(states)
        scenario.wait_for(lambda: len(scenario.snapshot("lab_robot/joint_states")) > first + 200, 60,
                          "200 more joint_states")
        states = scenario.snapshot("lab_robot/joint_states")[first:]
        # arms in anti-phase: left ≈ -right at every sample
        left, right = positions(states, "left_arm_joint"), positions(states, "right_arm_joint")
        # (each limb has its own controller and message, so a sample may catch one a cycle ahead)
        mismatch = sorted(abs(a + b) for a, b in zip(left, right))
        assert mismatch[int(0.9 * len(mismatch))] < 0.05 and mismatch[-1] < 0.3, mismatch[-10:]
        out = scenario.output()
        assert "[robot_controller]" in out and "Left arm:" in out
        assert "=== Joint States ===" in out and "left_leg_joint: pos=" in out


@pytest.mark.slow
def test_controller_lab_joint1_reaches_1_57(tmp_path: Path, zenoh_port: int) -> None:
    with Scenario(tmp_path, zenoh_port, "controller_lab.yaml", "mode:=lockstep") as scenario:
        scenario.connect("simple_robot/joint_states")

        def goals_done() -> bool:
            return "Point trajectory execution completed" in scenario.output()

        scenario.wait_for(goals_done, 90, "the sine and point goals to finish")
        time.sleep(0.5)
        q = positions(scenario.snapshot("simple_robot/joint_states"), "joint1")
        assert len(q) > 20 and all(abs(v - 1.57) < 0.02 for v in q[-5:]), f"joint1 ends at {q[-5:]}"
        assert max(q) < 1.57 + 0.05, "joint1 overshot 1.57"
        assert min(q) < -1.4, "the sine wave's negative half never showed"
        out = scenario.output()
        assert "Sine trajectory execution completed: SUCCEEDED" in out
        assert "Point trajectory execution completed: SUCCEEDED" in out


@pytest.mark.slow
def test_joint_animation_atlas_follows_playback_without_gravity(tmp_path: Path, zenoh_port: int) -> None:
    with Scenario(tmp_path, zenoh_port, "joint_animation.yaml") as scenario:
        scenario.connect("atlas/joint_states", "sim/model_states", "sim/clock")

        def moved_through_the_wave() -> bool:
            q = positions(scenario.snapshot("atlas/joint_states"), "back_mby")
            return len(q) > 20 and max(q) > 0.45 and min(q) < -0.45

        scenario.wait_for(moved_through_the_wave, 90, "back_mby (x2) to swing through ±0.5")
        states = scenario.snapshot("atlas/joint_states")
        x1_joints = ["back_lbz", "l_leg_lhy", "r_arm_uwy", "l_arm_ely"]
        x2_joints = ["back_mby", "neck_ay", "l_leg_kny", "r_arm_elx"]
        moving = 0
        for m in states:
            q = dict(zip(m["name"], m["position"]))
            x2 = q["back_mby"]
            # every x2 joint equals x2, every x1 joint equals -0.5*sin(2θ) with sin θ = 2*x2
            assert all(abs(q[j] - x2) < 0.02 for j in x2_joints), q
            x1 = q["back_lbz"]
            assert all(abs(q[j] - x1) < 0.02 for j in x1_joints), q
            expected_abs_x1 = abs(2 * x2) * math.sqrt(max(0.0, 1 - 4 * x2 * x2))
            assert abs(abs(x1) - expected_abs_x1) < 0.03, (x1, x2)
            moving += abs(x2) > 0.1
        assert moving > 10
        z = [m["pose"][m["name"].index("atlas")]["position"]["z"] for m in scenario.snapshot("sim/model_states")
             if "atlas" in m["name"]]
        assert z and all(abs(v - 1.0) < 0.01 for v in z), "without gravity the pelvis stays where it was spawned"
        assert "ground_plane" not in {n for m in scenario.snapshot("sim/model_states") for n in m["name"]}
        # kinematic playback is paced at real_time_factor 1 like the tutorial (unpaced it ran ~10x)
        clock = scenario.snapshot("sim/clock")
        sim_span = (clock[-1]["clock"]["sec"] + clock[-1]["clock"]["nanosec"] * 1e-9
                    - clock[0]["clock"]["sec"] - clock[0]["clock"]["nanosec"] * 1e-9)
        wall_span = clock[-1]["_received"] - clock[0]["_received"]
        assert wall_span > 5 and sim_span / wall_span < 1.5, (sim_span, wall_span)


@pytest.mark.slow
def test_arm_viz_publishes_moving_tf(tmp_path: Path, zenoh_port: int) -> None:
    with Scenario(tmp_path, zenoh_port, "arm_viz.yaml", "frequency:=1.0") as scenario:
        scenario.connect("humanoid_simplified/tf", "humanoid_simplified/joint_states")

        def elbow_moves() -> bool:
            rotations = {tuple(round(v, 3) for v in t["transform"]["rotation"].values())
                         for m in scenario.snapshot("humanoid_simplified/tf") for t in m["transforms"]
                         if t["child_frame_id"] == "left_forearm"}
            return len(rotations) > 5

        scenario.wait_for(elbow_moves, 60, "the left forearm frame to move in tf")
        frames = {t["child_frame_id"] for m in scenario.snapshot("humanoid_simplified/tf") for t in m["transforms"]}
        assert {"left_upper_arm", "left_forearm", "left_hand", "right_upper_arm", "right_forearm",
                "right_hand"} <= frames


@pytest.mark.slow
def test_a_world_model_named_like_the_robot_ends_the_launch_naming_the_clash(tmp_path: Path, zenoh_port: int) -> None:
    """The robot could never be spawned into that world: the launch exits 1 at once instead of waiting for ever
    for a robot that is not there."""
    world = tmp_path / "clash.world"
    world.write_text("<?xml version='1.0'?><sdf version='1.7'><world name='clash'><model name='humanoid'>"
                     "<static>true</static><link name='l'><collision name='c'><geometry><box><size>1 1 1</size>"
                     "</box></geometry></collision></link></model></world></sdf>")
    launch = Launch("humanoid.yaml", f"world:={world}", log_dir=tmp_path, port=zenoh_port)
    try:
        status = launch.proc.wait(90)
    finally:
        launch.close()
    output = launch.output()
    assert status == 1, output[-3000:]
    assert f"world '{world}' has a model named 'humanoid', the name of an entity to spawn at start" in output
    assert "'simulator' refused its configuration (status 2)" in output
