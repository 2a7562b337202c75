"""The node logger: identical lines collapse, floods from one place are rate-limited, huge lines are cut."""

from __future__ import annotations

import time

import pytest

from nodes.core import log
from nodes.core.log import Logger, parse_level


def _sink_logger(level: str = "debug") -> tuple[Logger, list[tuple[int, str]]]:
    lines: list[tuple[int, str]] = []
    logger = Logger("t", level, sink=lambda lvl, name, msg, wall: lines.append((lvl, msg)))
    return logger, lines


def test_identical_lines_collapse_and_report_the_count(capsys) -> None:
    logger, lines = _sink_logger()
    for _ in range(65):  # lab_2_3's "preempted" flood: 65 identical INFO lines in a second
        logger.info("trajectory stopped: preempted by a new trajectory")
    assert len(lines) == log.REPEAT_BURST
    out = capsys.readouterr().out
    assert out.count("preempted") == log.REPEAT_BURST
    time.sleep(log.REPEAT_PERIOD * 1.1)
    logger.info("trajectory stopped: preempted by a new trajectory")
    assert len(lines) == log.REPEAT_BURST + 1
    assert f"({65 - log.REPEAT_BURST} identical lines suppressed in" in lines[-1][1]
    logger.info("another line")  # other text is not affected
    assert lines[-1] == (20, "another line")


def test_errors_from_one_place_are_rate_limited_even_when_their_text_varies() -> None:
    logger, lines = _sink_logger()

    def reject(joint: str) -> None:  # one call site
        logger.error(f"trajectory rejected: unknown joint '{joint}'")

    for i in range(200):
        reject(f"j{i}")
    assert len(lines) == log.SITE_BURST
    for i in range(5):  # info lines with varying text from one place are not limited (a 2 Hz status line)
        logger.info(f"left arm: {i}")
    assert len(lines) == log.SITE_BURST + 5
    time.sleep(1.0 / log.SITE_RATE * 1.5)
    reject("last")
    assert "similar lines from the same place suppressed" in lines[-1][1]


def test_throttled_lines_per_endpoint_are_each_shown_past_the_site_budget(capsys) -> None:
    """A node with more endpoints than the site budget (the simulator's ROS 2 services under a fuzz): each
    endpoint's throttled rejection line shows; the same lines through the site budget lose the last ones."""
    logger, lines = _sink_logger()
    endpoints = [f"/simulator/service_{i}" for i in range(log.SITE_BURST + 10)]
    for name in endpoints:   # one call site, one key per endpoint
        logger.warn_throttle(5.0, f"ROS 2 wire: bad request on {name}: garbage", key=name, per_site=False)
    assert [text.split(": ")[1] for _, text in lines] == [f"bad request on {n}" for n in endpoints]
    budgeted, shown = _sink_logger()
    for name in endpoints:
        budgeted.warn_throttle(5.0, f"ROS 2 wire: bad request on {name}: garbage", key=name)
    assert len(shown) == log.SITE_BURST
    capsys.readouterr()


def test_absurdly_long_lines_are_truncated(capsys) -> None:
    logger, lines = _sink_logger()
    huge = "unknown joint '" + "x" * 10_000_000 + "'"  # a 10 MB name in a bad message
    logger.error(huge)
    (level, text), = lines
    assert level == 40 and len(text) < log.MAX_CHARS + 100
    assert text.endswith(f"… ({len(huge) - log.MAX_CHARS} more characters)")
    assert len(capsys.readouterr().err) < log.MAX_CHARS + 200


def test_level_changes_at_run_time() -> None:
    logger, lines = _sink_logger("info")
    logger.debug("hidden")
    logger.set_level("debug")
    logger.debug("shown")
    assert lines == [(10, "shown")] and logger.level_name == "debug"
    assert parse_level("WARN") == parse_level(30) == 30
    with pytest.raises(ValueError, match="unknown log level"):
        parse_level("loud")
