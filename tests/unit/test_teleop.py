"""Keyboard teleop's model: selection, nudges inside the limits, zero pose, the trajectory it sends."""

from __future__ import annotations

import math

import pytest

from msgs import duration_to_sec
from nodes.tools.teleop import TeleopModel


def model() -> TeleopModel:
    return TeleopModel.create(["a", "knee", "free"], [0.1, 0.0, 3.0],
                              {"a": (-1.0, 1.0), "knee": (-0.05, 2.4)}, step=0.05)


def test_selection_wraps_and_nudges_move_the_selected_target_by_one_step():
    m = model()
    m.select(-1)
    assert m.selected == 2
    m.select(+2)
    assert m.selected == 1
    assert m.nudge(+1) and m.targets == [0.1, 0.05, 3.0]
    assert m.status == "knee -> +0.050 rad"
    msg = m.trajectory(0.2)
    assert msg.joint_names == ["a", "knee", "free"]
    assert msg.points[0].positions == [0.1, 0.05, 3.0] and duration_to_sec(msg.points[0].time_from_start) == 0.2


def test_nudges_stop_at_the_limits_and_say_so():
    m = model()
    m.selected = 1
    assert m.nudge(-1) and m.targets[1] == -0.05
    assert not m.nudge(-1) and m.targets[1] == -0.05
    assert m.status == "knee is at its lower limit -0.050 rad"
    m.targets[1] = 2.38
    assert m.nudge(+1) and m.targets[1] == 2.4 and m.status.endswith("(limit)")
    m.selected = 2                       # no limits known: free
    assert m.nudge(+1) and m.targets[2] == pytest.approx(3.05)


def test_zero_pose_is_clamped_into_the_limits_and_rows_show_targets_and_measured():
    m = TeleopModel.create(["a", "b"], [0.5, 0.5], {"a": (0.2, 1.0)}, step=0.1)
    m.zero()
    assert m.targets == [0.2, 0.0]
    m.measured = {"a": 0.2049, "b": -1e-9}
    rows = m.rows()
    assert rows[0].split() == [">", "a", "+0.205", "+0.200", "[+0.20,", "+1.00]"]
    assert rows[1].split() == ["b", "+0.000", "+0.000", "(no", "limits)"]
    assert not math.isnan(m.targets[1])


def test_teleop_needs_a_terminal_and_says_so():
    import subprocess
    import sys

    from tests.conftest import ROOT

    result = subprocess.run([sys.executable, "-m", "nodes.tools", "teleop", "--zenoh-port", "1"], cwd=ROOT,
                            stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "teleop needs a terminal" in result.stderr
    bad = subprocess.run([sys.executable, "-m", "nodes.tools", "teleop", "--step", "nan"], cwd=ROOT,
                         stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "--step must be a positive number" in bad.stderr
