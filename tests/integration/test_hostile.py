"""Hostile input at scale, reduced: ``bench/fuzz.py`` against the real main job (its regressions from
issue #13 plus ~2,000 random malformed payloads on every input, seeded), with the same checks: no crash, no
hang, nothing lost (robot standing, controllers, physics, entities, a valid trajectory followed), memory back
to its warmed-up level, every target and regression reported on rosout, the output bounded."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench import fuzz

pytestmark = pytest.mark.slow


@pytest.mark.alone   # judged on each process's memory growth, which a CPU-starved job's backlog inflates
def test_reduced_fuzz_leaves_the_main_job_standing_and_every_rejection_logged(tmp_path: Path) -> None:
    report = fuzz.run(payloads=2000, seconds=90, seed=13, big=8, log_dir=tmp_path, progress=lambda _: None)
    summary = fuzz.table(report)
    assert report["tried"] >= 2000, summary
    kinds = report["target_kinds"]
    assert kinds.get("topic", 0) >= 5 and kinds.get("service", 0) >= 30, kinds
    assert kinds.get("ros2_topic", 0) >= 1 and kinds.get("ros2_service", 0) >= 10, kinds   # the ROS 2 wire
    assert report["crashes"] == 0, (report["dead"], report["restarted"])
    assert report["hangs"] == 0, (report["unanswered"], report["max_joint_states_silence_s"], report["replies"])
    assert not report["state_lost"], report["state_lost"]
    assert report["trajectory_followed"]
    assert not report["unlogged_targets"], report["unlogged_targets"]
    assert all(report["regressions_logged"].values()), report["regressions_logged"]
    assert not report["bad_error_replies"], report["bad_error_replies"]
    assert report["rosout_longest_chars"] < 3000 and report["longest_reply_bytes"] < 5000
    assert report["launch_output_mb"] < 5, "rejections flood the output (not rate-limited)"
    assert report["rss_ok"], summary


def test_a_control_cycle_that_never_ends_ends_the_controller_manager(processes, router, tmp_path: Path) -> None:
    """A controller stuck in update() wedges the hardware loop while every service still answers: the manager's
    watchdog ends the process (exit status 1) so that a launcher respawns it."""
    from tests.conftest import ROOT, wait_until
    from tests.integration.test_control_lab import Lab
    from tests.support.control import plugin_dir

    extra = tmp_path / "hanger.yaml"
    extra.write_text("controller_manager: {ros__parameters: {hanger: {type: test_controllers/HangingController}}}\n"
                     "hanger: {ros__parameters: {hang_after: 0.5}}\n")
    plugins = plugin_dir(tmp_path / "plugins", {"test_controllers/HangingController":
                                                "tests.support.control:HangingController"})
    lab = Lab(processes, router, activate=("joint_state_broadcaster", "joint_trajectory_controller"),
              manager_args=("--params-file", str(extra)),
              manager_env={"PYTHONPATH": f"{ROOT}:{plugins}"})
    try:
        assert lab.manager.poll() is None
        result = _cli_switch(router, "hanger")
        assert result.returncode == 0, result.stdout + result.stderr
        wait_until(lambda: lab.manager.poll() is not None, timeout=30, message="the stuck manager to exit")
        assert lab.manager.returncode == 1
        assert "a control cycle has not ended for" in processes.output(lab.manager)
    finally:
        lab.close()


def _cli_switch(router: str, name: str):  # noqa: ANN202 - a CompletedProcess
    import os
    import subprocess
    import sys

    from tests.conftest import ROOT

    env = dict(os.environ, ZENOH_CONNECT=router, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "nodes.tools", "control", "spawner", name, "--ns", "simple_robot"],
                          capture_output=True, text=True, env=env, timeout=60, cwd=ROOT)


def test_fuzz_classes_accumulation_and_include_fan_out_are_refused_well(tmp_path: Path) -> None:
    """``bench/fuzz.py``'s accumulation and fan-out classes against the real main job: every case refused with
    its limit named, and the job whole after each class (nothing restarted, joint_states and the camera on)."""
    from bench import fuzz_classes

    reports = fuzz_classes.run_classes(["accumulation", "fan-out"], tmp_path, progress=lambda _: None)
    summary = fuzz_classes.table(reports)
    assert [r.name for r in reports] == ["accumulation", "fan-out", "fan-out (world:=)"], summary
    for report in reports:
        assert report.outcomes and not report.broke, summary
