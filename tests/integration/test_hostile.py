"""Hostile input at scale, reduced: ``bench/fuzz.py`` against the real main job (its regressions from
issue #13 plus ~2,000 random malformed payloads on every input, seeded), with the same checks: no crash, no
hang, nothing lost (robot standing, controllers, physics, entities, a valid trajectory followed), memory back
to its warmed-up level, every target and regression reported on rosout, the output bounded."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench import fuzz

pytestmark = pytest.mark.slow


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
